"""Time simulation with kinematic inputs in the compiled engine (`engine.prescribed`,
`simulation.simulator_motion`): the path's kernel against the scene's move in numpy, closed
forms where nothing is left free (a truss moved along its axis, a pendulum turned), the numpy
reference `motion_response` where something is (a chain of springs and masses; the 3-DOF
stage in the slow tier), the prescribed Jacobian against finite differences, the command
line, and the refusals of what does not take kinematic inputs yet. IDA's implicit form:
tests/test_ida_motion.py."""

import numpy as np
import pytest
from cli_runs import run, warm_command_modules
from kinematic_scenes import chain, turned_pendulum, with_motion

from flexure.core import build_model, load_scene
from flexure.core.analysis.motion_paths import increment_path
from flexure.core.analysis.motion_response import motion_response
from flexure.core.engine.prescribed import path_point, quintic_path
from flexure.core.errors import SimulationError
from flexure.core.scene.building import scene_path
from flexure.core.simulation.simulation import simulate
from flexure.core.simulation.simulator import Simulator
from flexure.core.simulation.simulator_motion import path_values

METHODS = ["cvode-bdf", "esdirk", "ida"]


def moved_truss(value=0.101):
    """truss_1dof_x with its node 2 moved along x from 0.1 m to `value`: nothing left free."""
    return build_model(with_motion("truss_1dof_x", "2", "x", value=value))


def moved_chain(value=0.101):
    data = chain()
    data["inputs"]["u"]["value"] = value
    return build_model(data)


# -- the path ------------------------------------------------------------------------------

def test_the_compiled_path_is_the_scenes_move():
    """The records of `quintic_path` evaluated by the compiled `path_point` and by numpy's
    `path_values` give `increment_path`'s u, u', u'' before, during and after the move
    (to round-off: 1e-13 of the increment d, of d / T and of d / T^2; measured 1.4e-14 of
    d / T^2 on the acceleration, whose power-basis terms cancel to 1/60 of their size)."""
    model = build_model(with_motion("stage_planar_3dof", "3", "x", value=0.101, start=0.099))
    T, t0 = 0.04, 0.01
    path = quintic_path(model.motion_starts, model.motion_values, T, t0)
    reference = increment_path(model, T, t0=t0)
    d = 0.002  # the increment, m
    scales = np.array([d, d / T, d / T**2])
    for t in [0.0, 0.01, 0.013, 0.02, 0.03, 0.0449, 0.05, 0.2]:
        expected = np.array([part[0] for part in reference(t)])
        numpy = np.array([part[0] for part in path_values(path, t)])
        compiled = np.array(path_point(path, 0, t))
        if t in (0.0, 0.2):  # held: exactly the start and the value
            np.testing.assert_array_equal(numpy, expected)
        assert np.all(np.abs(numpy - expected) <= 1e-13 * scales)
        assert np.all(np.abs(compiled - numpy) <= 1e-13 * scales)


# -- nothing left free: closed forms --------------------------------------------------------

@pytest.mark.parametrize("method", METHODS)
def test_a_truss_moved_along_its_axis_takes_m_a_plus_c_v_plus_k_u(method):
    """truss_1dof_x, 2.x moved 0.1 -> 0.101 m in 50 ms: the effort is m u'' + c u' + k (u -
    0.1) - 1 N (m = 0.206 + rho_A l / 3, k = EA / l, c = EdA / l, the scene's 1 N on node 2;
    linear along x), to 1e-12 of its largest; q and qdot are the path's (to round-off:
    1e-15 m, 1e-15 m/s)."""
    model = moved_truss()
    m, k, c = 0.206 + 0.1413 * 0.1 / 3, 94.5 / 0.1, 0.0036494 / 0.1
    T = 0.05
    result = simulate(model, 0.08, method=method, rtol=1e-8, motion_duration=T,
                      output_times=np.linspace(0.0, 0.08, 17))
    path = increment_path(model, T)
    u, v, a = (np.array([path(t)[j][0] for t in result.times]) for j in range(3))
    exact = m * a + c * v + k * (u - 0.1) - 1.0
    effort = result.outputs["X.effort"]
    assert result.output_units[result.output_names.index("X.effort")] == "N"
    assert np.max(np.abs(effort - exact)) <= 1e-12 * np.max(np.abs(exact))
    np.testing.assert_allclose(result.q[:, 0], u, rtol=0, atol=1e-15)
    np.testing.assert_allclose(result.qdot[:, 0], v, rtol=0, atol=1e-15)
    assert result.outputs["x"][-1] == 0.101  # the scene's output on the moved node


def test_an_effort_carries_the_held_force_on_its_row():
    """truss_1dof_x held at 0.1 m with the force input F = 2 N on its node: the effort at
    rest is the static one, k (u - 0.1) - 1 N (the load) - F, to 1e-12 N, in the simulator
    and in simulate() (with F = 0 it would be -1 N)."""
    model = moved_truss(0.1)
    sim = Simulator(model, method="esdirk", stepwise_motion=True)
    sim.set_inputs([2.0])
    sim.move_to([0.1], 1e-3)
    assert sim.efforts()[0] == pytest.approx(-3.0, rel=0, abs=1e-12)
    result = simulate(model, 1e-3, inputs={"F": 2.0})
    assert result.outputs["X.effort"][-1] == pytest.approx(-3.0, rel=0, abs=1e-12)


def test_set_motion_moves_the_inputs_again_from_a_later_time():
    """set_motion(T, t0): the truss's move of 20 ms starting at 10 ms (held at the start
    before): the effort m u'' + c u' + k (u - 0.1) - 1 N of the shifted quintic to 1e-12 of its
    largest; a model without kinematic inputs is refused, naming what is missing."""
    model = moved_truss()
    m, k, c = 0.206 + 0.1413 * 0.1 / 3, 945.0, 0.036494
    sim = Simulator(model, method="esdirk", motion_duration=0.05)
    sim.set_motion(0.02, t0=0.01)
    path = increment_path(model, 0.02, t0=0.01)
    efforts, exact = [], []
    for t in np.linspace(0.005, 0.04, 8):
        sim.advance_to(t)
        u, v, a = (part[0] for part in path(t))
        exact.append(m * a + c * v + k * (u - 0.1) - 1.0)
        efforts.append(sim.efforts()[0])
        assert sim.prescribed_values()[0][0] == pytest.approx(u, abs=1e-15)
    assert np.max(np.abs(np.array(efforts) - exact)) <= 1e-12 * np.max(np.abs(exact))
    with pytest.raises(SimulationError, match="'truss_1dof_x' has no kinematic input to move"):
        Simulator(load_scene("truss_1dof_x")).set_motion(0.02)


@pytest.mark.parametrize("method", METHODS)
def test_a_pendulum_turned_takes_m_g_l_sin_plus_m_l2_theta_ddot(method):
    """A point mass m on a rigid link l turned 0 -> 0.8 rad in 0.5 s about its pivot: the
    effort (N m) is m g l sin(theta) + m l^2 theta'' to 1e-12 of its largest (nonlinear in
    theta, nothing free)."""
    mass, length, g = 0.3, 0.25, 9.81
    data = turned_pendulum(mass, length, g, value=0.8)
    model = build_model(data)
    result = simulate(model, 0.6, method=method, motion_duration=0.5,
                      output_times=np.linspace(0.0, 0.6, 13))
    assert result.output_units == ["N m"]
    path = increment_path(model, 0.5)
    theta, _, acceleration = (np.array([path(t)[j][0] for t in result.times]) for j in range(3))
    exact = mass * g * length * np.sin(theta) + mass * length**2 * acceleration
    assert np.max(np.abs(result.outputs["A.effort"] - exact)) <= 1e-12 * np.max(np.abs(exact))


# -- something left free: the numpy reference ----------------------------------------------

@pytest.fixture(scope="module")
def chain_reference():
    """`motion_response` of the chain (ground - k1, c1 - m1 moved 1 mm in 40 ms - k2, c2 -
    m2 free) at rtol 1e-10."""
    model = moved_chain()
    times = np.linspace(0.0, 0.06, 7)
    return model, motion_response(model, times, increment_path(model, 0.04), rtol=1e-10)


@pytest.mark.parametrize("method", METHODS + ["cvode-adams", "esdirk3"])
def test_the_chain_follows_the_numpy_reference(chain_reference, method):
    """At rtol 1e-10: the free mass m2 within 1e-10 m of the reference (it moves 1.2 mm;
    measured 3.1e-12), its velocity within 1e-8 m/s (measured 2.4e-10), the effort on m1
    (1.9 N from least to most) within 1e-8 N (measured 1.5e-9; IDA 1.9e-12 m, 5.7e-11 m/s,
    9.4e-10 N)."""
    model, reference = chain_reference
    sim = Simulator(model, method=method, rtol=1e-10, motion_duration=0.04)
    sim.reset(q0=reference.q[0])
    for i, t in enumerate(reference.times[1:], 1):
        sim.advance_to(t)
        assert np.max(np.abs(sim.q - reference.q[i])) < 1e-10
        assert np.max(np.abs(sim.qdot - reference.qdot[i])) < 1e-8
        assert np.max(np.abs(sim.efforts() - reference.efforts[i])) < 1e-8
        assert abs(sim.prescribed_values()[0][0] - reference.q[i, 0]) < 1e-15  # m


@pytest.mark.slow
def test_the_stage_follows_the_numpy_reference():
    """stage_planar_3dof with 3.x moved 1 mm in 20 ms and held to 30 ms (its 3.y and 4.phi
    free, a 3.6 kHz mode excited): CVODE and the ESDIRK at rtol 1e-9 against `motion_response`
    at rtol 1e-10 (70 s): the DOFs within 1e-9 m or rad (measured 2.7e-10), the effort (5 N
    over the move) within 5e-5 N (measured 1.0e-5: it holds M_kf qddot_f of the stiff mode)."""
    model = build_model(with_motion("stage_planar_3dof", "3", "x", value=0.001))
    times = np.linspace(0.0, 0.03, 7)
    reference = motion_response(model, times, increment_path(model, 0.02), rtol=1e-10)
    for method in ("cvode-bdf", "esdirk"):
        sim = Simulator(model, method=method, rtol=1e-9, motion_duration=0.02)
        sim.reset(q0=reference.q[0])
        for i, t in enumerate(times[1:], 1):
            sim.advance_to(t)
            assert np.max(np.abs(sim.q - reference.q[i])) < 1e-9
            assert np.max(np.abs(sim.efforts() - reference.efforts[i])) < 5e-5


@pytest.mark.parametrize("t", [0.0, 0.013, 0.05])
def test_one_evaluation_equals_the_numpy_formulas(t):
    """stage_planar_3dof with 3.x prescribed, at a state off equilibrium, before, during and
    after the move: the compiled right-hand side's qddot and efforts against
    `motion_response`'s numpy evaluation of M_ff qddot_f = Q_f - M_fk u'' and
    F = M_kf qddot_f + M_kk u'' - Q_k at the same (t, q_f, qdot_f), to round-off: 1e-12 of
    their largest (measured 1.0e-14; the efforts' scale at least 1 N)."""
    from flexure.core.analysis.motion_response import PrescribedBalance
    from flexure.core.mechanics.mechanics import Mechanics

    model = build_model(with_motion("stage_planar_3dof", "3", "x", value=0.001))
    sim = Simulator(model, rtol=1e-8, motion_duration=0.04)
    n, free, k = sim.ndof, model.free_dofs, model.prescribed_dofs
    rng = np.random.default_rng(5)
    y = np.concatenate([1e-5 * rng.standard_normal(n), 1e-3 * rng.standard_normal(n)])
    ydot = sim.derivative(t, y)
    q, qdot = sim.q_ref + y[:n], y[n:]
    balance = PrescribedBalance(model, Mechanics(model), increment_path(model, 0.04), np.zeros(1))
    _, _, qddot, efforts, _ = balance.evaluate(t, q[free], qdot[free])
    scale = np.max(np.abs(qddot))
    assert np.max(np.abs(ydot[n:] - qddot)) <= 1e-12 * scale
    assert np.max(np.abs(ydot[n + k] - qddot[k])) <= 1e-13 * 1.0  # u'' (0.001 / 0.04^2)
    state = sim.on_path([t], [np.concatenate([q, qdot])])
    compiled = sim.efforts_along([t], state)[0]
    assert np.max(np.abs(compiled - efforts)) <= 1e-12 * max(np.max(np.abs(efforts)), 1.0)


@pytest.mark.parametrize("t", [0.0, 0.013, 0.05])
def test_the_prescribed_jacobian_against_finite_differences(t):
    """stage_planar_3dof with 3.x prescribed, mid-move and at rest: the analytic Jacobian of
    the prescribed form against central differences of its right-hand side (relative step
    1e-7 of each state's scale) within 1e-5 of each column's largest entry; the input's rows
    and columns of the accelerations exactly zero."""
    model = build_model(with_motion("stage_planar_3dof", "3", "x", value=0.001))
    sim = Simulator(model, rtol=1e-8, motion_duration=0.04)
    n = sim.ndof
    rng = np.random.default_rng(3)
    y = np.concatenate([1e-5 * rng.standard_normal(n), 1e-3 * rng.standard_normal(n)])
    J = sim.jacobian_matrix(t, y)
    k = int(model.prescribed_dofs[0])
    for j in range(2 * n):
        h = 1e-7 * (1e-3 if j < n else 1.0)
        up, down = y.copy(), y.copy()
        up[j] += h
        down[j] -= h
        column = (sim.derivative(t, up) - sim.derivative(t, down)) / (2 * h)
        scale = max(np.max(np.abs(column)), 1.0)
        assert np.max(np.abs(J[:, j] - column)) <= 1e-5 * scale, j
    assert np.all(J[n + k] == 0.0)
    assert np.all(J[n:, k] == 0.0) and np.all(J[n:, n + k] == 0.0)


# -- the command line -----------------------------------------------------------------------

def test_flexure_simulate_moves_a_scene_and_writes_its_effort(capsys, tmp_path):
    """`flexure simulate SCENE --motion-duration T`: the summary names the effort, the CSV
    holds it (the truss's effort at the end, held at 0.101 m: k (0.001 m) - 1 N)."""
    from flexure.core import scene_toml

    path = tmp_path / "moved.toml"
    path.write_text(scene_toml(with_motion("truss_1dof_x", "2", "x", value=0.101), "a test"))
    out_csv = tmp_path / "out.csv"
    code, out, err = run(capsys, "simulate", path, "--t-end", "0.08", "--motion-duration",
                         "0.05", "--method", "esdirk", "--samples", "8", "--out", out_csv)
    assert code == 0, err
    assert "X.effort" in out
    header = out_csv.read_text().splitlines()[0]
    assert header.split(",")[-1] == "X.effort [N]"
    last = np.loadtxt(out_csv, delimiter=",", skiprows=1)[-1]
    assert last[-1] == pytest.approx(945.0 * 0.001 - 1.0, rel=1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_a_warm_simulation_with_prescribed_motion_imports_no_numba(tmp_path, method):
    """The prescribed form's entries load as object code like the others': a warm `flexure
    simulate` of a moved scene does not import numba (the first run may compile)."""

    from flexure.core import scene_toml

    path = tmp_path / "moved.toml"
    path.write_text(scene_toml(with_motion("truss_1dof_x", "2", "x", value=0.101), "a test"))
    code, stdout, loaded = warm_command_modules(
        ["simulate", path, "--t-end", "0.02", "--motion-duration", "0.01", "--method", method],
        "m.split('.')[0] == 'numba' and m.count('.') < 2 and not m.startswith('numba._')", tmp_path)
    assert code == 0, stdout
    assert loaded == [], f"flexure simulate --method {method} imported {loaded}"


def test_flexure_simulate_refuses_a_motion_duration_without_kinematic_inputs(capsys):
    code, _, err = run(capsys, "simulate", scene_path("truss_1dof_x"), "--t-end", "0.01",
                       "--motion-duration", "0.01")
    assert code != 0
    assert "--motion-duration 0.01: 'truss_1dof_x' has no kinematic input" in err


# -- what is refused -------------------------------------------------------------------------

def test_what_does_not_take_kinematic_inputs_yet_is_refused():
    """A Simulator without the move's duration, actuators with kinematic inputs; a duration
    for a model without them, or one that is not a positive number (the sampled loop takes
    them: tests/test_loop_motion.py)."""
    model = moved_truss()
    with pytest.raises(SimulationError, match=r"kinematic inputs \(X\): a time simulation "
                                              r"needs the duration of their move"):
        Simulator(model)
    with pytest.raises(SimulationError, match="duration must be a finite number of seconds "
                                              "> 0"):
        Simulator(model, motion_duration=-1.0)
    with pytest.raises(SimulationError, match="motion_duration 0.1: 'truss_1dof_x' has no "
                                              "kinematic input"):
        Simulator(load_scene("truss_1dof_x"), motion_duration=0.1)
    actuated = with_motion("truss_1dof_x", "2", "x", value=0.101)
    actuated["actuators"] = {"VCM1": {"input": "F", "force_constant": 2.0, "resistance": 2.0,
                                      "inductance": 0.01}}
    with pytest.raises(SimulationError, match=r"kinematic inputs \(X\) and actuators"):
        Simulator(build_model(actuated), motion_duration=0.1)
