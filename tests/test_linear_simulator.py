"""The LinearSimulator: the scene's state space stepped exactly under the held input, against
python-control's zero-order-hold discretisation, the matrix exponential, and the nonlinear
Simulator where the model is nearly linear; and the loop's linear plant around it."""

import numpy as np
import pytest

from flexure.controllers.runner import run_loop
from flexure.core import LinearSimulator, SimulationError, load_scene, state_space

FS = 4000.0  # Hz


def _drive(sim, inputs, fs=FS):
    """The simulator's outputs after each sample of held `inputs` (N, n_inputs)."""
    out = []
    for k, u in enumerate(inputs):
        sim.set_inputs(u)
        sim.advance_to((k + 1) / fs)
        out.append(sim.outputs())
    return np.array(out)


@pytest.fixture(scope="module")
def stage3():
    return load_scene("stage_planar_3dof")


def test_the_modal_step_is_python_controls_zero_order_hold(stage3):
    """x_k+1 = Ad x_k + Bd u_k, y = C x with python-control's c2d (zoh) of the same state
    space: the same outputs to 1e-10 of their range."""
    import control

    sim = LinearSimulator(stage3)
    assert sim.modal
    u = np.random.default_rng(1).normal(size=(300, len(sim.u0)))
    for fs in (FS, 1000.0):  # a new step length: new factors
        sys_d = control.c2d(state_space(stage3), 1 / fs, method="zoh")
        x = sim.initial_state.copy()
        expected = []
        for uk in u:
            x = sys_d.A @ x + sys_d.B @ uk
            expected.append(sim.y_start + sys_d.C @ (x - sim.initial_state))
        sim.reset()
        got = _drive(sim, u, fs)
        scale = np.max(np.abs(np.array(expected) - sim.y_start))
        assert np.max(np.abs(got - expected)) < 1e-10 * scale


def test_the_modal_step_is_the_matrix_exponentials():
    """The 19-DOF spatial stage (38 states, loaded away from its start): modal steps and the
    Van Loan matrix exponential agree to 1e-9 of the motion, at two step lengths."""
    model = load_scene("stage_spatial_19dof")
    modal, dense = LinearSimulator(model), LinearSimulator(model, modal=False)
    assert modal.modal and not dense.modal
    u = np.random.default_rng(2).normal(size=(200, 1))
    for fs in (FS, 1000.0):
        modal.reset(), dense.reset()
        a, b = _drive(modal, u, fs), _drive(dense, u, fs)
        assert np.max(np.abs(a - b)) < 1e-9 * np.max(np.abs(b - b[0]))


def test_it_starts_at_the_scenes_initial_coordinates_at_rest():
    """Under the 19-DOF stage's constant 1 N the equilibrium is 1.06 mm away; it starts
    at the initial coordinates with the outputs Simulator starts with (x = 0 on its DOF,
    y = 0.1 m off the DOFs), and with no input settles where the nonlinear statics put the
    bar: x to 1e-7 (a DOF: measured 2.6e-11 m), y to the second order of the 1.06 mm
    (measured 6.7 um)."""
    from flexure.core import static_equilibrium

    model = load_scene("stage_spatial_19dof")
    sim = LinearSimulator(model)
    np.testing.assert_allclose(sim.outputs(), [0.0, 0.1], rtol=0, atol=1e-15)
    sim.set_inputs([0.0])
    sim.advance_to(0.01)
    assert 0 < sim.outputs()[0] < 2.2e-3  # swinging toward 1.06 mm
    sim.advance_to(200.0)  # the slowest mode's decay time is under 10 s
    coordinates = static_equilibrium(model).coordinates()
    x, y = sim.outputs()
    assert abs(x - coordinates["3.x"]) < 1e-10  # m, 1e-7 of it: the statics and rounding
    assert 1e-6 < abs(y - coordinates["3.y"]) < 1e-5


@pytest.mark.parametrize("scene, tolerance", [
    ("stage_planar_1dof", 1e-6 * 1e-5), ("stage_planar_3dof", 1e-6 * 1e-5),
    # linearised at its loaded equilibrium 1.06 mm from where the loop holds it: measured
    # 8.2 nm apart whatever the stroke, the stiffness's change over that 1.06 mm
    pytest.param("stage_spatial_19dof", 1e-8, marks=pytest.mark.slow)])
def test_the_linear_loop_is_the_nonlinear_loop_for_a_small_move(scene, tolerance):
    """A 10 um move: the loops' positions (m) on the linear plant and on the nonlinear plant
    (at rtol 1e-9) agree (measured on the planar stages: 2.5e-8 of the stroke or better), and
    the linear loop tracks."""
    linear = run_loop(scene, stroke=1e-5, plant="linear")
    nonlinear = run_loop(scene, stroke=1e-5, rtol=1e-9)
    assert np.max(np.abs(linear.position - nonlinear.position)) < tolerance
    assert linear.summary()["passed"]
    assert linear.settings["method"] == "exact" and linear.settings["rtol"] is None


def test_the_linear_loop_linearises_once(stage3, monkeypatch):
    """The plant, the feedback's design and the modal feedforward share one linearisation,
    and the loop is the one a feedforward of its own linearisation gives."""
    import flexure.core
    from flexure.controllers import low_frequency_model

    reference = run_loop(stage3, stroke=1e-5, plant="linear",
                         feedforward_model=low_frequency_model(stage3))
    calls = []
    linearize = flexure.core.linearize

    def counted(*args, **kwargs):
        calls.append(args)
        return linearize(*args, **kwargs)

    monkeypatch.setattr(flexure.core, "linearize", counted)
    shared = run_loop(stage3, stroke=1e-5, plant="linear")
    assert len(calls) == 1
    np.testing.assert_array_equal(shared.position, reference.position)
    np.testing.assert_array_equal(shared.force, reference.force)


def test_the_linear_loop_runs_through_a_coil():
    """A voltage-driven coil adds its current to the state; the linear loop through it
    follows the nonlinear one to 1e-6 of a 1 mm stroke."""
    from test_loop_actuators import stage

    model = stage(drive="voltage", amplifier_gain=2.0)
    linear = run_loop(model, stroke=1e-3, plant="linear")
    nonlinear = run_loop(model, stroke=1e-3, rtol=1e-9)
    assert LinearSimulator(model).A.shape[0] == 2 * model.ndof + 1
    assert np.max(np.abs(linear.position - nonlinear.position)) < 1e-6 * 1e-3


def test_bad_inputs_and_times_are_refused(stage3):
    sim = LinearSimulator(stage3)
    n = len(sim.u0)
    with pytest.raises(SimulationError, match=rf"t = 0 s: expected {n} inputs \(F\), got 2"):
        sim.set_inputs(np.zeros(n + 1))
    with pytest.raises(SimulationError, match="t = 0 s: input 'F' is not finite"):
        sim.set_inputs(np.full(n, np.nan))
    sim.advance_to(1e-3)
    for t_end in (1e-3, 0.5e-3, np.inf, np.nan):
        with pytest.raises(SimulationError, match="t = 0.001 s: advance to t_end = .*: "
                                                  "expected a finite time after the current"):
            sim.advance_to(t_end)


@pytest.mark.parametrize("modal", [True, False])
def test_a_state_that_overflows_is_refused_and_the_simulator_kept(recwarn, modal):
    """100 N on the 1-DOF stage's bar, above its buckling load of 78.75 N: the straight
    equilibrium is unstable (growth rate 34.7 1/s), and 100 s of it overflow the state, in
    either way of stepping. SimulationError naming the time and the rate, no numpy warning,
    and the simulator stays at its last state."""
    model = load_scene("stage_planar_1dof", overrides={"nodes.3.force": [0.0, -100.0]})
    sim = LinearSimulator(model, modal=modal)
    assert abs(sim.growth_rate - 34.66) < 0.05
    sim.set_inputs([1e-3])
    sim.advance_to(1e-3)
    before = sim.outputs()
    with pytest.raises(SimulationError, match=r"t = 0.001 s: the linearised state overflows "
                                              r".* fastest growth rate: 34.6"):
        sim.advance_to(100.0)
    assert sim.time == 1e-3 and np.array_equal(sim.outputs(), before)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


def test_reset_keeps_the_inputs_as_simulator_does(stage3):
    """After reset both simulators hold the inputs set before it, and from rest they agree
    on a small motion (the stage is nearly linear: 1e-4 of it)."""
    from flexure.core import Simulator

    linear, nonlinear = LinearSimulator(stage3), Simulator(stage3, rtol=1e-10)
    for sim in (linear, nonlinear):
        sim.set_inputs([1e-3])
        sim.reset()
        sim.advance_to(0.05)
    assert linear.inputs.tolist() == nonlinear.inputs.tolist() == [1e-3]
    motion = np.max(np.abs(linear.outputs() - linear.y_start))
    assert motion > 0
    assert np.max(np.abs(linear.outputs() - nonlinear.outputs())) < 1e-4 * motion


def test_long_runs_keep_one_set_of_factors(stage3):
    """k / fs - (k - 1) / fs wobbles by a rounding unit of t, more the longer the run (at 4
    kHz: 11 step lengths in the first second; in the 60th, 2.4e-11 of the step): neither
    second computes the step's factors again at a wobble (one set for each step length)."""
    sim = LinearSimulator(stage3)
    sim.set_inputs(np.zeros(len(sim.u0)))
    for k in range(1, 4_001):
        sim.advance_to(k / FS)
    assert sim.factor_updates == 1
    sim.advance_to(236_000 / FS)  # one step of 58 s, with factors of its own
    assert sim.factor_updates == 2
    for k in range(236_001, 240_001):
        sim.advance_to(k / FS)
    assert sim.factor_updates == 3
    sim.advance_to(60.01)
    assert sim.factor_updates == 4


def test_ill_conditioned_eigenvectors_take_the_matrix_exponential(stage3, monkeypatch):
    """Above MODAL_CONDITION it steps with e^(Ah) (the switch, with the threshold
    lowered below this model's condition number)."""
    from flexure.core.simulation import linear_simulator

    assert LinearSimulator(stage3).modal
    monkeypatch.setattr(linear_simulator, "MODAL_CONDITION", 1.0)
    assert not LinearSimulator(stage3).modal


def test_flexure_loop_runs_on_the_linear_plant(capsys, tmp_path):
    """`flexure loop --plant linear --move ...`: the path defaults to the linearised statics
    (the plant's own), and the loop tracks."""
    import json

    from cli_runs import run

    code, out, _ = run(capsys, "loop", "stage_planar_3dof", "--plant", "linear",
                       "--move", "3.x=1e-3", "--duration", "0.2", "--settle", "0.05",
                       "--no-plot", "--json")
    assert code == 0
    summary = json.loads(out)
    assert summary["plant"] == "linear" and summary["passed"]
    assert summary["path"]["kind"] == "linear"
    code, out, _ = run(capsys, "loop", "stage_planar_3dof", "--plant", "linear",
                       "--move", "3.x=1e-3", "--path", "nonlinear", "--duration", "0.2",
                       "--settle", "0.05", "--no-plot", "--json")
    assert code == 0 and json.loads(out)["path"]["kind"] == "nonlinear"
