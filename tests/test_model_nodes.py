"""The model's node table: every coordinate's node, axis and unit, without parsing names."""

import copy

import numpy as np
import pytest

from flexure.core import build_model, load_scene
from flexure.core.scene.building import builtin_scenes, parse_toml, scene_path


# the manipulator's scenes (hundreds of DOFs, one refused by design): tests/test_manipulator.py
@pytest.mark.parametrize("name", [n for n in builtin_scenes() if not n.startswith("manipulator")])
def test_every_coordinate_has_one_node_and_axis(name):
    model = load_scene(name)
    covered = sorted(i for node in model.nodes for i in node.coordinates)
    assert covered == list(range(model.nx))
    for node in model.nodes:
        for i, axis, unit in zip(node.coordinates, node.axes, node.units, strict=True):
            assert model.coordinate_names[i] == f"{node.name}.{axis}"
            assert model.coordinate_node[i] == node.name and model.coordinate_axis[i] == axis
            assert unit == ("m" if node.kind == "translational" else
                            "rad" if model.dimension == 2 else "1")
    translations = [i for node in model.nodes if node.kind == "translational"
                    for i in node.coordinates]
    np.testing.assert_array_equal(model.translations, sorted(translations))


def test_a_node_named_like_a_coordinate_is_still_told_apart():
    """Names are labels, not data: a node called "x" (its coordinates "x.x", "x.y") is a
    translational node with its axes from the table."""
    data = copy.deepcopy(parse_toml(scene_path("truss_1dof_x")))
    data["nodes"]["x"] = data["nodes"].pop("2")
    for table in (data["elements"]["spring"], data["inputs"]["F"], data["outputs"]["x"]):
        if "nodes" in table:
            table["nodes"] = [n if n != "2" else "x" for n in table["nodes"]]
        if table.get("node") == "2":
            table["node"] = "x"
    data["scene"].pop("tunable", None)
    model = build_model(data)
    node = next(n for n in model.nodes if n.name == "x")
    assert node.kind == "translational" and node.axes == ("x", "y")
    assert model.coordinate_node[model.coordinate_index("x.x")] == "x"


def test_meshing_adds_its_interior_nodes_to_the_table():
    data = copy.deepcopy(parse_toml(scene_path("stage_planar_3dof")))
    data["elements"]["leaf_left"]["segments"] = 3
    model = build_model(data)
    kinds = {node.name: node.kind for node in model.nodes}
    assert kinds["leaf_left_1"] == kinds["leaf_left_2"] == "translational"
    assert kinds["leaf_left_1_r"] == kinds["leaf_left_2_r"] == "rotational"
