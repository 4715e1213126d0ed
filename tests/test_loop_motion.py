"""The closed loop on a scene with a kinematic input: the chain of `kinematic_scenes` (node 1
prescribed, node 2 a DOF) with a force F on node 2, whose loop holds x2 on its move while
node 1, the base, moves 2 mm along the scene's quintic: a known motion the loop rides on."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

from cli_runs import run  # noqa: E402
from compiled_loops import run_compiled_loop  # noqa: E402
from kinematic_scenes import C2, K1, K2, chain  # noqa: E402

from flexure.controllers import build_loop  # noqa: E402
from flexure.controllers.errors import LoopError  # noqa: E402
from flexure.controllers.plants import InProcessPlant  # noqa: E402
from flexure.controllers.runner import run_loop, simulate_loop  # noqa: E402
from flexure.core import Simulator, build_model, load_scene  # noqa: E402

BASE = 2e-3  # m: node 1's move
STROKE, DURATION, SETTLE, FS = 1e-3, 0.05, 0.02, 2000.0  # m, s, s, Hz
X1 = 0.1  # m: node 1's start


def pushed_chain(base=BASE):
    """The chain with the force input F on node 2's x and node 1 moved by `base` (m)."""
    data = chain()
    data["inputs"]["F"] = {"node": "2", "coordinate": "x"}
    data["inputs"]["u"]["value"] = X1 + base
    return build_model(data)


@pytest.fixture(scope="module")
def model():
    return pushed_chain()


def loop_of(model):
    return build_loop(model, stroke=STROKE, duration=DURATION, settle=SETTLE, fs=FS,
                      crossover=200.0)


def reference_loop(model, controller, design, *, method, rtol):
    """The loop written out: a Simulator moved along the quintic over DURATION, stepped
    sample by sample with `advance_to` under the controller's `step` (one sample of delay,
    the force held): position (N+1,) m and force (N+1,) N."""
    sim = Simulator(model, method=method, rtol=rtol, motion_duration=DURATION)
    i, j = design.pairs[0].input_index, design.pairs[0].output_index
    N = controller.samples
    position, force = np.empty(N + 1), np.empty(N + 1)
    controller.reset()
    y, u = sim.outputs()[[j]], controller.initial_output()
    for k in range(N):
        position[k], force[k] = y[0], u[0]
        u_next, _ = controller.step(k, y)
        held = np.zeros(len(sim.input_names))
        held[i] = u[0]
        sim.set_inputs(held)
        sim.advance_to((k + 1) / FS)
        y, u = sim.outputs()[[j]], u_next
    position[N], force[N] = y[0], force[N - 1]
    return position, force, sim


@pytest.mark.parametrize("method", ["esdirk2", "esdirk3", "cvode-bdf"])
def test_the_compiled_loop_on_a_moving_base_is_the_python_loop_bit_for_bit(model, method):
    """run_sampled_loop on a Simulator moved over DURATION against controllers' Python loop
    around an InProcessPlant moved alike (`simulate_loop`): the same positions and forces to
    the bit (the same kernels evaluate the path at the same times), and the base where it
    ends."""
    controller, design = loop_of(model)
    _, _, position, force = simulate_loop(
        InProcessPlant(model, method=method, rtol=1e-7, motion_duration=DURATION),
        controller, design)
    sim = Simulator(model, method=method, rtol=1e-7, motion_duration=DURATION)
    _, position_c, force_c = run_compiled_loop(sim, controller, design)
    assert np.array_equal(position_c, position)
    assert np.array_equal(force_c, force)
    k = model.prescribed_dofs[0]
    assert sim.prescribed_values()[0][0] == pytest.approx(X1 + BASE, abs=1e-15)
    # the state's entry, integrated from u'': within the integrator's tolerance of the path
    # (measured 2.4e-8 m on esdirk2, 1.0e-8 on CVODE)
    assert abs(sim.q[k] - (X1 + BASE)) < 1e-7


def test_the_compiled_loop_agrees_with_a_tight_reference_written_out(model):
    """The compiled loop (esdirk2 at the loop's rtol 1e-5) against `reference_loop` on CVODE
    at rtol 1e-11: positions within 2e-8 m (2e-5 of the stroke; measured 5.2e-9) and forces
    within 2e-4 N (measured 3.4e-5) of the reference, while the base's move changes the
    positions by over 1e-4 m (so the motion, at its right time, is what they agree on)."""
    controller, design = loop_of(model)
    position, force, _ = reference_loop(model, controller, design, method="cvode-bdf",
                                        rtol=1e-11)
    sim = Simulator(model, method="esdirk2", rtol=1e-5, motion_duration=DURATION)
    _, position_c, force_c = run_compiled_loop(sim, controller, design)
    position_error = np.max(np.abs(position_c[:, 0] - position))
    force_error = np.max(np.abs(force_c[:, 0] - force))
    print(f"compiled esdirk2 against CVODE 1e-11: {position_error:.3g} m, {force_error:.3g} N")
    assert position_error < 2e-8
    assert force_error < 2e-4
    still = pushed_chain(base=0.0)
    still_controller, still_design = loop_of(still)
    sim_still = Simulator(still, method="esdirk2", rtol=1e-5, motion_duration=DURATION)
    _, position_still, _ = run_compiled_loop(sim_still, still_controller, still_design)
    assert np.max(np.abs(position_still[:, 0] - position)) > 1e-4


def test_run_loop_reports_the_effort_of_the_moved_input(model):
    """`run_loop` on the in-process plant: the motion over the loop's duration by default,
    the summary's kinematic input with its effort at the end, which at rest balances the
    springs on node 1: K1 d1 + K2 (d1 - d2) + C2 (v1 - v2) (v1 = 0 after the move; v2 from
    the last two samples), within 2e-5 N (measured 2.2e-6)."""
    result = run_loop(model, stroke=STROKE, duration=DURATION, settle=SETTLE, fs=FS,
                      crossover=200.0)
    motion = result.summary()["kinematic_inputs"]["u"]
    assert motion["start"] == X1 and motion["value"] == pytest.approx(X1 + BASE)
    assert motion["motion_duration"] == DURATION
    d2 = result.position[-1, 0] - 0.2
    v2 = (result.position[-1, 0] - result.position[-2, 0]) * FS
    balance = K1 * BASE + K2 * (BASE - d2) - C2 * v2
    print(f"effort {motion['effort_end']!r} N against {balance!r} N")
    assert motion["effort_end"] == pytest.approx(balance, abs=2e-5)


def test_motion_duration_reaches_the_plant(model):
    """A motion_duration of its own: the base at its value by then, held after."""
    result = run_loop(model, stroke=STROKE, duration=DURATION, settle=SETTLE, fs=FS,
                      crossover=200.0, motion_duration=0.01)
    assert result.summary()["kinematic_inputs"]["u"]["motion_duration"] == 0.01


def test_a_callable_controller_runs_the_python_loop_on_the_moving_base(model):
    """A callable feedback takes the Python loop around the InProcessPlant (a call per
    sample): the base moved there too, and its effort reported."""
    result = run_loop(model, stroke=STROKE, duration=DURATION, settle=SETTLE, fs=FS,
                      crossover=200.0, controller=lambda k, e: 300.0 * e)
    motion = result.summary()["kinematic_inputs"]["u"]
    assert motion["motion_duration"] == DURATION
    assert 1.5 < motion["effort_end"] < 2.5  # K1 d1 = 1.6 N plus spring b's share


@pytest.mark.parametrize("plant", ["linear", "fmu", "libcosim"])
def test_a_plant_that_does_not_move_the_inputs_refuses_them(model, plant):
    """Named: the plant and the inputs, before anything is designed or built."""
    with pytest.raises(LoopError, match=rf"plant '{plant}' does not move the kinematic inputs "
                                        r"\(u\) of 'chain'"):
        run_loop(model, plant=plant, stroke=STROKE, duration=DURATION, fs=FS)


@pytest.mark.parametrize("value, message", [
    (-1.0, "motion_duration must be a finite number of seconds > 0, got -1.0"),
    (float("nan"), "motion_duration must be a finite number of seconds > 0, got nan"),
    ("0.1", "motion_duration must be a finite number of seconds > 0, got '0.1'"),
    (True, "motion_duration must be a finite number of seconds > 0, got True")])
def test_a_bad_motion_duration_is_refused(model, value, message):
    with pytest.raises(LoopError, match=message):
        run_loop(model, stroke=STROKE, duration=DURATION, fs=FS, motion_duration=value)


def test_a_motion_duration_without_kinematic_inputs_is_refused():
    with pytest.raises(LoopError, match="motion_duration 0.1: 'stage_planar_1dof' has no "
                                        "kinematic input"):
        run_loop(load_scene("stage_planar_1dof"), motion_duration=0.1)


CHAIN_TOML = f"""
[scene]
name = "chain"
[sections.a]
kx = {K1}
cx = 0.3
[sections.b]
kx = {K2}
cx = {C2}
[nodes.0]
position = [0.0, 0.0]
fixed = ["x", "y"]
[nodes.1]
position = [{X1}, 0.0]
mass = 0.4
[nodes.2]
position = [0.2, 0.0]
mass = 0.25
dof = ["x"]
[elements.a]
type = "PLSPRING"
nodes = ["0", "1"]
section = "a"
released = ["e1"]
[elements.b]
type = "PLSPRING"
nodes = ["1", "2"]
section = "b"
released = ["e1"]
[inputs.u]
kind = "motion"
node = "1"
coordinate = "x"
value = {X1 + BASE}
[inputs.F]
node = "2"
coordinate = "x"
[outputs.x2]
node = "2"
coordinate = "x"
"""


def test_flexure_loop_on_a_scene_with_a_kinematic_input(tmp_path, capsys):
    """The command: --motion-duration reaches the summary, with the input's effort; the
    table names the input; --plant linear is refused naming the input."""
    scene = tmp_path / "chain.toml"
    scene.write_text(CHAIN_TOML)
    common = ["loop", str(scene), "--stroke", "1e-3", "--duration", "0.05", "--settle",
              "0.02", "--fs", "2000", "--crossover", "200", "--no-plot"]
    code, out, _ = run(capsys, *common, "--motion-duration", "0.03", "--json")
    assert code == 0
    motion = json.loads(out)["kinematic_inputs"]["u"]
    assert motion["motion_duration"] == 0.03 and motion["effort_end"] > 1.5
    code, out, _ = run(capsys, *common)
    assert code == 0 and "kinematic input u" in out and "u.effort at the end" in out
    code, _, err = run(capsys, *common, "--plant", "linear")
    assert code != 0 and "plant 'linear' does not move the kinematic inputs (u)" in err
