"""Mode shapes in words: which nodes move most, along or about which axis."""

import json

import numpy as np

from flexure.core import load_scene, natural_frequencies
from flexure.core.analysis.modal import describe_mode
from flexure.core.cli import main


def test_the_planar_stage_modes_in_words():
    """Sideways (10.6 Hz), vertical (2.1 kHz), and the tilt of the bar with the springs'
    opposite vertical motion (3.6 kHz): the stage's three modes."""
    model = load_scene("stage_planar_3dof")
    modes = natural_frequencies(model)
    words = [describe_mode(model, shape) for shape in modes.coordinate_shapes.T]
    assert words == ["3 and 5 along x", "3 and 5 along y",
                     "3 and 5 along y; 4 and 6 turn about z"]


def test_spatial_modes_name_body_frame_rotations():
    """In space a rotational node turns about an axis of its own frame (x', y', z'): the
    19-DOF stage's first mode is the sideways one, the springs bending about z'; its second
    moves the bar out of plane (z), the springs turning about y'."""
    model = load_scene("stage_spatial_19dof")
    modes = natural_frequencies(model, 2)
    first, second = (describe_mode(model, shape) for shape in modes.coordinate_shapes.T)
    assert first.startswith("3 and 5 along x; ") and first.endswith("turn about z'")
    assert second.startswith("3 and 5 along z; ") and second.endswith("turn about y'")


def test_no_motion_and_the_json(capsys):
    model = load_scene("stage_planar_1dof")
    assert describe_mode(model, np.zeros(model.nx)) == "no motion"
    assert main(["analyze", "stage_planar_1dof", "--modes", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["modes"]["descriptions"] == ["3 and 5 along x"]


def test_a_node_moving_at_45_degrees_is_named_the_same_whatever_the_round_off():
    """Components equal to within round-off (what another CPU's eigensolver may give) are a
    tie, named by the first axis (x), whichever is larger in the last bits; a difference
    beyond AXIS_TIE (1e-9, relative) names the larger."""
    model = load_scene("stage_planar_3dof")
    x, y = model.nodes[2].coordinates  # node 3, translational

    def words(along_x, along_y):
        shape = np.zeros(model.nx)
        shape[[x, y]] = along_x, along_y
        return describe_mode(model, shape)

    ulp = np.spacing(1.0)
    assert words(1.0, 1.0 + ulp) == words(1.0, 1.0 - ulp) == words(1.0, 1.0) == "3 along x"
    assert words(-1.0, 1.0 + 4 * ulp) == "3 along x"
    assert words(1.0, 1.0 + 1e-6) == "3 along y"
