"""The manipulator's six loops as a controller FMU: what the FMU carries (the move path, through
JSON, as controller_fmu.py embeds it) gives the in-process references and feedforward bit for
bit, the FMU computes them so, and the plant FMU's ports are connected by name.

The six loops running through fmpy and libcosim against the in-process loop are in the slow
tier (tests/test_manipulator_loop.py).
"""

import json
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from flexure.controllers.controller_fmu import build_controller_fmu, controller_config
from flexure.controllers.cosim import scene_fmu, scene_fmu_path
from flexure.controllers.feedback import ControlDesignError, DiscreteController, design_feedback
from flexure.controllers.feedforward import low_frequency_model
from flexure.controllers.loop_controller import LoopController
from flexure.controllers.move_path import MovePath, move_path
from flexure.controllers.plants import FmuPlant
from flexure.controllers.profiles import ThirdOrderProfile
from flexure.controllers.runner import run_loop
from flexure.core import SimulationError, load_scene
from flexure.fmu import build_scene_fmu

FS = 4000.0  # Hz
SAMPLES = 240  # a 0.05 s move and 0.01 s after it


@pytest.fixture(scope="module")
def six():
    """The manipulator, a 4-point nonlinear path of its 6 mm xy move (the end effector's x
    and y by 4.24 mm, its height and tilts held), its loops and their controller."""
    model = load_scene("manipulator_control")
    d = 6e-3 / np.sqrt(2)
    path = move_path(model, {"E.x": d, "E.y": d, "E_M1.x": d, "E.z": 0.0, "E_M1.z": 0.0,
                             "E_M2.z": 0.0}, kind="nonlinear", points=4)
    lf = low_frequency_model(model)
    design = design_feedback(model, crossover=300.0, fs=FS, plant=lf.state_space())
    offsets = [model.initial_coordinates[model.outputs[p.output_index].coordinate]
               for p in design.pairs]
    controller = LoopController(DiscreteController(design.controller),
                                ThirdOrderProfile(1.0, 0.05), fs=FS, samples=SAMPLES,
                                offsets=offsets, feedforward=lf, path=path)
    return model, path, design, controller


def test_the_move_path_survives_json_bit_for_bit(six):
    _, path, _, _ = six
    again = MovePath.from_dict(json.loads(json.dumps(path.to_dict())))
    assert again.kind == "nonlinear" and again.targets == path.targets
    s = np.linspace(-0.1, 1.1, 1201)  # past both ends too: the path is held there
    for derivative in (0, 1, 2):
        np.testing.assert_array_equal(again.displacement(s, derivative),
                                      path.displacement(s, derivative))
    np.testing.assert_array_equal(again.static_force(s), path.static_force(s))
    assert np.max(np.abs(path.displacement([1.0]))) > 4e-3  # m: a real move, not zeros


def test_the_controller_fmus_configuration_gives_the_same_references_and_feedforward(six):
    """controller_config -> JSON -> LoopController, as the controller FMU's __init__ does."""
    model, path, design, controller = six
    config = json.dumps(controller_config(controller, design, model), sort_keys=True)
    data = json.loads(config)
    assert [tuple(pair) for pair in data["loops"]] == [(f"F{i}", f"x{i}") for i in range(1, 7)]
    again = LoopController.from_dict(data)
    assert again.path is not None and again.samples == SAMPLES
    np.testing.assert_array_equal(again.reference, controller.reference)
    np.testing.assert_array_equal(again.feedforward, controller.feedforward)
    y = controller.reference[5] + 1e-7  # m: one step of the feedback too
    np.testing.assert_array_equal(again.step(5, y)[0], controller.step(5, y)[0])


def test_the_controller_fmu_puts_out_the_in_process_references_and_feedforward(six, tmp_path):
    """Stepped by fmpy with the measurement on the reference (zero error, so the feedback adds
    exactly nothing), its six forces are the feedforward of the next interval and its
    references the in-process ones, bit for bit."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    model, _, design, controller = six
    path = build_controller_fmu(controller, design, model, tmp_path / "controller.fmu")
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path), unzipdir=str(tmp_path / "six")),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="six")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    forces = [vr[f"F{i}"] for i in range(1, 7)]
    positions = [vr[f"x{i}"] for i in range(1, 7)]
    references = [vr[f"x{i}_reference"] for i in range(1, 7)]
    try:
        assert fmu.getReal(forces) == controller.feedforward[0].tolist()
        for k in range(SAMPLES):
            fmu.setReal(positions, controller.reference[k].tolist())
            fmu.doStep(currentCommunicationPoint=k / FS, communicationStepSize=1 / FS)
            assert fmu.getReal(references) == controller.reference[k].tolist(), k
            assert fmu.getReal(forces) == controller.feedforward[k + 1].tolist(), k
    finally:
        fmu.terminate()
        fmu.freeInstance()
    assert np.ptp(controller.feedforward, axis=0).min() > 0.1  # N: forces that change


@pytest.mark.parametrize("change, match", [
    (lambda d: d.pop("displacements"), "lacks 'displacements'"),
    (lambda d: d.update(kind="cubic"), "kind must be one of"),
    (lambda d: d.update(s=[0.0, 0.7, 0.5, 1.0]), "s must rise strictly from 0 to 1"),
    (lambda d: d.update(s=[0.0, 0.5, 0.9]), "s must rise strictly from 0 to 1"),
    (lambda d: d.update(displacements=[[0.0], [1e-3]]), r"expected displacements of shape "
                                                         r"\(3, n_loops\), got \(2, 1\)"),
    (lambda d: d.update(forces=[[0.0, 0.0]] * 3), r"expected forces of shape \(3, 1\)"),
])
def test_a_move_path_dictionary_that_does_not_fit_is_named(change, match):
    data = MovePath(np.array([0.0, 0.5, 1.0]), np.array([[0.0], [0.5e-3], [1e-3]]),
                    np.array([[0.0], [0.4], [0.8]]), "nonlinear", {"3.x": 1e-3}).to_dict()
    change(data)
    with pytest.raises(ControlDesignError, match=match):
        MovePath.from_dict(data)


@pytest.fixture(scope="module")
def stale_workdir(tmp_path_factory):
    """A workdir where the loop finds, in the place of truss_1dof_x's FMU, the FMU of another
    truss_1dof_x, its output named "position" where the scene has "x" (an FMU put there by
    hand: one kept from before an edit of the scene is not reused, the next test)."""
    folder = tmp_path_factory.mktemp("stale")
    scene = Path(__file__).parents[1] / "examples" / "scenes" / "truss_1dof_x.toml"
    older = folder / "older.toml"
    older.write_text(scene.read_text().replace("[outputs.x]", "[outputs.position]"))
    place = scene_fmu_path("truss_1dof_x", load_scene("truss_1dof_x"), folder)
    place.parent.mkdir()
    build_scene_fmu(older, place)
    return folder


def test_a_kept_workdir_builds_the_fmu_of_the_scene_as_edited(tmp_path):
    scene = tmp_path / "truss_1dof_x.toml"
    text = (Path(__file__).parents[1] / "examples" / "scenes" / "truss_1dof_x.toml").read_text()
    scene.write_text(text)
    first = scene_fmu(scene, load_scene(scene), tmp_path)
    assert scene_fmu(scene, load_scene(scene), tmp_path) == first  # unchanged: reused
    scene.write_text(text.replace("[outputs.x]", "[outputs.position]"))
    edited = scene_fmu(scene, load_scene(scene), tmp_path)
    assert edited != first and first.exists()
    outputs = {v.name for v in read_model_description(str(edited)).modelVariables
               if v.causality == "output"}
    assert "position" in outputs and "x" not in outputs


@pytest.mark.parametrize("plant, match", [
    ("fmu", "truss_1dof_x.fmu: the FMU has no output 'x'; its outputs are position"),
    ("libcosim", "truss_1dof_x.fmu: the FMU has no variable 'x' .a loop connects it by name"),
])
def test_a_plant_fmu_without_the_loops_port_is_named(stale_workdir, plant, match):
    with pytest.raises(SimulationError, match=match):
        run_loop("truss_1dof_x", plant=plant, workdir=stale_workdir, duration=0.01, settle=0.0)


def test_the_fmpy_plant_takes_its_ports_by_name(tmp_path):
    path = build_scene_fmu("stage_planar_1dof", tmp_path / "stage_planar_1dof.fmu")
    plain = FmuPlant(path)
    swapped = FmuPlant(path, inputs=["F"], outputs=["y", "x"])
    try:
        assert plain.output_names == ["x", "y"] and swapped.output_names == ["y", "x"]
        y0 = plain.reset()
        assert abs(y0[0] - y0[1]) > 1e-3  # m: the two outputs tell apart
        np.testing.assert_array_equal(swapped.reset(), y0[::-1])
    finally:
        plain.close()
        swapped.close()
