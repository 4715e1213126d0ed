"""Model reduction (`flexure reduce`) and writing scenes back to TOML."""

import copy
import json
import tomllib

import numpy as np
import pytest
import scipy.linalg

from flexure.core import FlexureError, build_model, load_scene, natural_frequencies
from flexure.core.analysis.reduction import frozen_scene, propose_reduction
from flexure.core.cli import main
from flexure.core.scene.building import builtin_scenes, parse_toml, scene_path
from flexure.core.scene.scene_writer import scene_toml


@pytest.mark.parametrize("name", builtin_scenes())
def test_a_written_scene_reads_back_the_same(name):
    data = parse_toml(scene_path(name))
    assert tomllib.loads(scene_toml(data, "a header\nover two lines")) == data


def test_what_a_scene_cannot_hold_is_named():
    with pytest.raises(ValueError, match=r"nodes\.3\.mass: nan has no place in a scene"):
        scene_toml({"nodes": {"3": {"mass": float("nan")}}})
    with pytest.raises(ValueError, match=r"scene\.gravity: a set cannot be written"):
        scene_toml({"scene": {"gravity": {1.0}}})


def test_the_3_dof_stage_reduces_to_the_1_dof_stage():
    """Keeping its first mode, stage_planar_3dof freezes the two leaf elongations (their
    share of the mode's strain energy 1.2e-5) and is then stage_planar_1dof: the same
    frequency to round-off, an independent model of the same stage."""
    data = parse_toml(scene_path("stage_planar_3dof"))
    reduction = propose_reduction(data, 1, 1.0)
    assert sorted(reduction.frozen) == [("leaf_left", "e1"), ("leaf_right", "e1")]
    assert (reduction.ndof_full, reduction.ndof_reduced) == (3, 1)
    assert reduction.change_percent <= 1.0 and reduction.dofs_chosen
    assert all(reduction.shares[key] < 1e-4 for key in reduction.frozen)
    reduced = build_model(reduction.scene)
    one_dof = natural_frequencies(load_scene("stage_planar_1dof")).frequencies_hz
    np.testing.assert_allclose(natural_frequencies(reduced).frequencies_hz, one_dof,
                               rtol=1e-9)


def test_no_tolerance_freezes_nothing():
    reduction = propose_reduction(parse_toml(scene_path("stage_planar_3dof")), 1, 0.0)
    assert reduction.frozen == [] and reduction.ndof_reduced == 3


def test_a_release_the_mechanism_needs_is_never_frozen():
    """The spatial stage's right leaf is cut locally (torsion and its second bending released,
    or the pair is over-constrained); meshed in 4 segments, only what keeps the model valid is
    frozen, and the five lowest frequencies stay within 1 %."""
    data = copy.deepcopy(parse_toml(scene_path("stage_spatial_1dof")))
    for leaf in ("leaf_left", "leaf_right"):
        data["elements"][leaf]["segments"] = 4
    reduction = propose_reduction(data, 5, 1.0)
    assert reduction.frozen and reduction.ndof_reduced < reduction.ndof_full
    assert reduction.change_percent <= 1.0
    build_model(reduction.scene)  # exactly constrained
    for key in reduction.frozen:  # each alone keeps it valid too
        build_model(frozen_scene(data, [key])[0])


def test_frozen_elongations_come_first_whatever_the_tolerance():
    """--freeze e1: every elongation prescribed zero before the ranking, even at a tolerance
    of 0 (the chapter's elongation-frozen model); on stage_planar_3dof that is
    stage_planar_1dof, shown beside the full and the reduced frequencies."""
    data = parse_toml(scene_path("stage_planar_3dof"))
    reduction = propose_reduction(data, 1, 0.0, freeze=("e1",))
    assert sorted(reduction.forced) == [("leaf_left", "e1"), ("leaf_right", "e1")]
    assert sorted(reduction.frozen) == sorted(reduction.forced)
    assert reduction.ndof_forced == reduction.ndof_reduced == 1
    one_dof = natural_frequencies(load_scene("stage_planar_1dof")).frequencies_hz
    np.testing.assert_allclose(reduction.forced_hz, one_dof, rtol=1e-9)
    none = propose_reduction(parse_toml(scene_path("stage_spatial_19dof")), 2, 0.0,
                             freeze=("e1",))  # its elongations are prescribed already
    assert none.forced == [] and none.forced_hz is None


def test_keeping_more_modes_than_dofs_is_refused():
    with pytest.raises(FlexureError, match="--keep 2: the model has only 1 DOFs"):
        propose_reduction(parse_toml(scene_path("stage_planar_1dof")), 2)


def test_reduce_command_writes_a_scene_that_loads(tmp_path, capsys):
    out = tmp_path / "reduced.toml"
    assert main(["reduce", "stage_planar_3dof", "--keep", "1", "--out", str(out),
                 "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    # the two leaves' elongations carry equal shares: the scene's order decides (ties.py)
    assert result["frozen"] == ["leaf_left.e1", "leaf_right.e1"] and result["forced"] == []
    assert result["ndof_reduced"] == 1 and result["change_percent"] < 0.01
    model = load_scene(out)
    assert model.ndof == 1 and model.chosen_dofs == ("3.x",)
    assert model.name == "reduced"  # another model: its file's name, which names its FMU
    assert out.read_text().startswith("# stage_planar_3dof, reduced by `flexure reduce")


@pytest.mark.parametrize("argv, message", [
    (["--keep", "0"], "argument --keep: expected an integer >= 1, got '0'"),
    (["--keep", "1", "--tol", "-1"], "argument --tol: expected a number > 0, got '-1'"),
    (["--keep", "9"], "--keep 9: the model has only 3 DOFs"),
    (["--keep", "1", "--out", "reduced.txt"], "expected a file name ending in .toml"),
    (["--keep", "1", "--freeze", "x1"], "expected deformation names such as e1 or e1,e2"),
    (["--keep", "1", "--freeze", "e1,e9"], "--freeze e9: no element of the model has it "
                                           "(its deformations: e1, e2, e3)"),
])
def test_reduce_command_refuses_bad_options_without_traceback(argv, message, tmp_path,
                                                             capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    try:
        code = main(["reduce", "stage_planar_3dof", *argv])
    except SystemExit as exit_:  # argparse refuses an option's value itself
        code = exit_.code
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())  # nothing written


def test_the_projected_trials_give_the_built_models_frequencies():
    """At rest without load the bisection's trials project the full linearisation onto the
    motions that keep the frozen deformations zero (`projected_frequencies`, one QR for
    every prefix of the order): for the 19-DOF spatial stage with the first 2, 5 and 9 of
    its freezable deformations frozen, the lowest three frequencies of the built reduced
    scene to 1e-7 relative (measured 4e-9 on the lowest: round-off of the stiff elongations
    reaches it amplified, as between any two orderings of the same sums), and those of the
    plain projection on each prefix's own null space (scipy's, from an SVD) likewise
    (measured 3.8e-9 on the lowest, 7e-12 on the others); the loaded scene (1 N sideways) is
    not projected."""
    from flexure.core.analysis.reduction import (
        deformation_rows,
        frozen_scene,
        lowest_frequencies,
        projected_frequencies,
    )
    from flexure.core.mechanics.freezing import freezable

    loaded = parse_toml(scene_path("stage_spatial_19dof"))
    data = copy.deepcopy(loaded)
    for node in data["nodes"].values():  # at rest: without its sideways force
        node.pop("force", None)
    model = build_model(data)
    modes, _ = lowest_frequencies(model, 3)
    rows = deformation_rows(model, data)
    keys = sorted(rows)
    order = [keys[k] for k in freezable(model, [rows[key] for key in keys])]
    lin = modes.linear_model
    projected = projected_frequencies(model, lin, rows, order, 3)
    assert projected is not None
    for count in (2, 5, 9):
        scene, _ = frozen_scene(data, order[:count])
        built, _ = lowest_frequencies(build_model(scene), 3)
        found = projected(count)
        assert np.allclose(found, built.frequencies_hz, rtol=1e-7, atol=0.0)
        frozen = np.concatenate([rows[key] for key in order[:count]])
        n = scipy.linalg.null_space(lin.solution.config.De[frozen] @ lin.DF)
        values = scipy.linalg.eigh(n.T @ lin.K @ n, n.T @ lin.M0 @ n, eigvals_only=True)[:3]
        assert np.allclose(found, np.sqrt(values) / (2.0 * np.pi), rtol=1e-7, atol=0.0)
    model = build_model(loaded)
    modes, _ = lowest_frequencies(model, 3)
    assert projected_frequencies(model, modes.linear_model, rows, order, 3) is None
