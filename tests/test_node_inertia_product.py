"""The node inertias' point products in closed form (`core/engine/node_inertia_product.py`,
group field node_inertia): the kernel against the numpy points of `rotary_inertia` and the
plain formula Dp^T Mp (g - (D2p v) v - Dp a); packing marks exactly the node inertias' groups;
and the engine's right-hand side and Jacobian with the closed form are bitwise those of the
general point kernel (the field cleared) on manipulator_control, with and without its rigid
clusters eliminated.
"""

import numpy as np
import pytest

from flexure.core import Mechanics, load_scene
from flexure.core.elements import rotary_inertia
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.engine.node_inertia_product import node_point_products


def plain(kernel):
    return getattr(kernel, "py_func", kernel)


@pytest.mark.parametrize("moving", [True, False])
def test_the_closed_form_is_the_plain_formula(moving):
    """Both products (at a and at a = 0) of random bodies at random Euler parameters (off
    the unit norm too), against Dp^T Mp (g - (D2p v) v - Dp a) with the points of
    `rotary_inertia.inertia_points`, to 1e-13 of the largest term."""
    rng = np.random.default_rng(11)
    for _ in range(5):
        A = rng.standard_normal((3, 3))
        J = A @ A.T + np.eye(3)
        (s,), (axes,) = rotary_inertia.point_masses(J[None])
        Mp = np.kron(np.diag(s), np.eye(3))
        lam, v, a = rng.standard_normal(4), rng.standard_normal(4), rng.standard_normal(4)
        gravity = rng.standard_normal(9)  # zero in the models; the kernel must carry it
        ref = rotary_inertia.pack_reference({"axes": axes[None]})[0]
        out_a, out_0 = np.full(4, np.nan), np.full(4, np.nan)
        plain(node_point_products)(ref, lam, v, moving, True, gravity, Mp.ravel(), a, out_a,
                                   out_0, True)
        _, Dp, D2p = rotary_inertia.inertia_points(lam[None], {"axes": axes[None]})
        Dp, D2p = Dp[0], D2p[0]
        acc = np.einsum("pij,i,j->p", D2p, v, v) if moving else np.zeros(9)
        at_rest = Dp.T @ Mp @ (gravity - acc)
        expected = Dp.T @ Mp @ (gravity - acc - Dp @ a)
        scale = np.max(np.abs(Dp)) ** 2 * np.max(np.abs(Mp)) * (
            np.max(np.abs(gravity)) + np.max(np.abs(acc)) + np.max(np.abs(Dp)) * 2.0)
        assert np.max(np.abs(out_a - expected)) <= 1e-13 * scale
        assert np.max(np.abs(out_0 - at_rest)) <= 1e-13 * scale


def test_packing_marks_the_node_inertias_groups():
    """manipulator_control: node_inertia on its node inertias' group (the one after the
    model's groups, 22 nodes) and on no other."""
    model = load_scene("manipulator_control")
    data = EngineData(model, augmented=True)
    dims = data.int_array("dims")
    groups = data.int_array("groups").reshape(-1, ed.G_WIDTH)[: dims[ed.NGROUPS]]
    flags = groups[:, ed.G_NODE_INERTIA]
    assert flags[: len(model.groups)].sum() == 0
    marked = np.flatnonzero(flags)
    assert marked.size == 1 and groups[marked[0], ed.G_COUNT] == 22
    assert groups[marked[0], ed.G_P] == 9 and groups[marked[0], ed.G_M] == 4


@pytest.mark.parametrize("rigid", [True, False])
def test_the_rhs_and_jacobian_are_the_general_kernels(rigid):
    """OP_RHS and OP_JACOBIAN at a state 1e-4 from the scene's DOFs with velocities 0.05 and
    inputs of 1: bitwise equal with the closed form and with the group field cleared."""
    model = load_scene("manipulator_control")
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    n = q0.size
    rng = np.random.default_rng(5)
    q, qdot = q0 + 1e-4 * rng.standard_normal(n), 0.05 * rng.standard_normal(n)
    results = []
    for closed in (True, False):
        data = EngineData(model, augmented=True, rigid=rigid)
        dims = data.int_array("dims")
        groups = data.int_array("groups").reshape(-1, ed.G_WIDTH)[: dims[ed.NGROUPS]]
        assert groups[:, ed.G_NODE_INERTIA].sum() == 1
        if not closed:
            groups[:, ed.G_NODE_INERTIA] = 0
        data.float_array("inputs")[:] = 1.0
        y = np.concatenate([q - data.float_array("q_ref"), qdot])
        ydot, jac = np.zeros(2 * n), np.zeros(4 * n * n)
        assert engine.call(data, engine.OP_RHS, y, ydot) == ed.OK
        assert engine.call(data, engine.OP_JACOBIAN, y, jac) == ed.OK
        results.append((ydot, jac))
    assert np.any(results[0][0] != 0.0)
    assert np.array_equal(results[0][0], results[1][0])
    assert np.array_equal(results[0][1], results[1][1])
