"""The integrator contract, over every registered method (flexure.core.simulation.methods), the
way tests/test_elements.py runs over every element; and the one list of methods.

The contract (each method at RTOL, on a planar and a spatial scene with an input step):
- its `Stepper` implements the interface and is the registry's;
- the same answers: the outputs just before an input change, just after it (the step after
  the restart: had the change entered late or early, this is where it shows) and at the end
  are within BOUND x RTOL of the run's motion of a tight-tolerance reference (cvode-bdf at
  REFERENCE_RTOL) run with the same inputs;
- the restart point and state round trip: a snapshot at the input change (get_state), advance,
  set_state, advance again gives the same state and outputs bit for bit, also in a simulator
  of its own;
- statistics present (steps, evaluations, wall time; the stepper's own counts);
- kinematic inputs: the chain's node 1 moved by the scene's quintic, its free mass's position
  and velocity and the input's effort within MOTION_BOUND x RTOL of the motion of the same
  reference; a host's steps (`move_to`) restart from a snapshot bit for bit;
- the compiled sampled loop: the methods with `compiled_loop` give a Python loop's numbers bit
  for bit, the others are refused by name.
"""

import ast
import inspect
from pathlib import Path

import numpy as np
import pytest
from kinematic_scenes import X0, chain, motion
from test_engine import check_compiled_loop_against_python_loop

from flexure.core import Simulator, build_model, load_scene, run_sampled_loop
from flexure.core.engine import engine
from flexure.core.errors import SimulationError
from flexure.core.simulation import methods
from flexure.core.simulation.methods import (
    COMPILED_LOOP_METHODS,
    METHOD_TABLE,
    METHODS,
    REGISTRY,
)
from flexure.core.simulation.stepper import Stepper

PACKAGE = Path(methods.__file__).resolve().parents[2]  # flexure/: core, controllers, fmu
RTOL = 1e-6
REFERENCE_RTOL = 1e-12
# The bound on each method's error, in units of RTOL times the motion (the largest change of
# an output over the run, 9.1e-5 m on both scenes). Measured on these runs (the largest of the
# three times and two scenes, at RTOL = 1e-6): cvode-bdf 4.4, cvode-adams 0.51, ida 1.4,
# esdirk 1.7, esdirk3 1.9, esdirk2 24 (TR-BDF2's second order: its error per step is within
# rtol, and 30 steps add up on the spatial stage). BOUND leaves a factor 2 to 3 for another
# CPU's rounding; a new method states its own here if it needs more.
BOUND = {"esdirk2": 60.0}
DEFAULT_BOUND = 10.0
# scene: (input held first, input after the change)
SCENES = {"stage_planar_3dof": (1.0, -0.5), "stage_spatial_1dof": (1.0, -0.5)}
T_CHANGE, T_AFTER, T_END = 4e-3, 4.25e-3, 8e-3  # s: the input change, just after, the end
# The kinematic inputs' part: the chain (tests/kinematic_scenes.py) with node 1 moved 1 mm in
# MOVE s, read at MOTION_TIMES (during, at the end of and after the move). The errors in units
# of RTOL times the motion of x2, v2 and the effort (1.2 mm, 0.040 m/s, 1.08 N) measured at
# RTOL = 1e-6, the largest of the three: cvode-bdf 8.0, cvode-adams 0.31, ida 1.8, esdirk 2.8,
# esdirk3 5.1, esdirk2 36; the bounds leave a factor 2.5.
MOVE, MOTION_TIMES = 0.04, (0.02, 0.04, 0.06)
MOTION_BOUND = {"esdirk2": 90.0}
MOTION_DEFAULT_BOUND = 20.0


def run(scene, method, rtol):
    """The scene's first input at the first value to T_CHANGE, then at the second to T_AFTER
    and T_END: the simulator and its outputs (m, rad) at the three times (3, n_outputs)."""
    first, second = SCENES[scene]
    sim = Simulator(load_scene(scene), method=method, rtol=rtol)
    start = sim.outputs().copy()
    u = np.zeros(len(sim.input_names))
    u[0] = first
    sim.set_inputs(u)
    sim.advance_to(T_CHANGE)
    outputs = [sim.outputs().copy()]
    u[0] = second
    sim.set_inputs(u)
    for t in (T_AFTER, T_END):
        sim.advance_to(t)
        outputs.append(sim.outputs().copy())
    return sim, start, np.array(outputs)


_references = {}


def reference(scene):
    """The tight run's outputs at the three times, and its motion (m): the largest
    distance of an output from its start."""
    if scene not in _references:
        _, start, outputs = run(scene, "cvode-bdf", REFERENCE_RTOL)
        _references[scene] = outputs, float(np.max(np.abs(outputs - start)))
    return _references[scene]


# -- the one list of methods --------------------------------------------------------------------
def test_every_list_of_methods_is_the_registry():
    """The command line, the Simulator, the FMU, the work-precision study and the integrator
    modules take their methods from the registry: adding one in one place only fails here."""
    import flexure.core as core
    from flexure.controllers import cli as loop_cli
    from flexure.core.cli import build_parser
    from flexure.core.simulation import (
        esdirk_method,
        sampled_loop,
        simulator,
        sundials,
        workprecision,
    )
    from flexure.fmu import scene_slave

    def choices(parser, command):
        sub = next(a for a in parser._actions if a.dest == "command").choices[command]
        return tuple(next(a for a in sub._actions if a.dest == "method").choices)

    assert core.METHODS == simulator.METHODS == METHODS == tuple(REGISTRY)
    assert choices(build_parser(["simulate"]), "simulate") == METHODS
    assert loop_cli.LOOP_METHODS == METHODS
    assert sorted(scene_slave.METHODS) == sorted(METHODS)
    assert sundials.METHODS == tuple(m.name for m in METHOD_TABLE if m.module == "sundials")
    assert sorted(esdirk_method.TABLEAUS) == sorted(m.variant for m in METHOD_TABLE
                                                    if m.module == "esdirk")
    assert set(METHODS) <= set(workprecision.ALL_METHODS)
    assert {m.module for m in METHOD_TABLE if m.compiled_loop} <= set(sampled_loop.DRIVERS)


@pytest.mark.parametrize("name", METHODS)
def test_every_method_has_a_stepper_of_its_registry_entry(name):
    entry = REGISTRY[name]
    cls = entry.stepper_class()
    assert issubclass(cls, Stepper) and not inspect.isabstract(cls)
    for op in entry.operations:  # the engine operations it connects
        assert isinstance(getattr(engine, op), int), op
    assert entry.order >= 1 and entry.summary
    assert set(entry.options) <= {"max_order", "finite-difference", "input_functions"}


def test_no_module_keeps_a_list_of_method_names_of_its_own():
    """A tuple, list or set literal naming two or more registered methods anywhere in the
    package but methods.py is a second list, which a new method would miss."""
    found = []
    for path in (p for part in ("core", "controllers", "fmu")
                 for p in (PACKAGE / part).rglob("*.py")):
        text = path.read_text()
        # a literal naming two methods has two of them quoted; parse only such files
        quoted = sum(text.count(f'"{name}"') + text.count(f"'{name}'") for name in REGISTRY)
        if path.name == "methods.py" or quoted < 2:
            continue
        for node in ast.walk(ast.parse(text, str(path))):
            if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
                names = [e.value for e in node.elts
                         if isinstance(e, ast.Constant) and e.value in REGISTRY]
                if len(names) >= 2:
                    found.append(f"{path.relative_to(PACKAGE)}:{node.lineno} {names}")
    assert found == []


# -- the contract over every method ---------------------------------------------------------
@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("method", METHODS)
def test_the_same_answers_within_the_methods_tolerance(method, scene):
    sim, start, outputs = run(scene, method, RTOL)
    assert isinstance(sim.integrator, Stepper) and sim.integrator.method is REGISTRY[method]
    expected, motion = reference(scene)
    assert motion > 1e-7  # it moved
    error = np.max(np.abs(outputs - expected), axis=1) / (RTOL * motion)
    # before the change, just after it, at the end
    assert np.all(error <= BOUND.get(method, DEFAULT_BOUND)), (method, scene, error)
    assert sim.time == T_END


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("method", METHODS)
def test_a_snapshot_restarts_bit_for_bit(method, scene):
    """get_state at the input change, advance, set_state, advance: the same numbers, in the
    same simulator and in a new one (the restart point holds what the stepper learnt)."""
    first, second = SCENES[scene]
    sim = Simulator(load_scene(scene), method=method, rtol=RTOL)
    u = np.zeros(len(sim.input_names))
    u[0] = first
    sim.set_inputs(u)
    sim.advance_to(T_CHANGE)
    u[0] = second
    sim.set_inputs(u)
    snapshot = sim.get_state()
    runs = []
    for target in (sim, sim, Simulator(load_scene(scene), method=method, rtol=RTOL)):
        target.set_state(snapshot)
        target.advance_to(T_AFTER)
        target.advance_to(T_END)
        runs.append((target.time, target.state, target.outputs().copy()))
    for other in runs[1:]:
        assert other[0] == runs[0][0]
        assert np.array_equal(other[1], runs[0][1]) and np.array_equal(other[2], runs[0][2])


@pytest.mark.parametrize("method", METHODS)
def test_statistics_are_present(method):
    sim, _, _ = run("stage_planar_3dof", method, RTOL)
    stats = sim.statistics
    assert set(stats) == {"steps", "rhs_evaluations", "jacobian_evaluations", "wall_time_s"}
    assert stats["steps"] > 0 and stats["rhs_evaluations"] >= stats["steps"]
    assert stats["jacobian_evaluations"] >= 1 and stats["wall_time_s"] > 0
    own = sim.integrator.statistics()
    assert {"steps", "solver_rhs_evaluations", "solver_jacobian_evaluations"} <= set(own)
    assert all(isinstance(v, int) and v >= 0 for v in own.values())
    assert sim.integrator.step_count() == own["steps"] >= stats["steps"]
    assert isinstance(sim.integrator.restart_memory, dict)


def moved_chain():
    data = chain()
    data["inputs"]["u"]["value"] = X0 + 1e-3
    return build_model(data)


def run_motion(method, rtol):
    """The chain moved by the scene's quintic: [x2, v2, effort] (m, m/s, N) at the start and
    at MOTION_TIMES."""
    sim = Simulator(moved_chain(), method=method, rtol=rtol, motion_duration=MOVE)
    start = np.array([*sim.outputs(), *sim.efforts()])
    rows = []
    for t in MOTION_TIMES:
        sim.advance_to(t)
        rows.append([*sim.outputs(), *sim.efforts()])
    return start, np.array(rows)


@pytest.mark.parametrize("method", METHODS)
def test_kinematic_inputs_within_the_methods_tolerance(method):
    if "motion" not in _references:
        start, rows = run_motion("cvode-bdf", REFERENCE_RTOL)
        _references["motion"] = rows, np.max(np.abs(rows - start), axis=0)
    expected, motion_size = _references["motion"]
    _, rows = run_motion(method, RTOL)
    error = np.max(np.abs(rows - expected), axis=0) / (RTOL * motion_size)
    assert np.all(error <= MOTION_BOUND.get(method, MOTION_DEFAULT_BOUND)), (method, error)


@pytest.mark.parametrize("method", METHODS)
def test_a_hosts_steps_restart_from_a_snapshot_bit_for_bit(method):
    """The chain moved by a host (`stepwise_motion`): get_state after three steps, two more
    steps, set_state, the same two steps: the same state, outputs and effort bit for bit, in
    the same simulator and in a new one."""
    times = np.array([0.0, 1e-3, 2.5e-3, 4e-3, 5.2e-3, 7e-3])

    def simulator():
        return Simulator(build_model(chain()), method=method, rtol=RTOL, stepwise_motion=True)

    sim = simulator()
    for t1 in times[1:4]:
        sim.move_to([motion(t1)[0]], t1)
    snapshot = sim.get_state()
    runs = []
    for target in (sim, sim, simulator()):
        target.set_state(snapshot)
        for t1 in times[4:]:
            target.move_to([motion(t1)[0]], t1)
        runs.append((target.time, target.state, [*target.outputs(), *target.efforts()]))
    for other in runs[1:]:
        assert other[0] == runs[0][0]
        assert np.array_equal(other[1], runs[0][1]) and other[2] == runs[0][2]


@pytest.mark.parametrize("method", METHODS)
def test_the_compiled_loop_drives_its_methods_bit_for_bit_and_refuses_the_others(method):
    if REGISTRY[method].compiled_loop:
        check_compiled_loop_against_python_loop(method)
        return
    zero = np.zeros((1, 1))
    sim = Simulator(load_scene("stage_planar_3dof"), method=method)
    with pytest.raises(SimulationError, match=f"does not drive method '{method}'"):
        run_sampled_loop(sim, fs=1e4, samples=1, reference=zero, feedforward=zero,
                         controller=(zero, zero, zero, zero), loop_inputs=[0],
                         loop_outputs=[0])
    assert method not in COMPILED_LOOP_METHODS
