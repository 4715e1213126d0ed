"""DOFs chosen for the user: a scene that lists none gets a valid set, which describes the
same mechanism as the set the built-in scene lists (the same natural frequencies)."""

import copy
import re

import numpy as np
import pytest

from flexure.core import ConstraintError, build_model, load_scene, natural_frequencies
from flexure.core.cli import main
from flexure.core.scene.building import parse_toml, scene_path


def without_dofs(name):
    """The built-in scene with its DOF lists removed (a DOF deformation becomes released)."""
    data = copy.deepcopy(parse_toml(scene_path(name)))
    for node in data["nodes"].values():
        node.pop("dof", None)
    for element in data["elements"].values():
        listed = element.pop("dof", [])
        if listed:
            element["released"] = sorted(set(element.get("released", [])) | set(listed))
    return data


@pytest.mark.parametrize("name, expected", [
    ("truss_1dof_x", ("2.x",)),
    ("stage_planar_1dof", ("3.x",)),
    ("stage_planar_3dof", None),
    ("stage_spatial_1dof", ("3.x",)),
    ("stage_spatial_19dof", None),
])
def test_chosen_dofs_describe_the_same_mechanism(name, expected):
    """As many DOFs as the listed ones, reported in model.chosen_dofs, and every natural
    frequency the same to 3e-8 (another choice of coordinates linearises the same motion at
    the same equilibrium; the round-off of the 19-DOF spatial stage's lowest mode, 10.6 Hz
    beside modes of several kHz, is amplified to 1.6e-8 with the chosen set, 5.5e-9 with
    another; a wrong mechanism differs by percents)."""
    listed = load_scene(name)
    chosen = build_model(without_dofs(name), source=name)
    assert chosen.declared_dof_count == listed.declared_dof_count == chosen.ndof
    assert chosen.chosen_dofs == tuple(chosen.dof_names) and listed.chosen_dofs == ()
    if expected is not None:
        assert chosen.chosen_dofs == expected
    np.testing.assert_allclose(natural_frequencies(chosen).frequencies_hz,
                               natural_frequencies(listed).frequencies_hz, rtol=3e-8)


def test_a_free_rotation_in_space_gets_a_deformation_dof():
    """In space a rotational node's Euler parameters cannot be DOFs: the 19-DOF stage's
    bending and torsion of the meshed spring become DOF deformations instead."""
    model = build_model(without_dofs("stage_spatial_19dof"))
    assert not any(".lambda" in name for name in model.chosen_dofs)
    assert any(".e" in name for name in model.chosen_dofs)


@pytest.mark.parametrize("rotation", [[0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [0.2, -0.1, 0.4]])
def test_a_rotated_end_node_leaves_its_torsion_to_the_deformation(rotation):
    """A spatial beam released in torsion only, its end node starting rotated: no coordinate
    takes the twist (the translations' projections on it are round-off, 1e-17), so the
    torsion deformation is the one DOF, as with the node unrotated."""
    model = build_model({
        "scene": {"name": "twist", "dimension": 3},
        "sections": {"s": {"EA": 1e7, "GIt": 2.0, "EIy": 1e3, "EIz": 1e3}},
        "nodes": {"1": {"position": [0.0, 0.0, 0.0], "fixed": ["x", "y", "z"]},
                  "2": {"rotation": [0.0, 0.0, 0.0], "fixed": True},
                  "3": {"position": [0.1, 0.0, 0.0]},
                  "4": {"rotation": rotation, "inertia": [1e-3, 1e-3, 1e-3]}},
        "elements": {"b": {"type": "BEAM", "nodes": ["1", "2", "3", "4"], "section": "s",
                           "y_axis": [0.0, 1.0, 0.0], "released": ["e2"]}}})
    assert model.chosen_dofs == ("b.e2",)
    # GIt / l over J: the same torsion frequency however the node starts
    assert natural_frequencies(model).frequencies_hz[0] == pytest.approx(
        np.sqrt(2.0 / 0.1 / 1e-3) / (2 * np.pi), rel=1e-10)


def test_an_over_constrained_scene_without_dofs_is_still_named():
    """Two rigid collinear trusses hold a node: no DOF can fix that; the check names it."""
    data = {"scene": {"name": "collinear"}, "sections": {"s": {"EA": 1.0}},
            "nodes": {"A": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                      "B": {"position": [2.0, 0.0], "fixed": ["x", "y"]},
                      "C": {"position": [1.0, 0.0], "mass": 1.0}},
            "elements": {"AC": {"type": "PLTRUSS", "nodes": ["A", "C"], "section": "s"},
                         "CB": {"type": "PLTRUSS", "nodes": ["C", "B"], "section": "s"}}}
    with pytest.raises(ConstraintError, match="over-constrained: the prescribed deformations "
                                              "AC.e1, CB.e1 are mutually dependent"):
        build_model(data)


def test_analyze_reports_the_chosen_dofs(tmp_path, capsys):
    """The scene file without its `dof = [...]` line: `flexure analyze` names the DOF it chose
    and says so."""
    text = scene_path("stage_planar_1dof").read_text()
    assert re.search(r"^dof = ", text, flags=re.M)
    path = tmp_path / "no_dofs.toml"
    path.write_text(re.sub(r"^dof = .*$", "", text, flags=re.M))
    assert main(["analyze", str(path), "--modes", "1"]) == 0
    out = capsys.readouterr().out
    assert "(DOFs: 3.x; chosen by flexure, the scene lists none)" in out


def _whole_svd(matrix, rtol):
    """`nullspace.rank_and_null_space` by one SVD of the whole matrix (the plain reference)."""
    if matrix.shape[0] == 0:
        return 0, 0.0, np.eye(matrix.shape[1])
    _, s, vt = np.linalg.svd(matrix)
    top = float(s.max(initial=0.0))
    rank = int(np.sum(s > rtol * max(top, 1e-300)))
    entries = int(np.sum(s > rtol * max(np.abs(matrix).max(initial=0.0), 1e-300)))
    return entries, top, vt[rank:].T


@pytest.mark.parametrize("name", ["stage_planar_3dof", "stage_spatial_19dof"])
def test_the_choice_by_blocks_is_the_choice_by_whole_svds(name, monkeypatch):
    """The DOF choice takes the null spaces of the prescribed rows and of the chosen
    coordinates' projections block by block; with one SVD of each whole matrix instead it
    chooses the same DOFs in the same order (the 19-DOF stage: coordinates, then deformations
    for the motions they leave)."""
    from flexure.core.mechanics import constraints

    data = without_dofs(name)
    by_blocks = build_model(data, source=name).chosen_dofs
    monkeypatch.setattr(constraints, "rank_and_null_space", _whole_svd)
    assert build_model(data, source=name).chosen_dofs == by_blocks
    if name == "stage_spatial_19dof":
        assert any(".e" in dof for dof in by_blocks) and any(".x" in d for d in by_blocks)
