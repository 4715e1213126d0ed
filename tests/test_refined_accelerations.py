"""An evaluation's accelerations refined with kept factors (core/engine/refined_accelerations.py)
against the plain path: the same packing with its kept factors dropped, which assembles and
factors the augmented system A = [M_ff J_o^T; J_o 0] at the state, and numpy's dense solve of
that assembled A for the right-hand side the refinement leaves in its slot.

Models with rigid clusters on the sparse Newton path: manipulator_control (massless rigid
beams) and its massive variant (every cluster folded into a rigid body, whose forces and mass
come from their own operation). The states: a random moving state about the scene's
(tests/test_engine.py's `random_states`), and one five steps of 1e-7 (m or rad on every DOF)
further along a straight path with other velocities, about the 6 mm move's motion in 0.1 ms.
"""

import numpy as np
import pytest
from test_engine import close, random_states
from test_inertia_product import dense_augmented
from test_rigid_inertia import massive_manipulator

from flexure.core import Mechanics, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.engine.factors import KEPT_NONE, KEPT_SPARSE

MODELS = {"manipulator_control": lambda: load_scene("manipulator_control"),
          "manipulator_massive": massive_manipulator}


def packed(name, seed=51):
    """(data, y0, y1, u0): the model packed in the augmented form, y0 a random moving state,
    y1 five steps of 1e-7 along a random direction from it, with velocities 1 % changed."""
    model = MODELS[name]()
    data = EngineData(model, augmented=True)
    dims = data.int_array("dims")
    assert dims[ed.NEWTON_SPARSE] == 1 and dims[ed.NSLAVES] > 0
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    (q, qdot, u0), = random_states(model, q0, seed=seed, count=1)
    y0 = np.concatenate([q - data.float_array("q_ref"), qdot])
    rng = np.random.default_rng(seed + 1)
    n = q.size
    y1 = y0 + np.concatenate([5e-7 * rng.standard_normal(n), 0.01 * qdot * rng.random(n)])
    return data, y0, y1, u0


def rhs(data, y, u):
    """(qddot, A_FACTORS after it) of the full rhs at y with the inputs u."""
    data.float_array("inputs")[:] = u
    ydot = np.full_like(y, np.nan)
    assert engine.call(data, engine.OP_RHS, y, ydot) == ed.OK
    return ydot[y.size // 2:], data.int_array("dims")[ed.A_FACTORS]


def plain(data, y, u):
    """(qddot, slot force, slot xddot, A's dense matrix) of the rhs at y with the kept
    factors dropped: A assembled and factored there."""
    data.int_array("dims")[ed.A_KEPT] = KEPT_NONE
    qddot, factors = rhs(data, y, u)
    assert factors == ed.SPARSE_FACTORS
    return (qddot, data.float_array("force").copy(), data.float_array("xddot").copy(),
            dense_augmented(data))


@pytest.mark.parametrize("start", ["warm", "cold"])
@pytest.mark.parametrize("name", sorted(MODELS))
def test_refined_rhs_equals_the_plain_path_and_numpys_solve(name, start):
    """The rhs at y1 with the factors kept from y0 is refined (A of no state after it), from
    the solution at y0 (warm) or, that solution overwritten, from A_kept^-1 b (cold), and
    equals the plain path's there: qddot and xddot to 1e-11 of their largest (the
    tolerance 1e-12 on z and the direct LU's round-off; measured 1e-15 to 1e-14), r with the
    element masses' forces (slot force, which the tangent reads) to 1e-13 of its largest
    (the same sums in another order). Cold, the accelerations on z it returned equal numpy's
    dense solve of A assembled at y1 for the b it formed, to 1e-11."""
    data, y0, y1, u0 = packed(name)
    dims = data.int_array("dims")
    nf, na = dims[ed.NFREE], dims[ed.NFREE] + dims[ed.NRIGID]
    _, factors = rhs(data, y0, u0)
    assert factors == ed.SPARSE_FACTORS and dims[ed.A_KEPT] == KEPT_SPARSE
    if start == "cold":  # as a stage force or an input response would leave it
        data.float_array("augmented_rhs")[:] = 0.0
    qddot, factors = rhs(data, y1, u0)
    assert factors == ed.A_AT_STAGE
    force, xddot = data.float_array("force").copy(), data.float_array("xddot").copy()
    d = data.float_array("augmented_rhs")[:na].copy()
    b = data.float_array("refinement")[:na].copy()
    plain_qddot, plain_force, plain_xddot, A = plain(data, y1, u0)
    close(qddot, plain_qddot, 1e-11)
    close(xddot, plain_xddot, 1e-11)
    close(force, plain_force, 1e-13)
    if start == "cold":
        close(d[:nf], np.linalg.solve(A, b)[:nf], 1e-11)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_kept_factors_of_a_far_state_are_replaced(name):
    """Factors kept from a state 1e-3 (m or rad on every DOF) away contract too slowly: the
    rhs assembles and factors A at its state instead (its factors current after it, and
    kept), equal to the plain path to 1e-11 of the largest acceleration."""
    data, y0, _, u0 = packed(name)
    rhs(data, y0, u0)
    n = y0.size // 2
    y = y0.copy()
    y[:n] += 1e-3 * np.random.default_rng(53).standard_normal(n)
    qddot, factors = rhs(data, y, u0)
    assert factors == ed.SPARSE_FACTORS
    assert data.int_array("dims")[ed.A_KEPT] == KEPT_SPARSE
    close(qddot, plain(data, y, u0)[0], 1e-11)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_input_response_after_a_refined_rhs(name):
    """After a refined rhs the input response solves A at its state by refinement too, and
    equals the difference of two refined rhs there, qddot(u1) - qddot(u0), to 1e-12 of
    qddot (tests/test_refinement.py's bound)."""
    data, y0, y1, u0 = packed(name)
    rhs(data, y0, u0)
    before, factors = rhs(data, y1, u0)
    assert factors == ed.A_AT_STAGE
    u1 = u0 + np.random.default_rng(54).standard_normal(u0.size)
    data.float_array("inputs")[:] = u1
    change = np.full(before.size, np.nan)
    assert engine.call(data, engine.OP_INPUT_RESPONSE, change) == ed.OK
    after, _ = rhs(data, y1, u1)
    size = max(np.max(np.abs(before)), np.max(np.abs(after)))
    close(change, after - before, 1e-12, scale=size)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_the_tangent_after_a_refined_rhs(name):
    """OP_JACOBIAN (an rhs, then the tangent on what it left in the slots: r, xdot, conv,
    xddot) at y1 with the factors kept from y0 equals it with none kept (A factored at y1),
    to 1e-10 of its largest entry (the accelerations' 1e-12 through the tangent's
    products)."""
    data, y0, y1, u0 = packed(name)
    data.float_array("inputs")[:] = u0
    n = y1.size
    rhs(data, y0, u0)
    refined = np.full(n * n, np.nan)
    assert engine.call(data, engine.OP_JACOBIAN, y1, refined) == ed.OK
    assert data.int_array("dims")[ed.A_FACTORS] == ed.A_AT_STAGE
    data.int_array("dims")[ed.A_KEPT] = KEPT_NONE
    direct = np.full(n * n, np.nan)
    assert engine.call(data, engine.OP_JACOBIAN, y1, direct) == ed.OK
    assert data.int_array("dims")[ed.A_FACTORS] == ed.SPARSE_FACTORS
    close(refined, direct, 1e-10)


def test_repeated_rhs_at_one_state_is_the_plain_one():
    """The rhs asked twice at one state (what the benchmark's rhs cost measures): the second
    refines with the first's factors, made at that very state, in one product, and equals
    the first to 1e-13 of the largest acceleration (measured 4.5e-16)."""
    data, y0, _, u0 = packed("manipulator_control")
    first, factors = rhs(data, y0, u0)
    assert factors == ed.SPARSE_FACTORS
    second, factors = rhs(data, y0, u0)
    assert factors == ed.A_AT_STAGE
    close(second, first, 1e-13)
