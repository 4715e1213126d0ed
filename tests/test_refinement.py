"""The input response at a stage force's state, refined with kept factors (core/engine/
refinement.py), against numpy's dense solve of the same system at that state.

After a stage force in mass form the slots hold a state whose augmented system A = [M_ff
J_o^T; J_o 0] is not assembled; the response solves A d = b there by iterative refinement
with the factors of an earlier state. The reference: A assembled at the current state as
`motion.evaluate` assembles it (tests/test_inertia_product.py's `assembled`, read out of its
sparse or band storage) and solved by numpy for the response's right-hand side b (T^T B du;
0), which the refinement leaves in its slot. Models on the sparse Newton path by default:
manipulator_control (75 DOFs, rigid clusters, A sparse) and the 16-BEAM spatial cantilever
with a force and a moment input at its tip (96 DOFs, no clusters, A banded). The product it
is made of, -M_ff w without the mass, against the assembled mass block on those and on
models with folded clusters and with gravity.
"""

import numpy as np
import pytest
from test_engine import close, random_states, scene_with_gravity
from test_inertia_product import assembled, dense_augmented
from test_rigid_inertia import massive_manipulator

from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import Mechanics, build_model, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.engine.factors import KEPT_BANDED, KEPT_NONE, KEPT_SPARSE
from flexure.core.engine.inertia_product import minus_mass_product
from flexure.core.engine.operations import OP_STAGE_FORCE
from flexure.core.engine.refinement import MAX_PRODUCTS


def loaded_cantilever(n=16, length=0.2):
    """`spatial_cantilever(n)` (a steel strip of n BEAMs, every deformation a DOF) with a
    force input along z and a moment input about x at its tip instead of the 1 N load."""
    from examples.benchmarks.spatial import cantilever_spec

    spec = cantilever_spec(n, length=length, name=f"loaded_cantilever_{n}")
    spec["inputs"] = {"F": {"node": str(n), "coordinate": "z"},
                      "M": {"node": f"{n}r", "coordinate": "rx"}}
    return build_model(spec)


NEWTON_MODELS = {"manipulator_control": (lambda: load_scene("manipulator_control"), KEPT_SPARSE),
                 "cantilever_16": (loaded_cantilever, KEPT_BANDED)}


def packed(name):
    """(model, data, y0, u0) on the sparse Newton path, y0 = [q - q_ref, qdot] a random
    moving state about the scene's (`random_states`)."""
    make, _ = NEWTON_MODELS[name]
    model = make()
    data = EngineData(model, augmented=True)
    assert data.int_array("dims")[ed.NEWTON_SPARSE] == 1
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    (q, qdot, u0), = random_states(model, q0, seed=41, count=1)
    return model, data, np.concatenate([q - data.float_array("q_ref"), qdot]), u0


def stage_force(data, y, u):
    """A stage force at y with inputs u: the slots at y, A neither assembled nor factored."""
    n = y.size // 2
    data.float_array("inputs")[:] = u
    assert engine.call(data, OP_STAGE_FORCE, y, np.zeros(n), np.zeros(n)) == ed.OK
    assert data.int_array("dims")[ed.A_FACTORS] == ed.A_AT_STAGE


def response(data, u):
    """d qddot (m/s^2, rad/s^2) for the inputs u against the last stage force's."""
    data.float_array("inputs")[:] = u
    out = np.full(data.int_array("dims")[ed.NDOF], np.nan)
    assert engine.call(data, engine.OP_INPUT_RESPONSE, out) == ed.OK
    return out


def rhs(data, y, u):
    """qddot of the full rhs at y with inputs u."""
    data.float_array("inputs")[:] = u
    ydot = np.zeros_like(y)
    assert engine.call(data, engine.OP_RHS, y, ydot) == ed.OK
    return ydot[y.size // 2:]


def numpy_solution(data):
    """(d, numpy's A^-1 b) on the free coordinates' accelerations: the response's solution
    and right-hand side as it left them, A assembled at the slots' state."""
    dims = data.int_array("dims")
    nx, nf, na = dims[ed.NX], dims[ed.NFREE], dims[ed.NFREE] + dims[ed.NRIGID]
    d = data.float_array("augmented_rhs")[:na].copy()
    b = data.float_array("refinement")[:na].copy()
    assembled(data.address, True, np.zeros(nx), np.zeros(nx), np.zeros(nf))
    return d[:nf], np.linalg.solve(dense_augmented(data), b)[:nf]


def counted(data):
    """(refined responses, their products, responses that factored A) so far."""
    counters = data.int_array("counters")
    return (counters[ed.REFINED_RESPONSES], counters[ed.REFINEMENT_PRODUCTS],
            counters[ed.RESPONSE_FACTORS])


@pytest.mark.parametrize("name", sorted(NEWTON_MODELS))
def test_factors_several_states_back_refine_to_numpys_solve(name):
    """The first response after a stage force factors A there (no factors kept yet); five
    states further along a straight path (1e-7 m or rad a state on every DOF, about the
    6 mm move's motion in 0.1 ms), the response refines with those factors in two or three
    products, takes no factorisation, and its accelerations equal numpy's dense solve at the
    new state to 1e-11 of their largest (the refinement's tolerance 1e-12 and the dense
    LU's round-off, A's condition being 8e4 on the manipulator; measured 7.5e-13 on the
    manipulator, 2.2e-15 on the cantilever), and qddot(u1) - qddot(u0) of two full rhs there
    to 1e-12 of qddot (tests/test_input_response.py's bound; measured 1.3e-15, 7e-14)."""
    model, data, y0, u0 = packed(name)
    dims = data.int_array("dims")
    assert dims[ed.A_KEPT] == KEPT_NONE
    stage_force(data, y0, u0)
    response(data, u0 + 1.0)
    assert counted(data)[2] == 1 and dims[ed.A_KEPT] == NEWTON_MODELS[name][1]
    rng = np.random.default_rng(42)
    n = y0.size // 2
    direction = np.concatenate([rng.standard_normal(n), np.zeros(n)])
    y = y0 + 5 * 1e-7 * direction
    stage_force(data, y, u0)
    before = counted(data)
    u1 = u0 + rng.standard_normal(u0.size)
    change = response(data, u1)
    refined, products, factored = (a - b for a, b in zip(counted(data), before, strict=True))
    assert (refined, factored) == (1, 0) and 2 <= products <= MAX_PRODUCTS
    d, expected = numpy_solution(data)
    close(d, expected, 1e-11)
    before_qddot, after_qddot = rhs(data, y, u0), rhs(data, y, u1)
    size = max(np.max(np.abs(before_qddot)), np.max(np.abs(after_qddot)))
    close(change, after_qddot - before_qddot, 1e-12, scale=size)


@pytest.mark.parametrize("name", sorted(NEWTON_MODELS))
def test_factors_of_a_far_state_are_refactored(name):
    """Kept factors from a state 1e-3 (m or rad on every DOF, random) away contract too
    slowly: the response factors A at the current state instead, exact to the dense LU's
    round-off against numpy (1e-11 of the largest acceleration), and the factors it made
    are kept."""
    model, data, y0, u0 = packed(name)
    stage_force(data, y0, u0)
    response(data, u0 + 1.0)
    rng = np.random.default_rng(43)
    n = y0.size // 2
    y = y0.copy()
    y[:n] += 1e-3 * rng.standard_normal(n)
    stage_force(data, y, u0)
    before = counted(data)
    response(data, u0 - 1.0)
    refined, _, factored = (a - b for a, b in zip(counted(data), before, strict=True))
    assert (refined, factored) == (0, 1)
    assert data.int_array("dims")[ed.A_KEPT] == NEWTON_MODELS[name][1]
    d, expected = numpy_solution(data)
    close(d, expected, 1e-11)


MASS_MODELS = {
    "manipulator_control": lambda: load_scene("manipulator_control"),
    "manipulator_massive": massive_manipulator,
    "cantilever_16": lambda: spatial_cantilever(16),
    "stage_planar_3dof_gravity": lambda: scene_with_gravity("stage_planar_3dof", [0.0, -9.81]),
}


@pytest.mark.parametrize("name", sorted(MASS_MODELS))
def test_the_mass_product_is_the_assembled_mass_block(name):
    """minus_mass_product(w) = -A_ff w for the mass block A_ff assembled at the state of an
    evaluation (moving, random inputs), for random w, to 1e-13 of max |A_ff| |w| (the same
    products in another order; with folded clusters their operation's gravity added and taken
    off), with and without gravity on the element masses."""
    model = MASS_MODELS[name]()
    data = EngineData(model, augmented=True)
    dims = data.int_array("dims")
    nx, nf = dims[ed.NX], dims[ed.NFREE]
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    rng = np.random.default_rng(44)
    for q, qdot, u in random_states(model, q0, seed=45):
        data.float_array("inputs")[:] = u
        assert engine.call(data, engine.OP_ACCELERATIONS, q, qdot) == ed.OK
        assembled(data.address, True, np.zeros(nx), np.zeros(nx), np.zeros(nf))
        mass = dense_augmented(data)[:nf, :nf]
        for _ in range(2):
            w = rng.standard_normal(nf)
            out = np.full(nf, np.nan)
            minus_mass_product(data.address, w, np.zeros(nx), np.zeros(nx), out)
            close(out, -mass @ w, 1e-13, scale=np.max(np.abs(mass) @ np.abs(w)))

