"""Scene FMUs under fmpy: the model description, stepping against the in-process simulation,
the ports' units and the optional von Mises output.

The FMU must give what the in-process simulation gives on the same communication grid (same
code, bundled: to 1e-12) and agree with one continuous in-process run within the integrator's
tolerance. States: test_fmu_states.py; failures: test_fmu_failures.py; the build, the
command line and the regression references: test_fmu_regression.py.
"""

import tomllib
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy_slave import SCENES, Slave, grid_and_inputs

from flexure.core import Simulator, load_scene, scene_path
from flexure.fmu import (
    FMUBuildError,
    build_scene_fmu,
    default_tunable,
    escape_log,
    fix_model_description,
    validate_fmu_file,
)
from flexure.fmu.scene_slave import DEFAULT_RTOL as FMU_RTOL
from flexure.fmu.scene_slave import METHODS as FMU_METHODS

FMU_METHOD = FMU_METHODS[0]  # the integrator a scene FMU runs by default, at FMU_RTOL


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
            sim.advance_to(t + h)
            np.testing.assert_allclose(y_fmu, sim.outputs(), rtol=0, atol=1e-12)
    finally:
        slave.close()
    # nothing but the note of which pythonfmu binary it carries (at fmi2EnterInitialization)
    note, *others = slave.logs
    assert note[0] == 0 and note[1].startswith("a: pythonfmu binary (linux64): flexure's "
                                               "corrected build of pythonfmu 0.7.0")
    assert others == []


def test_fmu_agrees_with_a_continuous_run_within_tolerance(scene_fmus):
    """1 ms communication steps against one advance over 50 ms: the restarts at each
    communication point change the error only within the integrator's tolerance."""
    scene = "stage_planar_3dof"
    slave = Slave(scene_fmus(scene))
    sim = Simulator(load_scene(scene), method=FMU_METHOD, rtol=FMU_RTOL)
    sim.reset(t0=0.0)
    sim.set_inputs([1.0])
    sim.advance_to(0.05)
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


@pytest.mark.slow
def test_fmu_benchmark_example_runs():
    """examples/fmu_benchmark.py on 50 ms: every part timed, the parts adding up to the whole
    doStep, the FMU equal to in-process. (The pythonfmu layer is a difference of two runs'
    differences, a few us a step: a measurement, whose sign noise may flip, so it is not
    asserted.)"""
    from examples import fmu_benchmark

    result = fmu_benchmark.benchmark(duration=0.05, repeats=3)
    assert result["steps"] == 50 and result["same_outputs"]
    assert result["total_ms"] > result["integrator_ms"] > 0 and result["model_io_ms"] > 0
    parts = ("master_ms", "pythonfmu_ms", "glue_ms", "model_io_ms", "integrator_ms")
    assert abs(sum(result[p] for p in parts) - result["total_ms"]) < 1e-9 * result["total_ms"]
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
        sim.advance_to((k + 1) * 1e-3)
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
        sim.advance_to((k + 1) * 1e-3)
        _, expected = stresses_along(model, [np.concatenate([sim.q, sim.qdot])],
                                     inputs=[[0.5]])
        assert y[slave.outputs.index("von_mises_max")] == pytest.approx(
            np.nanmax(expected), rel=1e-12)
    slave.close()
    assert np.nanmax(expected) > 0
    # truss_1dof_x gives its truss's EA alone (planar beams with width and height have stresses)
    with pytest.raises(FMUBuildError, match="no beam or truss whose section gives its dimensions"):
        build_scene_fmu("truss_1dof_x", tmp_path / "planar.fmu", von_mises=True)
