"""The compiled loop around the linear plant (core/simulation/linear_loop.py): its step
against the plain matrix-exponential discretisation, its loop against the Python loop around
the same LinearSimulator, its refusals, and a warm run without numba."""

import numpy as np
import pytest
from scipy.linalg import expm

from flexure.controllers import build_loop, run_loop
from flexure.controllers.plants import LinearPlant
from flexure.controllers.sample_loop import linear_loop, prepare_linear_loop, simulate_loop
from flexure.core import LinearSimulator, SimulationError, load_scene
from flexure.core.simulation.linear_loop import run_linear_loop

FS = 4000.0  # Hz


def coil_stage():
    """stage_planar_1dof with a voltage-driven coil: 3 states, one real eigenvalue."""
    from test_loop_actuators import stage

    return stage(drive="voltage", amplifier_gain=2.0)


def open_loop(sim, inputs, outputs, forces, fs):
    """The compiled loop with no feedback: the held inputs are the given forces
    (N+2, n_loops); the positions (N+1, n_loops)."""
    n = len(inputs)
    zero = (np.zeros((1, 1)), np.zeros((1, n)), np.zeros((n, 1)), np.zeros((n, n)))
    samples = forces.shape[0] - 2
    sim.reset()
    _, position, force = run_linear_loop(sim, fs=fs, samples=samples,
                                         reference=np.zeros_like(forces), feedforward=forces,
                                         controller=zero, loop_inputs=inputs,
                                         loop_outputs=outputs)
    np.testing.assert_array_equal(force[:-1], forces[:-2])  # held from each sample
    return position


def matrix_exponential_outputs(sim, inputs, outputs, forces, fs):
    """The same held forces on z_k+1 = e^(A h) z_k + (integral_0^h e^(A s) ds) B du_k (Van
    Loan's block exponential of the state matrix), y = y_start + C (z - z0) + D du."""
    n, m = sim.B.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = sim.A / fs, sim.B / fs
    E = expm(block)
    decay, drive = E[:n, :n], E[:n, n:]
    z = sim.initial_state.copy()
    y = [sim.y_start[outputs]]
    for u in forces[:-2]:
        du = -sim.u0.copy()
        du[inputs] += u
        z = decay @ z + drive @ du
        y.append((sim.y_start + sim.C @ (z - sim.initial_state) + sim.D @ du)[outputs])
    return np.array(y)


def python_steps(sim, outputs, forces, fs):
    """The LinearSimulator's own steps (complex modal, `advance_to`) under the same held
    forces: its outputs (N+1, n_loops)."""
    sim.reset()
    y = [sim.outputs()[outputs]]
    for k, u in enumerate(forces[:-2]):
        sim.set_inputs(u)
        sim.advance_to((k + 1) / fs)
        y.append(sim.outputs()[outputs])
    return np.array(y)


# fs (Hz) -> the bound against the matrix exponential, of the motion: at 1 Hz the stiffest
# modes' lambda h reaches -1.8e7, where expm's scaling and squaring and the modal step part
# by 1.35e-8 (the LinearSimulator's complex modal step as much as the real one)
EXPM_BOUND = {FS: 1e-9, 1000.0: 1e-9, 1.0: 1e-7}


@pytest.mark.parametrize(("scene", "outputs"), [
    ("stage_spatial_19dof", [0]), ("stage_spatial_19dof", [1]), ("coil", [0])])
def test_the_real_modal_step_is_the_matrix_exponentials(scene, outputs):
    """Random held forces (N, scaled to move the stage about 1 mm) for 300 samples at three
    step lengths: the compiled loop's outputs are the block matrix exponential's to 1e-9 of
    the motion (EXPM_BOUND), and the LinearSimulator's own complex modal steps' to 1e-14 of
    the outputs' size.
    The 19-DOF stage starts 1.06 mm from its loaded equilibrium and has every kind of mode:
    at 4 kHz 13 conjugate pairs, 8 real eigenvalues and 4 modes a step forgets
    (e^(lambda h) = 0), at 1 Hz pairs forgotten too; the coil's real eigenvalue is forgotten
    at 1 Hz. Measured against expm: 2.8e-10 on the 19-DOF stage at 1 kHz, what the complex
    modal step gives too (its eigenvectors' cond_1(V) = 8.1e5), 1.35e-8 at 1 Hz; 7e-14 on
    the coil stage (cond_1(V) = 278). Against the complex modal steps: a rounding unit of
    y = 0.1 m, 6e-16 of x's motion."""
    from flexure.core.simulation.linear_loop import RealModes

    model = coil_stage() if scene == "coil" else load_scene(scene)
    sim = LinearSimulator(model)
    assert sim.modal
    if scene != "coil":
        groups = RealModes.of(sim, 1 / FS, outputs)
        assert (groups.pairs.size, groups.reals.size, groups.gone.size) == (13, 8, 4)
    forces = np.random.default_rng(3).normal(size=(302, 1))
    for fs, bound in EXPM_BOUND.items():  # a new step length: new factors
        got = open_loop(sim, [0], outputs, forces, fs)
        assert sim.time == 300 / fs
        expected = matrix_exponential_outputs(sim, [0], outputs, forces, fs)
        motion = np.max(np.abs(expected - expected[0]))
        assert motion > 1e-6
        assert np.max(np.abs(got - expected)) < bound * motion
        complex_steps = python_steps(sim, outputs, forces, fs)
        assert np.max(np.abs(got - complex_steps)) < 1e-14 * np.max(np.abs(complex_steps))


def python_and_compiled(model, **options):
    """(simulate_loop's, linear_loop's) t, r, y, u around one LinearPlant, and the plant's
    modal state and time after each."""
    loop, design = build_loop(model, **options)
    plant = LinearPlant(model)
    assert prepare_linear_loop(plant, loop)
    runs = []
    for run in (simulate_loop, linear_loop):
        runs.append((run(plant, loop, design), plant.simulator.modal_state,
                     plant.simulator.time, plant.simulator.inputs))
    return runs


@pytest.mark.parametrize(("scene", "options"), [
    ("stage_planar_3dof", {}),
    ("coil", {}),
    ("stage_spatial_19dof", {"quantum": 1e-9, "disturbance": 0.05}),
])
def test_the_compiled_linear_loop_is_the_python_loop(scene, options):
    """The same samples, within round-off: positions within 1e-12 of the 1 mm stroke
    (measured 3e-18 m or better), forces within 1e-12 of the largest (measured 3e-14), the
    state at t_N within 1e-12 of its size (4e-14), the same time, the held inputs within
    1e-12 of the largest force."""
    model = coil_stage() if scene == "coil" else load_scene(scene)
    stroke = 1e-3
    (python, w_python, t_python, u_python), (compiled, w_compiled, t_compiled, u_compiled) = (
        python_and_compiled(model, stroke=stroke, duration=0.1, settle=0.02, **options))
    (t, r, y, u), (t_c, r_c, y_c, u_c) = python, compiled
    assert np.array_equal(t, t_c) and np.array_equal(r, r_c)
    assert np.ptp(y[:, 0]) > 0.9 * stroke  # it moved
    assert np.max(np.abs(y_c - y)) < 1e-12 * stroke
    assert np.max(np.abs(u_c - u)) < 1e-12 * np.max(np.abs(u))
    assert np.max(np.abs(w_compiled - w_python)) < 1e-12 * np.max(np.abs(w_python))
    assert t_compiled == t_python == t[-1]
    assert np.max(np.abs(u_compiled - u_python)) < 1e-12 * np.max(np.abs(u))


@pytest.mark.slow  # 40 s: the 507-DOF model's linearisation, eigenvectors and design
def test_the_manipulators_compiled_linear_loop_is_its_python_loop():
    """`flexure loop manipulator_reduced --plant linear`: the compiled loop's positions are
    the Python loop's within 1e-12 of the 1 mm stroke at every sample (measured within 3e-17
    m), and so are its max |error| (1.66e-9 m; the same to the bit on one CPU, 2.8e-17 m
    apart on another: a difference of positions carries their round-off, not its own) and
    its final positions (1e-12 relative)."""
    (python, *_), (compiled, *_) = python_and_compiled(
        load_scene("manipulator_reduced"), stroke=1e-3, duration=1.0, settle=0.25)
    (_, r, y, _), (_, _, y_c, _) = python, compiled
    error, error_c = np.max(np.abs(r - y)), np.max(np.abs(r - y_c))
    assert 1.6e-9 < error < 1.7e-9
    assert abs(error_c - error) < 1e-12 * 1e-3
    assert np.max(np.abs(y_c[-1] - y[-1])) < 1e-12 * np.max(np.abs(y[-1]))
    assert np.max(np.abs(y_c - y)) < 1e-12 * 1e-3


def test_run_loop_takes_the_compiled_loop_on_the_linear_plant(monkeypatch):
    """run_loop(plant="linear") runs linear_loop's compiled run for a designed controller,
    and simulate_loop for a callable one."""
    from flexure.controllers import runner
    from flexure.core.simulation import linear_loop as module

    calls = []
    real = module.run_linear_loop

    def counted(*args, **kwargs):
        calls.append(args)
        return real(*args, **kwargs)

    monkeypatch.setattr(module, "run_linear_loop", counted)
    short = {"stroke": 1e-4, "duration": 0.02, "settle": 0.005, "plant": "linear"}
    compiled = runner.run_loop("stage_planar_1dof", **short)
    assert len(calls) == 1 and compiled.summary()["passed"]
    gain = 3e3  # N/m: a slow proportional loop, run by Python
    run_loop("stage_planar_1dof", controller=lambda k, e: gain * e, **short)
    assert len(calls) == 1


def test_an_overflow_is_refused_and_the_simulator_kept_at_the_last_sample():
    """100 N on the 1-DOF stage's bar, above its buckling load: the open loop's state
    overflows at 1 Hz within 30 s (growth rate 34.7 1/s). SimulationError naming the time and
    the rate; the simulator stays at the last sample's time and state, finite."""
    model = load_scene("stage_planar_1dof", overrides={"nodes.3.force": [0.0, -100.0]})
    sim = LinearSimulator(model)
    with pytest.raises(SimulationError, match=r"t = (\d+) s: the linearised state overflows "
                                              r"over the step to .* growth rate: 34.6"):
        open_loop(sim, [0], [0], np.full((32, 1), 1e-3), 1.0)
    assert 0 < sim.time < 30 and sim.time == int(sim.time)
    assert np.all(np.isfinite(sim.modal_state)) and np.all(np.isfinite(sim.outputs()))


def test_a_loop_the_compiled_run_cannot_take_is_refused():
    sim = LinearSimulator(load_scene("stage_planar_1dof"))
    forces = np.zeros((4, 1))
    sim.set_inputs([0.0])
    sim.advance_to(1e-3)
    with pytest.raises(SimulationError, match="starts at t = 0; the simulator is at "
                                              "t = 0.001 s: reset it first"):
        run_linear_loop(sim, fs=FS, samples=2, reference=forces, feedforward=forces,
                        controller=(np.zeros((1, 1)),) * 4, loop_inputs=[0],
                        loop_outputs=[0])
    sim.reset()
    with pytest.raises(SimulationError, match="1 loop inputs and 2 loop outputs"):
        run_linear_loop(sim, fs=FS, samples=2, reference=forces, feedforward=forces,
                        controller=(np.zeros((1, 1)),) * 4, loop_inputs=[0],
                        loop_outputs=[0, 1])
    dense = LinearSimulator(load_scene("stage_planar_1dof"), modal=False)
    with pytest.raises(SimulationError, match="steps the modal form"):
        run_linear_loop(dense, fs=FS, samples=2, reference=forces, feedforward=forces,
                        controller=(np.zeros((1, 1)),) * 4, loop_inputs=[0],
                        loop_outputs=[0])


def test_a_warm_linear_loop_imports_no_numba(tmp_path):
    """The compiled linear loop's C entry loads as object code in a warm process: `flexure
    loop --plant linear` imports no numba (the first run may load it through numba)."""
    from cli_runs import warm_command_modules

    code, stdout, loaded = warm_command_modules(
        ["loop", "stage_planar_3dof", "--plant", "linear", "--no-plot"],
        "m in ('numba', 'numba.core')", tmp_path)
    assert code == 0, stdout
    assert loaded == [], f"flexure loop --plant linear imported {loaded}"
