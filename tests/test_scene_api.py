"""Building a scene in Python (`Scene`) and writing a model back (`to_toml`): the same Model as
the TOML scene, and round trips through the file."""

import dataclasses
import tomllib

import numpy as np
import pytest

from flexure.core import (
    Scene,
    SceneError,
    buckling_load_factors,
    load_scene,
    natural_frequencies,
    scene_path,
    to_toml,
)
from flexure.core.scene.building import parse_toml


def course_notes_stage():
    """The course notes' planar stage (pf2db), built call by call as a SPACAR Light user
    would: two leaf springs of 0.1 m and a rigid bar, the bar's sideways position the DOF."""
    s = Scene("stage_planar_1dof", dimension=2, tunable=["sections.bar.rho_A"],
              description="planar leaf-spring stage, three PLBEAMs, 1 DOF (SPACAR pf2db)")
    s.section("leaf", E=2.1e11, rho=7850.0, width=0.018, height=0.0005, EdA=0.2835,
              EdI=1.5207e-6)
    s.section("bar", rho_A=2.06)
    s.node("1", position=[0.0, 0.0], fixed=["x", "y"]).node("2", angle=0.0, fixed=["phi"])
    s.node("3", position=[0.0, 0.1], dof=["x"]).node("4", angle=0.0)
    s.node("5", position=[0.1, 0.1]).node("6", angle=0.0)
    s.node("7", position=[0.1, 0.0], fixed=["x", "y"]).node("8", angle=0.0, fixed=["phi"])
    s.element("leaf_left", "PLBEAM", ["1", "2", "3", "4"], section="leaf")
    s.element("bar", "PLBEAM", ["3", "4", "5", "6"], section="bar")
    s.element("leaf_right", "PLBEAM", ["7", "8", "5", "6"], section="leaf")
    s.release("leaf_left", "e2", "e3").release("leaf_right", "e2", "e3")
    s.input("F", node="3", coordinate="x")
    s.output("x", node="3", coordinate="x").output("y", node="3", coordinate="y")
    s.buckling_load("3", [0.0, -1.0])
    return s


def test_a_scene_built_in_python_is_the_toml_scenes_model():
    built = course_notes_stage().build()
    loaded = load_scene("stage_planar_1dof")
    assert built.coordinate_names == loaded.coordinate_names
    np.testing.assert_array_equal(built.initial_coordinates, loaded.initial_coordinates)
    np.testing.assert_array_equal(built.coordinate_status, loaded.coordinate_status)
    assert built.deformation_names == loaded.deformation_names
    np.testing.assert_array_equal(built.deformation_status, loaded.deformation_status)
    assert built.inputs == loaded.inputs and built.outputs == loaded.outputs
    np.testing.assert_allclose(natural_frequencies(built).frequencies_hz,
                               natural_frequencies(loaded).frequencies_hz, rtol=1e-12)
    np.testing.assert_allclose(buckling_load_factors(built, 1), [78.75], rtol=1e-3)
    # the same dictionary as the file's (its comments aside)
    assert course_notes_stage().data == parse_toml(scene_path("stage_planar_1dof"))


def test_to_toml_writes_a_scene_that_loads_to_the_same_model(tmp_path):
    scene = course_notes_stage()
    path = tmp_path / "stage.toml"
    path.write_text(scene.to_toml("built in Python"))
    again = load_scene(path)
    assert again.name == "stage_planar_1dof"
    np.testing.assert_allclose(natural_frequencies(again).frequencies_hz,
                               natural_frequencies(scene.build()).frequencies_hz, rtol=1e-12)
    assert path.read_text().startswith("# built in Python")


@pytest.mark.parametrize("name", ["stage_planar_3dof", "stage_spatial_19dof", "manipulator_stage"])
def test_a_model_writes_back_the_scene_it_was_built_from(name, tmp_path):
    model = load_scene(name)
    assert tomllib.loads(to_toml(model)) == parse_toml(scene_path(name))
    path = tmp_path / f"{name}.toml"
    path.write_text(to_toml(model))
    again = load_scene(path)
    np.testing.assert_array_equal(again.coordinate_status, model.coordinate_status)
    assert again.dof_names == model.dof_names


def test_a_meshed_and_overridden_model_writes_its_scene_not_its_segments(tmp_path):
    """to_toml writes the scene as given (segments = 4, the override applied); building it
    again meshes it again: the same frequencies."""
    model = load_scene("stage_planar_3dof", overrides={"sections.leaf.height": 0.4e-3,
                                                       "elements.leaf_left.segments": 4})
    data = tomllib.loads(to_toml(model))
    assert data["sections"]["leaf"]["height"] == 0.4e-3
    assert data["elements"]["leaf_left"]["segments"] == 4 and "leaf_left_1" not in data[
        "elements"]
    path = tmp_path / "meshed.toml"
    path.write_text(to_toml(model))
    np.testing.assert_allclose(natural_frequencies(load_scene(path)).frequencies_hz,
                               natural_frequencies(model).frequencies_hz, rtol=1e-12)


def test_a_mistake_is_named_as_in_a_file():
    scene = course_notes_stage()
    scene.data["nodes"]["3"]["mass"] = -0.2
    with pytest.raises(SceneError, match=r"^<scene stage_planar_1dof>: nodes\.3\.mass: "
                                         r"expected a value >= 0\.0, got -0\.2$"):
        scene.build()


def test_a_name_given_twice_or_unknown_is_refused():
    scene = course_notes_stage()
    with pytest.raises(SceneError, match=r"nodes\.3: given twice"):
        scene.node("3", position=[0.0, 0.0])
    with pytest.raises(SceneError, match=r"elements\.spring: not added yet; known: leaf_left"):
        scene.release("spring", "e1")


def test_a_model_without_a_scene_has_nothing_to_write():
    model = dataclasses.replace(load_scene("truss_1dof_x"), scene=None)
    with pytest.raises(SceneError, match="expected a Model built from a scene, got Model"):
        to_toml(model)


def test_to_toml_of_something_else_than_a_model_is_named():
    with pytest.raises(SceneError, match="to_toml: expected a Model built from a scene, got dict"):
        to_toml({"scene": {}})
