"""The one-step ESDIRK integrators: their tableaus, their order, their accuracy against CVODE,
their restart-free sampled loop, and their error paths."""

import pickle
from fractions import Fraction

import numpy as np
import pytest
from test_engine import check_compiled_loop_against_python_loop

from flexure.core import Simulator, load_scene, simulate
from flexure.core.errors import SimulationError
from flexure.core.simulation.esdirk import Esdirk
from flexure.core.simulation.esdirk_method import ESDIRK3, ESDIRK4, SDIRK2, TRBDF2

TABLEAUS = [ESDIRK3, ESDIRK4, TRBDF2, SDIRK2]


# -- the tableaus --------------------------------------------------------------------------------
def order_conditions(tableau, b):
    """Residuals of the Runge-Kutta order conditions up to order 4 for weights b (the rooted
    trees with 1 to 4 nodes), in the tableau's own fractions."""
    A, c, s = tableau.A, tableau.c, tableau.stages

    def dot(u, v):
        return sum((Fraction(x) * Fraction(y) for x, y in zip(u, v, strict=True)), Fraction(0))

    def times_A(v):
        return [dot(A[i], v) for i in range(s)]

    c2 = [ci * ci for ci in c]
    Ac = times_A(c)
    return {1: [dot(b, [1] * s) - 1],
            2: [dot(b, c) - Fraction(1, 2)],
            3: [dot(b, c2) - Fraction(1, 3), dot(b, Ac) - Fraction(1, 6)],
            4: [dot(b, [ci ** 3 for ci in c]) - Fraction(1, 4),
                dot(b, [ci * a for ci, a in zip(c, Ac, strict=True)]) - Fraction(1, 8),
                dot(b, times_A(c2)) - Fraction(1, 12),
                dot(b, times_A(Ac)) - Fraction(1, 24)]}


@pytest.mark.parametrize("tableau", TABLEAUS, ids=lambda t: t.name)
def test_tableau_has_its_order_and_its_embedding_its_own(tableau):
    """ESDIRK4 is exact in its fractions; ESDIRK3's gamma is irrational and its fractions
    rational approximations (Kennedy & Carpenter's), good to about 1e-20; TR-BDF2's sqrt(2)
    a fraction good to 1e-44. Each order holds, and not one more."""
    bound = 0 if tableau is ESDIRK4 else Fraction(1, 10 ** 18)
    for weights, order in ((tableau.b, tableau.order), (tableau.b_hat, tableau.embedded_order)):
        residuals = order_conditions(tableau, weights)
        for p in range(1, order + 1):
            assert all(abs(r) <= bound for r in residuals[p]), (p, residuals[p])
        if order + 1 in residuals:  # and not one order more
            assert max(abs(r) for r in residuals[order + 1]) > 1e-6


@pytest.mark.parametrize("tableau", TABLEAUS, ids=lambda t: t.name)
def test_tableau_is_stiffly_accurate_explicit_first_and_l_stable(tableau):
    A = np.array([[float(v) for v in row] for row in tableau.A])
    b = A[-1]
    s = tableau.stages
    assert np.all(A[0] == 0.0) and np.all(np.triu(A, 1) == 0.0)
    assert np.all(np.diag(A)[1:] == float(tableau.gamma))

    def R(z):  # the stability function 1 + z b^T (I - z A)^-1 1
        return 1.0 + z * b @ np.linalg.solve(np.eye(s) - z * A, np.ones(s))

    assert abs(R(-1e9)) < 1e-6  # L-stable: stiff modes damped, not carried
    for w in np.logspace(-2, 4, 61):  # A-stable on the imaginary axis: undamped modes
        assert abs(R(1j * w)) <= 1.0 + 1e-12
    z = -0.01  # consistent with exp(z) to its order
    assert abs(R(z) - np.exp(z)) < 10 * abs(z) ** (tableau.order + 1)


def test_predictor_reproduces_polynomials_of_the_stage_time():
    """The Newton start of stage i extrapolates F_j in c: exact for F = 1, c, c^2 (quadratic
    through the last three stages)."""
    for tableau in TABLEAUS:
        P, c = tableau.predictor(), tableau.c
        for i in range(1, tableau.stages):
            degree = min(i, 3) - 1
            for power in range(degree + 1):
                assert sum(P[i][j] * c[j] ** power for j in range(i)) == c[i] ** power


def last_step_history(tableau, h, a, b, k):
    """`keep_history` (compiled) after a step of size h whose stage derivatives are F(t) = a +
    b t + k t^2 at the stage times: (mean slope, curvature)."""
    from flexure.core.simulation import esdirk_kernels, esdirk_layout

    A = tableau.arrays()[0]
    vectors = np.zeros((esdirk_layout.V_ROWS, a.size))
    for j, c in enumerate(tableau.c):
        t = float(c) * h
        vectors[esdirk_layout.V_F + j] = a + b * t + k * t * t
    esdirk_kernels.keep_history(vectors, A, h)
    return vectors[esdirk_layout.V_SLOPE], vectors[esdirk_layout.V_CURVATURE]


@pytest.mark.parametrize("tableau", TABLEAUS, ids=lambda t: t.name)
def test_the_last_steps_history_is_the_quadratic_through_its_stages(tableau):
    """On stage derivatives that are a quadratic in t, F(t) = a + b t + k t^2: the mean slope
    (F(h) - F(0)) / h = b + k h and the curvature k, per component, to round-off. With them
    the next step's Newton start is exact where F goes on as it was: stage 2's F_1 + c2 h
    slope for a linear F, stage 3's line through F_1, F_2 plus the curvature term for a
    quadratic one."""
    rng = np.random.default_rng(3)
    h, c = 2.5e-4, [float(v) for v in tableau.c]
    a, b, k = (rng.standard_normal(4) * scale for scale in (1.0, 1e3, 1e7))
    slope, curvature = last_step_history(tableau, h, a, b, k)
    np.testing.assert_allclose(slope, b + k * h, rtol=1e-9)
    np.testing.assert_allclose(curvature, k, rtol=1e-6)
    P = tableau.arrays()[2]
    after = [a + b * t + k * t * t for t in h + np.array(c) * h]  # the next step's stages
    third = P[2, 0] * after[0] + P[2, 1] * after[1] + c[2] * (c[2] - c[1]) * h * h * curvature
    np.testing.assert_allclose(third, after[2], rtol=1e-9)
    slope, _ = last_step_history(tableau, h, a, b, 0.0 * k)
    np.testing.assert_allclose(a + b * h + c[1] * h * slope, a + b * (1 + c[1]) * h,
                               rtol=1e-12)


# -- convergence and accuracy on a model ----------------------------------------------------------
@pytest.mark.parametrize("method, order", [("esdirk2", 2), ("esdirk3", 3), ("esdirk", 4)])
def test_observed_order_with_fixed_steps(method, order):
    """truss_1dof_x (a mass-spring-damper, its 1 N load from t = 0) for 0.05 s in fixed steps
    h (the first step given, rtol so loose that no step is rejected or resized, h the largest
    step): halving h divides the error at 0.05 s by 2^order (within 0.3)."""
    model = load_scene("truss_1dof_x")
    reference = simulate(model, 0.05, rtol=1e-12, output_times=[0.05]).q[-1, 0]
    errors = []
    for h in (0.05 / 8, 0.05 / 16, 0.05 / 32):
        sim = Simulator(model)
        data = sim.data
        data.float_array("q_ref")[:] = sim.q_ref  # what Simulator.advance sets before a run
        integrator = Esdirk(data, rtol=0.5, atol=np.full(2, 1.0), max_step=h, method=method)
        integrator.restart_memory = {"initial_step": h}
        integrator.reset(0.0, np.zeros(2))
        t, y = integrator.advance(0.05)
        assert t == 0.05 and integrator.statistics()["steps"] == round(0.05 / h)
        errors.append(abs(data.float_array("q_ref")[0] + y[0] - reference))
    observed = np.log2(np.array(errors[:-1]) / errors[1:])
    assert np.all(np.abs(observed - order) < 0.3), observed


@pytest.mark.parametrize("method, bound", [("esdirk", 2.0), ("esdirk3", 50.0),
                                           ("esdirk2", 50.0)])
def test_three_dof_step_within_rtol_of_a_tight_cvode_run(method, bound):
    """stage_planar_3dof, 1 N for 0.2 s at rtol 1e-6: x within `bound` rtol of its motion.
    Measured at rtol 1e-5 to 1e-7: esdirk 0.2 to 0.7 rtol, esdirk3 23 to 28 rtol (its
    order-2 error estimate is conservative per step, the order-3 solution's global error
    accumulates over ~400 steps), esdirk2 (TR-BDF2) 24 to 26 rtol over 900 to 9000 steps."""
    model = load_scene("stage_planar_3dof")
    times = np.linspace(0.0, 0.2, 21)
    reference = simulate(model, 0.2, inputs={"F": 1.0}, rtol=1e-11, output_times=times)
    result = simulate(model, 0.2, inputs={"F": 1.0}, method=method, rtol=1e-6,
                      output_times=times)
    motion = np.ptp(reference.outputs["x"])
    assert motion > 1e-3
    error = np.max(np.abs(result.outputs["x"] - reference.outputs["x"]))
    assert error <= bound * 1e-6 * motion


# -- the restart-free sampled loop ---------------------------------------------------------------
def test_compiled_loop_on_esdirk_equals_a_python_loop_bit_for_bit():
    check_compiled_loop_against_python_loop("esdirk3")


def test_an_input_change_costs_one_evaluation_not_a_restart():
    model = load_scene("stage_planar_1dof")
    sim = Simulator(model, method="esdirk", rtol=1e-8)
    sim.set_inputs([1.0])
    sim.advance_to(1e-3)
    before = sim.statistics
    for k in range(2, 12):  # ten samples, each with a new force
        sim.set_inputs([1.0 + 0.01 * k])
        sim.advance_to(k * 1e-3 / 2 + 0.5e-3)
    after = sim.statistics
    assert after["jacobian_evaluations"] == before["jacobian_evaluations"]
    assert after["steps"] - before["steps"] <= 12


@pytest.mark.parametrize("method", ["esdirk", "esdirk3"])
def test_restored_state_continues_bit_for_bit(method):
    model = load_scene("stage_planar_1dof")
    sim = Simulator(model, method=method, rtol=1e-7)
    sim.set_inputs([1.0])
    sim.advance_to(0.05)
    state = pickle.loads(pickle.dumps(sim.get_state()))
    assert state["jacobian"].size == 4 and state["lu_step"] > 0
    sim.advance_to(0.1)
    sim.set_inputs([-0.5])
    sim.advance_to(0.15)
    other = Simulator(model, method=method, rtol=1e-7)
    other.set_state(state)
    other.advance_to(0.1)
    other.set_inputs([-0.5])
    other.advance_to(0.15)
    assert other.time == sim.time
    assert np.array_equal(other.q, sim.q) and np.array_equal(other.qdot, sim.qdot)


# -- error paths -----------------------------------------------------------------------------------
@pytest.mark.parametrize("options, name", [
    ({"max_order": 2}, "max_order"), ({"jacobian": "finite-difference"}, "jacobian"),
    ({"input_functions": {0: np.sin}}, "input_functions")])
def test_options_a_one_step_method_does_not_take_are_refused(options, name):
    with pytest.raises(SimulationError, match=f"method 'esdirk' takes no {name}"):
        Simulator(load_scene("truss_1dof_x"), method="esdirk", **options)


@pytest.mark.parametrize("method", ["esdirk", "cvode-bdf", "ida"])
def test_step_budget_stops_at_the_last_accepted_state(method):
    """Simulator.advance_to(max_steps=5): the integrator counts its own steps (CVODE's and
    IDA's max_num_steps, the ESDIRK kernel's budget), the simulator stays at its last good
    state and goes on from there."""
    model = load_scene("stage_planar_3dof")
    sim = Simulator(model, method=method, rtol=1e-8)
    sim.set_inputs([1.0])
    with pytest.raises(SimulationError, match="step budget of 5 integrator steps"):
        sim.advance_to(0.5, max_steps=5)
    assert 0.0 < sim.time < 0.5 and np.all(np.isfinite(sim.state))
    sim.advance_to(0.01 if sim.time < 0.01 else sim.time + 0.01)  # and goes on from there


def test_a_state_it_cannot_evaluate_is_a_message_naming_the_cause():
    """A DOF driven through the truss pendulum's singular (stretched-flat) configuration:
    the integrator stops with the engine's reason, at its last good state."""
    model = load_scene("truss_1dof_x")
    integrator = Esdirk(Simulator(model).data, rtol=1e-6, atol=np.full(2, 1e-9))
    integrator.reset(0.0, np.array([np.nan, 0.0]))
    with pytest.raises(SimulationError, match=r"ESDIRK4\(3\)6L\[2\]SA failed with RHS_FAILURE "
                                              r"\(the state became non-finite\)"):
        integrator.advance(0.1)


def test_a_corrupt_integrator_memory_is_refused():
    model = load_scene("truss_1dof_x")
    sim = Simulator(model, method="esdirk")
    sim.advance_to(0.01)
    state = sim.get_state()
    for key, value in (("lu_step", -1.0), ("initial_step", np.nan), ("newton_rate", np.inf),
                       ("extra_iterations", -1.0)):
        with pytest.raises(SimulationError, match="integrator memory holds negative or "
                                                  f"non-finite numbers: {key} = "):
            Simulator(model, method="esdirk").set_state(dict(state, **{key: value}))
    with pytest.raises(SimulationError, match="non-finite numbers: in its jacobian"):
        Simulator(model, method="esdirk").set_state(
            dict(state, jacobian=np.full_like(state["jacobian"], np.nan)))
    for key, value in (("refresh", 2.0), ("extra_iterations", 2.5)):
        with pytest.raises(SimulationError, match=f"{key} = {value!r}.*expected 0 or 1 and "
                                                  "a whole number"):
            Simulator(model, method="esdirk").set_state(dict(state, **{key: value}))


# -- the Newton matrix of large models -----------------------------------------------------------
@pytest.mark.parametrize("second_order", [True, False])
def test_the_newton_matrix_through_its_schur_complement_solves_as_the_full_one(second_order):
    """From newton_matrix.SCHUR_FROM DOFs on, (I - hg J) v = r with J = [[0, I], [A, B]] is
    solved through I - hg B - hg^2 A: the same solution as numpy on the full matrix, to the
    round-off of either; a J of another form takes the full matrix."""
    from flexure.core.simulation import newton_matrix

    m = newton_matrix.SCHUR_FROM
    n = 2 * m
    rng = np.random.default_rng(5)
    J = np.zeros((n, n))
    J[:m, m:] = np.eye(m)
    J[m:, :m] = -rng.uniform(0.0, 1e6, (m, m)) / m  # -M^-1 K: stiff
    J[m:, m:] = -rng.uniform(0.0, 10.0, (m, m)) / m  # -M^-1 C
    if not second_order:
        J[0, 0] = 1e-3
    check_newton_solve(J, 2e-4, rng, reduced=second_order)


def check_newton_solve(J, hg, rng, *, reduced):
    """ESDIRK's factors of I - hg J (through the Schur complement if `reduced`, else the full
    matrix), and its solution of (I - hg J) v = r for a random r against numpy's, to 10 times
    the round-off that the matrix's condition number allows."""
    from flexure.core.simulation import esdirk_layout, esdirk_newton, newton_matrix

    n = J.shape[0]
    LU, piv = np.zeros(n * n), np.zeros(n, dtype=np.int64)
    flags = np.zeros(esdirk_layout.I_SIZE, dtype=np.int64)
    assert esdirk_newton.factor(J.ravel(), LU, piv, hg, flags)
    assert flags[esdirk_layout.I_REDUCED] == int(reduced)
    assert flags[esdirk_layout.I_FACTORIZATIONS] == 1
    r = rng.standard_normal(n)
    v = r.copy()
    newton_matrix.newton_solve(J.ravel(), LU, piv, hg, bool(reduced), v)
    matrix = np.eye(n) - hg * J
    expected = np.linalg.solve(matrix, r)
    bound = 10 * np.linalg.cond(matrix) * 2.2e-16 * np.max(np.abs(expected))
    assert np.max(np.abs(v - expected)) <= bound


def test_a_jacobian_grown_stale_is_renewed_and_a_current_one_kept():
    """Newton's iterations beyond the first that converge slowly (theta >= THETA_STALE) are
    the Jacobian's age; once they add up to JACOBIAN_COST n evaluations, the next step takes
    a new one. A 1 N step rings the 3-DOF stage's bar: new Jacobians along the way, the count
    never a step's iterations past the threshold. Where every extra iteration converges
    fast (the input changes of the 1-DOF test above), none is taken."""
    from flexure.core.simulation.esdirk_newton import JACOBIAN_COST, MAX_NEWTON

    model = load_scene("stage_planar_3dof")
    sim = Simulator(model, method="esdirk", rtol=1e-6)
    threshold = max(1.0, JACOBIAN_COST * 2 * model.ndof)
    one_step = (MAX_NEWTON - 1) * 5  # ESDIRK4's five implicit stages
    counts = []
    for k in range(1, 201):
        sim.set_inputs([1.0])
        sim.advance_to(k * 1e-3)
        counts.append(sim.integrator.restart_memory["extra_iterations"])
    assert sim.statistics["jacobian_evaluations"] >= 10
    assert threshold <= max(counts) < threshold + one_step  # reached, then renewed
    assert min(counts) == 0  # renewed, the count starts over


def test_the_cost_of_a_jacobian_is_the_dense_paths_n_over_4_or_the_sparse_paths_constant():
    """The iterations a Jacobian's age may cost before a new one, on made-up sizes: n / 4 on
    the dense path (at least 1), SPARSE_JACOBIAN_COST on the sparse Newton matrix however
    large n, the dense path's where that is smaller."""
    from flexure.core.simulation.esdirk_newton import (
        JACOBIAN_COST,
        SPARSE_JACOBIAN_COST,
        jacobian_cost,
    )

    assert (JACOBIAN_COST, SPARSE_JACOBIAN_COST) == (0.25, 40.0)
    assert jacobian_cost(2, False) == 1.0
    assert jacobian_cost(6, False) == 1.5
    assert jacobian_cost(1014, False) == 253.5
    assert jacobian_cost(1014, True) == 40.0
    assert jacobian_cost(768, True) == 40.0
    assert jacobian_cost(150, True) == 37.5
    assert jacobian_cost(20, True) == 5.0
    assert jacobian_cost(2, True) == 1.0


def test_on_the_sparse_newton_matrix_a_jacobian_is_renewed_at_its_constant_cost():
    """The 96-DOF spatial cantilever (sparse Newton matrix, 192 states) ringing under its tip
    load: the Jacobian's age reaches SPARSE_JACOBIAN_COST iterations, not the dense path's
    n / 4 = 48, and the next step takes a new one."""
    from examples.benchmarks.spatial import spatial_cantilever
    from flexure.core.simulation.esdirk_newton import MAX_NEWTON, SPARSE_JACOBIAN_COST

    sim = Simulator(spatial_cantilever(16), method="esdirk", rtol=1e-6)
    assert sim.integrator.sparse_newton
    one_step = (MAX_NEWTON - 1) * 5
    counts = []
    for k in range(1, 161):
        sim.advance_to(k * 5e-5)
        counts.append(sim.integrator.restart_memory["extra_iterations"])
    assert sim.statistics["jacobian_evaluations"] >= 2
    assert SPARSE_JACOBIAN_COST <= max(counts) < SPARSE_JACOBIAN_COST + one_step
    assert 0 in counts[counts.index(max(counts)):]  # renewed, the count starts over


def test_a_state_saved_with_stale_iterations_counted_replays_bit_for_bit():
    """The count is part of the state: a restored simulator renews its Jacobian at the same
    step as the one it was saved from."""
    model = load_scene("stage_planar_3dof")
    sim = Simulator(model, method="esdirk", rtol=1e-6)
    k = 0
    while True:  # to a state with iterations counted
        k += 1
        sim.set_inputs([np.sin(20.0 * k * 1e-3)])
        sim.advance_to(k * 1e-3)
        if sim.get_state()["extra_iterations"] > 0:
            break
    state = pickle.loads(pickle.dumps(sim.get_state()))
    before = sim.statistics["jacobian_evaluations"]
    other = Simulator(model, method="esdirk", rtol=1e-6)
    other.set_state(state)
    for j in range(k + 1, k + 51):
        for s in (sim, other):
            s.set_inputs([np.sin(20.0 * j * 1e-3)])
            s.advance_to(j * 1e-3)
    assert np.array_equal(other.q, sim.q) and np.array_equal(other.qdot, sim.qdot)
    renewed = sim.statistics["jacobian_evaluations"] - before
    assert renewed >= 1 and other.statistics["jacobian_evaluations"] == renewed
