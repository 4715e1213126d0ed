"""Scene FMUs under fmpy: model description, stepping, state, failures, regression references.

Each scene's FMU is built once per session. The FMU must give what the in-process simulation
gives on the same communication grid (same code, bundled: to 1e-12), agree with one
continuous in-process run within the integrator's tolerance, restore states bit for bit, and
answer every failure with fmi2Discard and a logged message instead of taking the host down.
"""

import json
import shutil
import tomllib
import zipfile
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from fmpy import calloc, extract, free, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from flexure.core import Simulator, builtin_scenes, load_scene, scene_path
from flexure.fmu import (
    FMUBuildError,
    build_scene_fmu,
    default_tunable,
    escape_log,
    fix_model_description,
    validate_fmu_file,
)
from flexure.fmu.regression import check_fmu, compare, read_csv
from flexure.fmu.scene_slave import DEFAULT_RTOL as FMU_RTOL
from flexure.fmu.scene_slave import METHODS as FMU_METHODS

FMU_METHOD = FMU_METHODS[0]  # the integrator a scene FMU runs by default, at FMU_RTOL

# the manipulator's scenes (hundreds of DOFs, one refused by design): tests/test_manipulator.py
SCENES = [name for name in builtin_scenes() if not name.startswith("manipulator")]


@pytest.fixture(scope="session")
def scene_fmus(tmp_path_factory):
    """{scene name: FMU path}, each built once, on first use."""
    folder = tmp_path_factory.mktemp("fmus")
    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = build_scene_fmu(name, folder / f"{name}.fmu")
        return cache[name]

    return get


class Slave:
    """An FMU2Slave with a capturing logger, initialised and ready to step."""

    def __init__(self, path, instance_name="a", *, parameters=None, strings=None,
                 integers=None):
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.outputs = [v.name for v in self.md.modelVariables if v.causality == "output"]
        self.inputs = [v.name for v in self.md.modelVariables if v.causality == "input"]
        self.dir = extract(str(path))
        self.logs = []
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(self._log)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._callbacks = callbacks
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier,
                             instanceName=instance_name)
        self.fmu.instantiate(callbacks=callbacks, loggingOn=True)
        self.initialize(parameters, strings, integers)

    def _log(self, environment, name, status, category, message):
        self.logs.append((status, message.decode().replace("%%", "%")))

    def initialize(self, parameters=None, strings=None, integers=None):
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for name, value in (parameters or {}).items():
            self.fmu.setReal([self.vr[name]], [value])
        for name, value in (integers or {}).items():
            self.fmu.setInteger([self.vr[name]], [value])
        for name, value in (strings or {}).items():
            self.fmu.setString([self.vr[name]], [value])
        self.fmu.exitInitializationMode()

    def set(self, u):
        self.fmu.setReal([self.vr[n] for n in self.inputs], list(np.atleast_1d(u)))

    def y(self):
        return np.array(self.fmu.getReal([self.vr[n] for n in self.outputs]))

    def step(self, t, h):
        self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        return self.y()

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def grid_and_inputs():
    """A variable communication grid (s) and the force held over each step (N)."""
    steps = np.array([1e-3, 2.5e-3, 0.4e-3, 1.7e-3, 3e-3, 0.9e-3, 1e-3, 2e-3] * 3)
    times = np.concatenate([[0.0], np.cumsum(steps)])
    forces = 0.5 * np.sin(2 * np.pi * 40 * times[:-1]) + 0.2
    return times, forces


# -- model description --------------------------------------------------------------------


@pytest.mark.parametrize("scene", SCENES)
def test_model_description_is_valid_and_carries_only_the_scene(scene, scene_fmus):
    path = scene_fmus(scene)
    assert validate_fmu_file(path) == []
    md = read_model_description(str(path))
    model = load_scene(scene)
    assert md.coSimulation.modelIdentifier == model.name == scene
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    assert md.coSimulation.canHandleVariableCommunicationStepSize
    by_name = {v.name: v for v in md.modelVariables}
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    assert inputs == [p.name for p in model.inputs]
    assert outputs == [p.name for p in model.outputs]
    for port in model.inputs:
        v = by_name[port.name]
        assert (v.unit, v.variability, float(v.start)) == (port.unit, "continuous", 0.0)
    for port in model.outputs:
        assert (by_name[port.name].unit, by_name[port.name].variability) == (port.unit,
                                                                              "continuous")
    data = tomllib.loads(scene_path(scene).read_text())
    parameters = [v.name for v in md.modelVariables if v.causality == "parameter"]
    assert parameters == ["integrator.method", "integrator.rtol", "integrator.atol",
                          "integrator.max_steps", *default_tunable(data)]
    assert all(by_name[p].variability == "fixed" and by_name[p].initial == "exact"
               for p in parameters)
    assert len(md.modelVariables) == len(inputs) + len(outputs) + len(parameters)
    units = {u.name for u in md.unitDefinitions}
    assert {v.unit for v in md.modelVariables if v.unit} <= units
    # every Real has its unit ("1" for the tolerances); FMI 2.0 gives Integer and String
    # variables none
    assert [v.name for v in md.modelVariables if v.type == "Real" and not v.unit] == []
    assert {v.name for v in md.modelVariables if v.type != "Real"} == {
        "integrator.method", "integrator.max_steps"}
    assert by_name["integrator.atol"].unit == by_name["integrator.rtol"].unit == "1"
    assert [u.variable.name for u in md.initialUnknowns] == outputs


def test_model_description_fix_adds_units_initial_unknowns_and_variability():
    raw = """<?xml version="1.0" encoding="utf-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="m" guid="g" variableNamingConvention="structured">
<CoSimulation modelIdentifier="m"/><LogCategories><Category name="logAll"/></LogCategories>
<ModelVariables>
<ScalarVariable name="u" valueReference="0" causality="input">
  <Real start="0" unit="N"/></ScalarVariable>
<ScalarVariable name="y" valueReference="1" causality="output"><Real unit="m/s"/></ScalarVariable>
<ScalarVariable name="k" valueReference="2" causality="parameter">
  <Real start="1" unit="N/m"/></ScalarVariable>
</ModelVariables><ModelStructure><Outputs><Unknown index="2"/></Outputs></ModelStructure>
</fmiModelDescription>"""
    root = ET.fromstring(fix_model_description(raw))
    assert [c.tag for c in root][:2] == ["CoSimulation", "UnitDefinitions"]
    newton = root.find("UnitDefinitions/Unit[@name='N']/BaseUnit")
    assert newton.attrib == {"kg": "1", "m": "1", "s": "-2"}
    variables = root.findall("ModelVariables/ScalarVariable")
    assert [v.get("variability") for v in variables] == ["continuous", "continuous", "fixed"]
    assert variables[2].get("initial") == "exact"
    assert [u.get("index") for u in root.findall("ModelStructure/InitialUnknowns/Unknown")] \
        == ["2"]


def test_escape_log_doubles_percent():
    assert escape_log("100% of %s") == "100%% of %%s"


# -- stepping --------------------------------------------------------------------------------


@pytest.mark.parametrize("scene", ["stage_planar_3dof", "truss_1dof_x"])
def test_fmu_equals_in_process_simulation_on_the_same_grid(scene, scene_fmus):
    times, forces = grid_and_inputs()
    slave = Slave(scene_fmus(scene))
    sim = Simulator(load_scene(scene), method=FMU_METHOD, rtol=FMU_RTOL)
    sim.reset(t0=0.0)
    try:
        assert np.array_equal(slave.y(), sim.outputs())
        for t, h, f in zip(times[:-1], np.diff(times), forces, strict=True):
            slave.set(f)
            y_fmu = slave.step(t, h)
            sim.set_inputs([f])
            sim.advance(t + h)
            np.testing.assert_allclose(y_fmu, sim.outputs(), rtol=0, atol=1e-12)
    finally:
        slave.close()
    assert slave.logs == []


def test_fmu_agrees_with_a_continuous_run_within_tolerance(scene_fmus):
    """1 ms communication steps against one advance over 50 ms: the restarts at each
    communication point change the error only within the integrator's tolerance."""
    scene = "stage_planar_3dof"
    slave = Slave(scene_fmus(scene))
    sim = Simulator(load_scene(scene), method=FMU_METHOD, rtol=FMU_RTOL)
    sim.reset(t0=0.0)
    sim.set_inputs([1.0])
    sim.advance(0.05)
    slave.set(1.0)
    h = 1e-3
    for k in range(50):
        y = slave.step(k * h, h)
    slave.close()
    displacement = sim.outputs() - load_scene(scene).initial_coordinates[
        [p.coordinate for p in load_scene(scene).outputs]]
    # x moves ~2 mm; the default rtol over the steps of 50 ms: within 1e-6 of the motion
    np.testing.assert_allclose(y, sim.outputs(), rtol=0,
                               atol=1e-6 * np.abs(displacement).max())


def test_simulate_fmu_with_input_and_parameters(scene_fmus):
    """fmpy's simulate_fmu: a force step as input, a parameter and the method set."""
    path = scene_fmus("truss_1dof_x")
    signal = np.array([(0.0, 0.0), (0.01, 0.0), (0.01, 2.0), (0.03, 2.0)],
                      dtype=[("time", float), ("F", float)])
    base = simulate_fmu(str(path), stop_time=0.03, output_interval=1e-3, input=signal)
    adams = simulate_fmu(str(path), stop_time=0.03, output_interval=1e-3, input=signal,
                         start_values={"integrator.method": "cvode-adams"})
    zero = simulate_fmu(str(path), stop_time=0.03, output_interval=1e-3)  # the scene's load
    assert len(base) == 31
    assert np.array_equal(base["x"][:11], zero["x"][:11])  # the step comes at 0.01 s
    assert base["x"][-1] > zero["x"][-1]
    motion = base["x"][-1] - base["x"][0]
    assert abs(adams["x"][-1] - base["x"][-1]) < 1e-5 * abs(motion)
    # The tunable mass: four times the mass, half the frequency: a slower rise.
    mass = float(next(v.start for v in read_model_description(str(path)).modelVariables
                      if v.name == "nodes.2.mass"))
    heavy = simulate_fmu(str(path), stop_time=0.03, output_interval=1e-3, input=signal,
                         start_values={"nodes.2.mass": 4 * mass})
    assert 0 < heavy["x"][12] - base["x"][0] < base["x"][12] - base["x"][0]


def test_state_get_set_and_serialize_replay_bit_for_bit(scene_fmus):
    path = scene_fmus("stage_planar_3dof")
    a = Slave(path, "a")
    times, forces = grid_and_inputs()
    half = len(forces) // 2
    for t, h, f in zip(times[:half], np.diff(times)[:half], forces[:half], strict=True):
        a.set(f)
        a.step(t, h)
    state = a.fmu.getFMUstate()
    data = a.fmu.serializeFMUstate(state)

    def rest(slave):
        ys = []
        for t, h, f in zip(times[half:-1], np.diff(times)[half:], forces[half:], strict=True):
            slave.set(f)
            ys.append(slave.step(t, h))
        return np.array(ys)

    original = rest(a)
    for _ in range(2):  # restoring twice: the saved state is not changed by stepping on
        a.fmu.setFMUstate(state)
        assert np.array_equal(rest(a), original)
    b = Slave(path, "b")  # another instance, from the serialized bytes
    restored = b.fmu.deSerializeFMUstate(data)
    b.fmu.setFMUstate(restored)
    assert np.array_equal(rest(b), original)
    a.fmu.freeFMUstate(state)
    b.fmu.freeFMUstate(restored)
    a.close()
    b.close()


def test_an_input_set_once_holds_and_a_restored_state_holds_its_own_inputs(scene_fmus):
    """Setting an input once or before every doStep gives the same numbers (the slave tells
    its simulator only of a change). An FMU state holds every settable variable: after
    fmi2SetFMUstate the inputs are the saved ones again, held by the next doStep without a
    set, although the host had set others since."""
    path = scene_fmus("stage_planar_3dof")
    once, every = Slave(path, "once"), Slave(path, "every")
    once.set(0.7)
    held_once, set_every = [], []
    for k in range(6):
        held_once.append(once.step(k * 1e-3, 1e-3))
        every.set(0.7)
        set_every.append(every.step(k * 1e-3, 1e-3))
    assert np.array_equal(np.array(held_once), np.array(set_every))
    state = once.fmu.getFMUstate()
    every.fmu.freeFMUstate(every.fmu.getFMUstate())  # taking a state restarts the kinematics
    once.set(0.2)
    changed = [once.step(k * 1e-3, 1e-3) for k in range(6, 9)]
    once.fmu.setFMUstate(state)
    assert once.fmu.getReal([once.vr[once.inputs[0]]]) == [0.7]
    restored = [once.step(k * 1e-3, 1e-3) for k in range(6, 9)]  # no set: 0.7 N held
    continued = [every.step(k * 1e-3, 1e-3) for k in range(6, 9)]
    assert np.array_equal(np.array(restored), np.array(continued))
    assert not np.array_equal(np.array(restored), np.array(changed))
    once.fmu.freeFMUstate(state)
    once.close()
    every.close()


def test_reset_starts_over(scene_fmus):
    scene = "stage_planar_1dof"
    slave = Slave(scene_fmus(scene))
    slave.set(1.0)
    first = [slave.step(k * 1e-3, 1e-3) for k in range(5)]
    slave.fmu.reset()
    slave.initialize()
    sim = Simulator(load_scene(scene))
    sim.reset()
    assert np.array_equal(slave.y(), sim.outputs())
    slave.set(1.0)
    again = [slave.step(k * 1e-3, 1e-3) for k in range(5)]
    slave.close()
    assert np.array_equal(np.array(first), np.array(again))


def test_two_instances_and_two_scenes_in_one_process(scene_fmus):
    planar = scene_fmus("stage_planar_3dof")
    truss = scene_fmus("truss_1dof_x")
    alone = {}
    for name, path, force in (("p", planar, 1.0), ("t", truss, 2.0)):
        s = Slave(path, name)
        s.set(force)
        alone[name] = [s.step(k * 1e-3, 1e-3) for k in range(8)]
        s.close()
    a, b, c = Slave(planar, "a"), Slave(planar, "b"), Slave(truss, "c")
    a.set(1.0)
    b.set(-1.0)
    c.set(2.0)
    ya, yb, yc = [], [], []
    for k in range(8):  # interleaved
        ya.append(a.step(k * 1e-3, 1e-3))
        yc.append(c.step(k * 1e-3, 1e-3))
        yb.append(b.step(k * 1e-3, 1e-3))
    for s in (a, b, c):
        s.close()
    assert np.array_equal(ya, alone["p"])
    assert np.array_equal(yc, alone["t"])
    assert not np.allclose(ya, yb)


# -- failures --------------------------------------------------------------------------------


def test_non_finite_input_is_discarded_at_the_last_good_time(scene_fmus):
    slave = Slave(scene_fmus("stage_planar_1dof"))
    slave.set(1.0)
    for k in range(3):
        good = slave.step(k * 1e-3, 1e-3)
    for bad in (np.nan, np.inf):
        slave.set(bad)
        with pytest.raises(FMICallException, match="discard"):
            slave.step(3e-3, 1e-3)
        assert np.array_equal(slave.y(), good)
    assert "not finite" in slave.logs[-1][1] and slave.logs[-1][0] == 3  # fmi2Error
    assert "last good time t = 0.003" in slave.logs[-1][1]
    slave.set(1.0)  # the instance goes on from its last good time
    slave.step(3e-3, 1e-3)
    slave.close()


def test_wrong_communication_point_and_step_are_discarded(scene_fmus):
    slave = Slave(scene_fmus("truss_1dof_x"))
    with pytest.raises(FMICallException, match="discard"):
        slave.step(0.5, 1e-3)
    assert "expected the communication point t = 0.0 s, got 0.5 s" in slave.logs[-1][1]
    with pytest.raises(FMICallException, match="discard"):
        slave.step(0.0, -1e-3)
    assert "expected a step size h > 0" in slave.logs[-1][1]
    slave.step(0.0, 1e-3)
    slave.close()


def test_bad_method_parameter_is_reported_not_fatal(scene_fmus):
    slave = Slave(scene_fmus("truss_1dof_x"), strings={"integrator.method": "euler%s"})
    with pytest.raises(FMICallException, match="discard"):
        slave.step(0.0, 1e-3)
    text = " ".join(m for _, m in slave.logs)
    assert "euler%s" in text and "cannot go on" in text
    slave.fmu.reset()  # a reset with a valid method recovers the instance
    slave.initialize()
    slave.step(0.0, 1e-3)
    slave.close()


@pytest.mark.parametrize("method", ["cvode-bdf", "esdirk"])
def test_a_do_step_beyond_its_step_budget_is_discarded(scene_fmus, method):
    """integrator.max_steps: a doStep that would need more integrator steps answers
    fmi2Discard naming the budget, in the integrator's own count (no step-by-step return to
    Python); the instance then goes on."""
    slave = Slave(scene_fmus("stage_planar_3dof"), strings={"integrator.method": method},
                  integers={"integrator.max_steps": 30})
    slave.set(1.0)
    slave.step(0.0, 1e-4)  # a short step, within the budget
    with pytest.raises(FMICallException, match="discard"):
        slave.step(1e-4, 0.5)  # thousands of steps
    status, message = slave.logs[-1]
    assert "the step budget of 30 integrator steps is spent" in message
    slave.close()


def test_a_state_beyond_the_range_of_validity_is_a_warning_in_the_log(scene_fmus):
    """1e9 N on stage_planar_3dof: the doStep answers OK (the equations stay defined) and the
    log carries fmi2Warning, once per kind of limit, naming the limit; 1 N stays silent."""
    slave = Slave(scene_fmus("stage_planar_3dof"))
    slave.set(1.0)
    slave.step(0.0, 1e-3)
    assert not any(status == 1 for status, _ in slave.logs)
    slave.set(1e9)
    for k in range(1, 4):
        slave.step(k * 1e-3, 1e-3)
    warnings = [message for status, message in slave.logs if status == 1]
    assert len(warnings) == 2
    assert any("axial strain" in m and "range of validity" in m for m in warnings)
    assert any("moved" in m and "0.25 x its length scale" in m for m in warnings)
    slave.close()


def test_a_step_budget_out_of_range_is_refused(scene_fmus):
    slave = Slave(scene_fmus("truss_1dof_x"), integers={"integrator.max_steps": 0})
    with pytest.raises(FMICallException):
        slave.step(0.0, 1e-3)
    assert any("integrator.max_steps = 0: expected an integer from 1 to 1e9" in message
               for _, message in slave.logs)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # the overflow on the way to failure
def test_integrator_failure_is_discarded(scene_fmus):
    """A force of 1e300 N: the integrator fails in the first step (error tests). The
    step is discarded with the cause at the last good time, never Fatal; the instance goes
    on when the force is sane again. (A Newton failure of the kinematics takes the same
    path, but needs ~20 s of integration to provoke.)"""
    slave = Slave(scene_fmus("stage_planar_1dof"))
    slave.set(1.0)
    good = slave.step(0.0, 1e-3)
    slave.set(1e300)
    with pytest.raises(FMICallException, match="discard"):
        slave.step(1e-3, 1e-3)
    status, message = slave.logs[-1]
    assert status == 3 and "discarded" in message
    assert "simulation of 'stage_planar_1dof' stopped at t = 0.001 s" in message  # the cause
    assert "last good time t = 0.001 s" in message
    assert np.array_equal(slave.y(), good)
    slave.set(1.0)
    slave.step(1e-3, 1e-3)
    slave.close()


# -- build and command line ------------------------------------------------------------------


def test_build_rejects_an_unknown_tunable_key(tmp_path):
    with pytest.raises(FMUBuildError, match="sections.leaf.EdX.*does not declare it"):
        build_scene_fmu("stage_planar_3dof", tmp_path / "x.fmu",
                        tunable=["sections.leaf.EdX"])


def test_cli_build_check_and_env(tmp_path, capsys):
    from flexure.core.cli import main

    fmu = tmp_path / "truss.fmu"
    assert main(["fmu", "build", "truss_1dof_x", "-o", str(fmu), "--no-tunable"]) == 0
    assert str(fmu) in capsys.readouterr().out
    md = read_model_description(str(fmu))
    assert [v.name for v in md.modelVariables if v.causality == "parameter"] == [
        "integrator.method", "integrator.rtol", "integrator.atol", "integrator.max_steps"]
    scenes = scene_path("truss_1dof_x").parent
    inputs, reference = scenes / "truss_1dof_x_in.csv", scenes / "truss_1dof_x_ref.csv"
    assert main(["fmu", "check", str(fmu), str(inputs), str(reference)]) == 0
    assert "matches" in capsys.readouterr().out
    changed = tmp_path / "changed_ref.csv"
    changed.write_text(_shifted_reference(reference))
    assert main(["fmu", "check", str(fmu), str(inputs), str(changed)]) == 1
    assert "x: max |error|" in capsys.readouterr().out
    assert main(["fmu", "build", "truss_1dof_x", "-o", str(fmu), "--tunable",
                 "nodes.9.mass"]) == 2
    error = capsys.readouterr().err
    assert "nodes.9.mass" in error and "Traceback" not in error
    assert main(["fmu", "check", str(fmu), str(tmp_path / "none_in.csv"), str(reference)]) == 2
    assert "none_in.csv: no such file" in capsys.readouterr().err
    assert main(["fmu", "env", "--json"]) == 0
    values = json.loads(capsys.readouterr().out)
    assert "libpython3" in values["LD_PRELOAD"] and "site-packages" in values["PYTHONPATH"]
    # The printed environment is what a shell (and the JVM test) uses.
    assert main(["fmu", "env"]) == 0
    assert capsys.readouterr().out.startswith("export LD_PRELOAD=")
    with zipfile.ZipFile(fmu) as archive:  # flexure travels inside, under a hashed name
        names = archive.namelist()
    assert any(n.startswith("resources/_flexure_") and n.endswith("core/simulation/simulation.py")
               for n in names)


def _shifted_reference(path):
    """The reference CSV with x moved by 1 mm at the last sample."""
    lines = path.read_text().splitlines()
    time, value = lines[-1].split(",")
    lines[-1] = f"{time},{float(value) + 1e-3!r}"
    return "\n".join(lines) + "\n"


# -- regression references -------------------------------------------------------------------


@pytest.mark.parametrize("scene", SCENES)
def test_regression_reference(scene, scene_fmus):
    """FMI cross-check style: <scene>_in.csv drives the FMU, <scene>_ref.csv is what it gave
    when the reference was written; every output within 1e-5 of its range + 1e-8."""
    folder = scene_path(scene).parent
    problems = check_fmu(scene_fmus(scene), folder / f"{scene}_in.csv",
                         folder / f"{scene}_ref.csv")
    assert problems == []


def test_regression_compare_reports_a_changed_signal():
    reference = read_csv(scene_path("truss_1dof_x").parent / "truss_1dof_x_ref.csv")
    changed = reference.copy()
    assert compare(changed, reference) == []
    changed["x"][50] += 1e-4 * (reference["x"].max() - reference["x"].min()) + 1e-8
    (problem,) = compare(changed, reference)
    assert problem.startswith("x: max |error|") and "t = 0.05 s" in problem


def test_regression_tolerance_catches_a_one_percent_change(scene_fmus):
    """1 % more mass on the truss (a tunable parameter) must fail the regression test."""
    from flexure.fmu.regression import simulate

    scene = "truss_1dof_x"
    path = scene_fmus(scene)
    folder = scene_path(scene).parent
    mass = float(next(v.start for v in read_model_description(str(path)).modelVariables
                      if v.name == "nodes.2.mass"))
    result = simulate(path, folder / f"{scene}_in.csv",
                      start_values={"nodes.2.mass": 1.01 * mass})
    (problem,) = compare(result, read_csv(folder / f"{scene}_ref.csv"))
    assert problem.startswith("x: max |error|")


def test_fmu_benchmark_example_runs():
    """examples/fmu_benchmark.py on 10 ms: every part timed, the FMU equal to in-process."""
    from examples import fmu_benchmark

    result = fmu_benchmark.benchmark(duration=0.01, repeats=1)
    assert result["steps"] == 10 and result["same_outputs"]
    assert result["total_ms"] > result["integrator_ms"] > 0
    assert result["model_io_ms"] > 0 and result["pythonfmu_ms"] > 0
    assert "overhead beyond our integrator" in fmu_benchmark.report(result)


def test_velocity_and_rotation_ports_get_their_units(tmp_path):
    """A scene of our own: a moment input (N.m), a rotation output (rad) and a velocity output
    (m/s), no [scene] name (the file's stem names the FMU)."""
    text = scene_path("stage_planar_3dof").read_text().replace(
        'name = "stage_planar_3dof"\n', "")
    text += ('\n[inputs.M]\nnode = "4"\ncoordinate = "phi"\n'
             '\n[outputs.phi]\nnode = "4"\ncoordinate = "phi"\n'
             '\n[outputs.v]\nnode = "3"\ncoordinate = "x"\nquantity = "velocity"\n')
    scene = tmp_path / "my_stage.toml"
    scene.write_text(text)
    path = build_scene_fmu(scene, tmp_path / "my_stage.fmu")
    md = read_model_description(str(path))
    assert md.coSimulation.modelIdentifier == "my_stage"
    units = {v.name: v.unit for v in md.modelVariables if v.causality in ("input", "output")}
    assert units == {"F": "N", "M": "N.m", "x": "m", "y": "m", "phi": "rad", "v": "m/s"}
    definitions = {u.name: u for u in md.unitDefinitions}
    speed, angle = definitions["m/s"].baseUnit, definitions["rad"].baseUnit
    assert (speed.m, speed.s, speed.kg, angle.rad) == (1, -1, 0, 1)
    slave = Slave(path)
    sim = Simulator(load_scene(scene), method=FMU_METHOD, rtol=FMU_RTOL)
    sim.reset()
    for k in range(5):
        slave.set([1.0, 0.01])
        sim.set_inputs([1.0, 0.01])
        sim.advance((k + 1) * 1e-3)
        np.testing.assert_allclose(slave.step(k * 1e-3, 1e-3), sim.outputs(), rtol=0,
                                   atol=1e-12)
    slave.close()
    assert sim.outputs()[3] > 0  # the bar moves along x: a positive velocity


def test_von_mises_output_on_request(tmp_path):
    """--von-mises adds von_mises_max (Pa): the largest stress of flexure.core's
    stresses_along in the state after each step; refused for a scene without section
    dimensions."""
    from flexure.core import stresses_along

    scene = "stage_spatial_1dof"
    path = build_scene_fmu(scene, tmp_path / "spatial.fmu", von_mises=True)
    md = read_model_description(str(path))
    stress = next(v for v in md.modelVariables if v.name == "von_mises_max")
    assert (stress.causality, stress.unit) == ("output", "Pa")
    assert validate_fmu_file(path) == []
    model = load_scene(scene)
    slave = Slave(path)
    sim = Simulator(model, method=FMU_METHOD, rtol=FMU_RTOL)
    sim.reset()
    for k in range(3):
        slave.set(0.5)
        y = slave.step(k * 1e-3, 1e-3)
        sim.set_inputs([0.5])
        sim.advance((k + 1) * 1e-3)
        _, expected = stresses_along(model, [np.concatenate([sim.q, sim.qdot])],
                                     inputs=[[0.5]])
        assert y[slave.outputs.index("von_mises_max")] == pytest.approx(
            np.nanmax(expected), rel=1e-12)
    slave.close()
    assert np.nanmax(expected) > 0
    # truss_1dof_x gives its truss's EA alone (planar beams with width and height have stresses)
    with pytest.raises(FMUBuildError, match="no beam or truss whose section gives its dimensions"):
        build_scene_fmu("truss_1dof_x", tmp_path / "planar.fmu", von_mises=True)
