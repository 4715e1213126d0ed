"""The engine on its sparse LU path (core/engine/factors.py, sparse_packing.py) against the
plain-numpy twin, as tests/test_engine.py checks the banded path: kinematics, accelerations
and tangent on small scenes forced onto the sparse LU (default tier) and on the six-DOF
manipulator, which takes it by its cost (slow tier), at the initial and a displaced
configuration. Also: which models take which LU, and the banded fallback's count."""

import numpy as np
import pytest

from flexure.core import Mechanics, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine, factors
from flexure.core.engine.data import EngineData
from flexure.core.numerics import banded, sparse_lu
from tests.test_engine import (
    MODELS,
    close,
    evaluate,
    plain_dynamics,
    plain_tangent,
    random_states,
)
from tests.test_engine_status import truss_pendulum


def check_against_the_twin(model, mechanics, data, states, *, tangent_rtol=1e-10):
    """x and DF, qddot (backward error to 1e-14 of the force terms, as test_engine), M_bar
    and K, C of OP_TANGENT against the plain formulas at each (q, qdot, u)."""
    n, L = model.declared_dof_count, mechanics.kinematics.length_scale
    for q, qdot, u in states:
        assert engine.call(data, engine.OP_KINEMATICS, q) == ed.OK
        expected = mechanics.kinematics.solve(q, model.initial_coordinates.copy())
        close(data.float_array("x"), expected.x, 1e-14, scale=max(L, np.max(np.abs(expected.x))))
        close(data.float_array("DF").reshape(model.nx, n), expected.DF, 1e-12)
        qddot = evaluate(data, q, qdot, u)
        plain = plain_dynamics(model, mechanics, q, qdot, u)
        DF, mass = plain["config"].DF, plain["mass"]
        size = np.max(plain["size"])
        close(mass @ qddot, DF.T @ plain["r"], 1e-14, scale=size)
        close(data.float_array("mass").reshape(n, n), mass, 1e-12)
        assert engine.call(data, engine.OP_TANGENT, qddot.copy()) == ed.OK
        K, C = plain_tangent(mechanics, plain, qddot)
        close(data.float_array("stiffness").reshape(n, n), K, tangent_rtol)
        close(data.float_array("damping").reshape(n, n), C, tangent_rtol,
              scale=max(np.max(np.abs(C)), 1e-300))


SMALL = ["stage_spatial_19dof", "stage_planar_3dof_gravity", "stage_spatial_1dof_gravity"]


@pytest.mark.parametrize("name", SMALL)
@pytest.mark.parametrize("form", ["reduced", "augmented"])
def test_small_scenes_on_the_sparse_lu_match_the_plain_twin(name, form):
    model = MODELS[name]()
    mechanics = Mechanics(model)
    data = EngineData(model, augmented=form == "augmented", sparse=True)
    dims = data.int_array("dims")
    assert dims[ed.J_SPARSE] == dims[ed.A_SPARSE] == 1
    # J's band storage is there, untouched, for the fallback
    assert data.float_array("lu").size == banded.storage_size(dims[ed.NFREE], dims[ed.J_KL],
                                                              dims[ed.J_KU])
    q0 = mechanics.kinematics.dofs_of(model.initial_coordinates)
    check_against_the_twin(model, mechanics, data, random_states(model, q0, seed=11))
    assert data.int_array("counters")[ed.SPARSE_FALLBACKS] == 0


def test_the_stages_and_tutorials_keep_the_banded_lu():
    """Every built-in scene but the manipulator's, and the refined 93-DOF stage: banded, so
    their numbers are those of before the sparse LU (their banded LUs cost at most 2.6e4
    multiplications, under sparse_packing.SPARSE_FROM)."""
    from examples.benchmarks.stage_models import refined_stage

    models = [factory() for factory in MODELS.values()] + [refined_stage(16)]
    for model in models:
        data = EngineData(model)
        dims = data.int_array("dims")
        assert (dims[ed.J_SPARSE], dims[ed.A_SPARSE]) == (0, 0), model.name
        assert data.costs["constraint_lu"] == data.costs["augmented_lu"] == "banded"


def test_forcing_the_sparse_lu_does_not_depend_on_an_earlier_packing_of_the_model():
    """The orders and the sparse analysis are kept per live model: a packing that chose the
    banded LU (below SPARSE_FROM, no analysis) must not leave a forced packing of the same
    model banded, nor a forced one make a later chosen packing sparse."""
    model = MODELS["stage_spatial_19dof"]()
    chosen = EngineData(model)
    forced = EngineData(model, sparse=True)
    chosen_again = EngineData(model)
    fresh = EngineData(MODELS["stage_spatial_19dof"](), sparse=True)
    for data, expected in ((chosen, 0), (forced, 1), (chosen_again, 0), (fresh, 1)):
        dims = data.int_array("dims")
        assert (dims[ed.J_SPARSE], dims[ed.A_SPARSE]) == (expected, expected)
    q = np.zeros(model.declared_dof_count)
    for data in (forced, fresh):
        assert engine.call(data, engine.OP_KINEMATICS, q) == ed.OK
    close(forced.float_array("x"), fresh.float_array("x"), 0.0)


def test_a_singular_configuration_falls_back_to_the_banded_lu_and_is_counted():
    """The truss pendulum hanging vertically (node 2 at (0, -0.5) m): J is exactly singular.
    The kept pivots fail, pivoting afresh fails (both counted), and the banded LU says what
    it says on the banded path: a pivot ratio of 0; at a regular configuration J factors
    sparse again. The kinematics report the singularity as on the banded path."""
    model = truss_pendulum()
    data = EngineData(model, sparse=True)
    counters, dims = data.int_array("counters"), data.int_array("dims")
    y = model.dof_coordinates[0]
    x = next(c for c in model.free_coordinates if c != y)
    hanging = model.initial_coordinates.astype(float).copy()
    hanging[[x, y]] = 0.0, -0.5
    assert engine.call(data, engine.OP_DEFORMATIONS, hanging, s=1.0) == ed.OK
    assert factors.j_factor(data.address) == 0.0
    assert (counters[ed.SPARSE_PIVOTING], counters[ed.SPARSE_FALLBACKS]) == (1, 1)
    assert dims[ed.J_FACTORS] == ed.BANDED_FACTORS
    assert engine.call(data, engine.OP_DEFORMATIONS, model.initial_coordinates.astype(float),
                       s=1.0) == ed.OK
    assert factors.j_factor(data.address) > 0.0
    assert dims[ed.J_FACTORS] == ed.SPARSE_FACTORS
    assert (counters[ed.SPARSE_PIVOTING], counters[ed.SPARSE_FALLBACKS]) == (2, 1)

    def kinematics(q):
        dims[ed.WARM] = 0
        return engine.call(data, engine.OP_KINEMATICS, np.array([q]))

    assert kinematics(-0.3) == ed.OK
    assert kinematics(-0.5 * (1 - 1e-13)) == ed.SINGULAR_CONSTRAINTS


def test_the_cost_counts_choose_the_sparse_lu_where_the_band_is_wide():
    from flexure.core.engine.data import banded_multiplications, evaluation_cost

    groups = [(261, 14, 24)]
    banded = evaluation_cost(1582, 1075, 507, groups, (165, 163, 326, 326))
    sparse = evaluation_cost(1582, 1075, 507, groups, (165, 163, 326, 326),
                             {"j_factor": 9e4, "j_solve": 2.5e4, "a_factor": 1e6,
                              "a_solve": 1.2e5})
    assert banded["constraint_lu"] == banded["augmented_lu"] == "banded"
    assert sparse["constraint_lu"] == sparse["augmented_lu"] == "sparse"
    assert sparse["augmented"] < banded["augmented"] / 50
    # as many multiplications either way (a narrow band, no fill): the banded LU, whose
    # multiplications are the cheaper ones (sparse_packing.SPARSE_WEIGHT)
    j, a = banded_multiplications(96, 4, 3), banded_multiplications(99, 10, 10)
    narrow = evaluation_cost(96, 3, 93, [(33, 6, 8)], (4, 3, 10, 10),
                             {"j_factor": j - 2 * 96 * 7, "j_solve": 2 * 96 * 7,
                              "a_factor": a - 2 * 99 * 20, "a_solve": 2 * 99 * 20})
    assert narrow["constraint_lu"] == narrow["augmented_lu"] == "banded"


# -- the manipulator (slow: building it and its plain twin take tens of seconds) --------------
@pytest.fixture(scope="module")
def manipulator():
    model = load_scene("manipulator_reduced")
    return model, Mechanics(model)


def twin_errors(model, mechanics, data, q, qdot, u):
    """Relative errors against the plain twin: the backward error of qddot (of the size of the
    force terms), M_bar, K (of their largest entries)."""
    n = model.declared_dof_count
    qddot = evaluate(data, q, qdot, u)
    plain = plain_dynamics(model, mechanics, q, qdot, u)
    DF, mass = plain["config"].DF, plain["mass"]
    backward = np.max(np.abs(mass @ qddot - DF.T @ plain["r"])) / np.max(plain["size"])
    mass_error = np.max(np.abs(data.float_array("mass").reshape(n, n) - mass)) / np.max(
        np.abs(mass))
    assert engine.call(data, engine.OP_TANGENT, qddot.copy()) == ed.OK
    K, _ = plain_tangent(mechanics, plain, qddot)
    stiffness = np.max(np.abs(data.float_array("stiffness").reshape(n, n) - K)) / np.max(
        np.abs(K))
    return np.array([backward, mass_error, stiffness])


# relative errors of qddot, M_bar and K below which the twin comparison is round-off of a
# 507-DOF model (n eps, n eps, n eps times K's spread of magnitudes, about 1e4)
ROUND_OFF = np.array([1e-14, 1e-13, 5e-12])


@pytest.mark.slow
def test_the_manipulator_takes_the_sparse_lu_and_matches_the_plain_twin(manipulator):
    """At the initial configuration and at two displaced ones (DOFs 1e-4 from it, 0.05 m/s),
    with the LUs the cost counts choose (both sparse): qddot's backward error, M_bar and K
    against the plain twin within twice the banded engine's errors plus the round-off of
    that comparison (ROUND_OFF: below it neither error says anything of the LU), and within
    1e-13, 1e-12 and 1e-9 outright. Measured: 0.8 to 1.0 times the banded errors; at 507
    DOFs both exceed the 1e-14 that test_engine asks of the small scenes, up to 6e-14 for
    qddot and 8e-11 for K; since the kinematics stop in each unknown's unit (2026-11-29), K's
    relative error at the displaced states is 1.7e-12 sparse against 5.7e-13 banded."""
    model, mechanics = manipulator
    data, banded = EngineData(model), EngineData(model, sparse=False)
    dims = data.int_array("dims")
    assert (dims[ed.J_SPARSE], dims[ed.A_SPARSE], dims[ed.AUGMENTED]) == (1, 1, 1)
    assert banded.int_array("dims")[ed.J_SPARSE] == banded.int_array("dims")[ed.A_SPARSE] == 0
    q0 = mechanics.kinematics.dofs_of(model.initial_coordinates)
    n = q0.size
    states = [(q0, np.zeros(n), np.zeros(len(model.inputs)))]
    states += random_states(model, q0, seed=12, count=2)
    for q, qdot, u in states:
        assert engine.call(data, engine.OP_KINEMATICS, q) == ed.OK
        expected = mechanics.kinematics.solve(q, model.initial_coordinates.copy())
        close(data.float_array("DF").reshape(model.nx, n), expected.DF, 1e-12)
        sparse_errors = twin_errors(model, mechanics, data, q, qdot, u)
        banded_errors = twin_errors(model, mechanics, banded, q, qdot, u)
        assert np.all(sparse_errors <= 2.0 * banded_errors + ROUND_OFF), (sparse_errors,
                                                                           banded_errors)
        assert np.all(sparse_errors <= [1e-13, 1e-12, 1e-9]), sparse_errors
    counters = data.int_array("counters")
    assert counters[ed.SPARSE_FALLBACKS] == 0
    # the Euler parameters of nodes rotated away from the initial configuration change
    # which pivots the augmented system needs: it pivots afresh, and keeps those
    assert counters[ed.SPARSE_PIVOTING] >= 1


@pytest.mark.slow
def test_the_manipulator_sparse_and_banded_engines_agree(manipulator):
    """qddot of the sparse and the banded engine at a displaced configuration, moving, to
    the backward error of either (1e-14 of the force terms over M_bar's smallest
    eigenvalue, as test_engine); the sparse augmented LU solves A z = b and A^T z = b to a
    backward error of 1e-13."""
    model, mechanics = manipulator
    q0 = mechanics.kinematics.dofs_of(model.initial_coordinates)
    (q, qdot, u), = random_states(model, q0, seed=13, count=1)
    sparse, banded = EngineData(model), EngineData(model, sparse=False)
    assert banded.int_array("dims")[ed.J_SPARSE] == 0
    fast, slow = evaluate(sparse, q, qdot, u), evaluate(banded, q, qdot, u)
    plain = plain_dynamics(model, mechanics, q, qdot, u)
    bound = 1e-14 * np.max(plain["size"]) / np.linalg.eigvalsh(plain["mass"])[0]
    close(fast, slow, 2.0, scale=bound)
    close(fast, plain["qddot"], 1.0, scale=bound)
    # the augmented system of the sparse engine, refactored by hand and solved both ways
    ints, floats = sparse.int_array("aug_sparse"), sparse.float_array("aug_sparse_values")
    rng = np.random.default_rng(14)
    b = rng.standard_normal(ints[sparse_lu.H_N])
    for transposed in (False, True):
        z = b.copy()
        sparse_lu.solve(ints, floats, z, transposed)
        matrix = np.zeros(b.size * b.size)
        sparse_lu.scatter_dense(ints, floats, matrix, np.arange(b.size), np.arange(b.size))
        matrix = matrix.reshape(b.size, b.size)
        matrix = matrix.T if transposed else matrix
        # normwise backward error (the system's condition is ~1e12: masses of 1e-12 kg m^2
        # beside constraint rows of 1)
        residual = np.max(np.abs(matrix @ z - b))
        assert residual <= 1e-13 * (np.max(np.abs(matrix) @ np.abs(z)) + np.max(np.abs(b)))


@pytest.mark.parametrize("name", ["stage_spatial_19dof", "stage_planar_3dof_gravity"])
def test_j_solves_with_the_lu_of_j_transposed(name):
    """J's sparse LU is that of J^T (`sparse_factors`): put back from it
    (`sparse_lu.scatter_rows`, transposed), it is the plain twin's J at a displaced
    configuration (to round-off of its entries), and the engine's j_solve solves J z = b and
    J^T z = b to a backward error of 1e-14."""
    model = MODELS[name]()
    mechanics = Mechanics(model)
    data = EngineData(model, sparse=True, rigid=False)  # J = [De on the free coordinates; I]
    q0 = mechanics.kinematics.dofs_of(model.initial_coordinates)
    q = q0 + 1e-3 * np.random.default_rng(3).standard_normal(q0.size)
    assert engine.call(data, engine.OP_KINEMATICS, q) == ed.OK  # J factored at its solution
    config = mechanics.kinematics.solve(q, model.initial_coordinates.copy())
    De = config.De.toarray() if hasattr(config.De, "toarray") else config.De
    # J in the engine's order: its rows of g, then the DOF coordinates' unit rows
    rows, free = data.int_array("constraint_rows"), data.int_array("free")
    n = free.size
    expected = np.zeros((n, n))
    expected[:rows.size] = De[np.ix_(rows, free)]
    expected[rows.size + np.arange(q0.size - data.int_array("dof_deformations").size),
             data.int_array("dof_positions")] = 1.0
    dense = np.zeros(n * n)
    sparse_lu.scatter_rows(data.int_array("j_sparse"), data.float_array("j_sparse_values"),
                           dense, np.arange(n), np.arange(n), n, 0, True)
    J = dense.reshape(n, n)
    close(J, expected, 1e-13)
    b = np.random.default_rng(4).standard_normal(n)
    for transposed, matrix in ((False, J), (True, J.T)):
        z = b.copy()
        factors.j_solve(data.address, z, transposed)
        residual = np.max(np.abs(matrix @ z - b))
        assert residual <= 1e-14 * (np.max(np.abs(matrix) @ np.abs(z)) + np.max(np.abs(b)))
