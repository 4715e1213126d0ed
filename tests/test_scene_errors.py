"""Every malformed scene gives a clear error naming the file, the key and what is wrong."""

import copy
import tomllib

import numpy as np
import pytest

from flexure.core import (
    ConstraintError,
    SceneError,
    build_model,
    load_scene,
    scene_path,
    scene_toml,
)
from flexure.core.cli import main

BASE = tomllib.loads(scene_path("stage_planar_1dof").read_text())


def scene(edit):
    data = copy.deepcopy(BASE)
    edit(data)
    return data


def write(tmp_path, data_or_text):
    path = tmp_path / "broken.toml"
    if isinstance(data_or_text, str):
        path.write_text(data_or_text)
    else:
        import io

        path.write_text(_to_toml(data_or_text, io.StringIO()))
    return path


def _to_toml(data, out, prefix=""):
    """A small TOML writer for the test scenes (tables, numbers, strings, lists)."""
    def value(v):
        if isinstance(v, str):
            return f'"{v}"'
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f'{k} = {value(x)}' for k, x in v.items()) + "}"
        return repr(v)

    scalars = {k: v for k, v in data.items() if not isinstance(v, dict)}
    if prefix:
        out.write(f"[{prefix}]\n")
    for k, v in scalars.items():
        out.write(f"{k} = {value(v)}\n")
    for k, v in data.items():
        if isinstance(v, dict):
            _to_toml(v, out, f"{prefix}.{k}" if prefix else f'"{k}"' if not k.isidentifier()
                     else k)
    return out.getvalue()


CASES = {
    "unknown node": (lambda d: d["elements"]["bar"].update(nodes=["3", "4", "99", "6"]),
                     ["elements.bar.nodes[2]", "unknown node '99'"]),
    "element without a section": (lambda d: d["elements"]["bar"].pop("section"),
                                  ["elements.bar", "without a section"]),
    "unknown section": (lambda d: d["elements"]["bar"].update(section="steel"),
                        ["elements.bar.section", "unknown section 'steel'"]),
    "zero-length element": (lambda d: d["nodes"]["5"].update(position=[0.0, 0.1]),
                            ["elements.bar.nodes", "zero-length element"]),
    "negative mass": (lambda d: d["nodes"]["3"].update(mass=-0.2),
                      ["nodes.3.mass", "expected a value >= 0.0, got -0.2"]),
    "released deformation without stiffness": (
        lambda d: d["elements"]["bar"].update(released=["e2"]),
        ["elements.bar.released", "released deformation 'e2' needs a stiffness",
         "no EI > 0"]),
    "unknown key": (lambda d: d["nodes"]["3"].update(mas=1.0),
                    ["nodes.3.mas", "unknown key"]),
    "unknown element type": (lambda d: d["elements"]["bar"].update(type="PLBEEM"),
                             ["elements.bar.type", "unknown element type 'PLBEEM'"]),
    "wrong node kind": (lambda d: d["elements"]["bar"].update(nodes=["3", "5", "4", "6"]),
                        ["elements.bar.nodes[1]", "node '5' is translational"]),
    "wrong number of nodes": (lambda d: d["elements"]["bar"].update(nodes=["3", "4"]),
                              ["elements.bar.nodes", "PLBEAM expects 4 nodes"]),
    "unknown deformation": (lambda d: d["elements"]["leaf_left"].update(released=["e7"]),
                            ["elements.leaf_left.released", "unknown name 'e7'"]),
    "fixed and dof": (lambda d: d["nodes"]["3"].update(fixed=["x"]),
                      ["nodes.3", "both fixed and a DOF"]),
    "position of wrong length": (lambda d: d["nodes"]["3"].update(position=[0.0]),
                                 ["nodes.3.position", "expected a list of 2 numbers"]),
    "not a number": (lambda d: d["sections"]["leaf"].update(E="steel"),
                     ["sections.leaf.E", "expected a number, got 'steel'"]),
    "node without position or angle": (lambda d: d["nodes"]["3"].pop("position"),
                                       ["nodes.3", "exactly one of 'position'"]),
    "input on unknown coordinate": (lambda d: d["inputs"]["F"].update(coordinate="z"),
                                    ["inputs.F.coordinate", "no coordinate 'z'"]),
    "output quantity": (lambda d: d["outputs"]["x"].update(quantity="jerk"),
                        ["outputs.x.quantity", "expected one of position, velocity, "
                         "acceleration", "jerk"]),
    "description that is no text": (lambda d: d["scene"].update(description=3),
                                    ["scene.description", "expected a string, got 3"]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_malformed_scene_is_refused_with_a_clear_message(case, tmp_path):
    edit, fragments = CASES[case]
    path = write(tmp_path, scene(edit))
    with pytest.raises(SceneError) as error:
        load_scene(path)
    message = str(error.value)
    assert message.startswith(str(path))
    for fragment in fragments:
        assert fragment in message


def test_ndof_mismatch_names_the_counts():
    data = scene(lambda d: d["nodes"]["4"].update(dof=["phi"]))
    with pytest.raises(ConstraintError) as error:
        build_model(data)
    assert "NDOF = NX - NXO - NEO = 12 - 6 - 5 = 1" in str(error.value)
    assert "declares 2 DOF(s): 3.x, 4.phi" in str(error.value)


def test_invalid_toml_names_the_file_and_line(tmp_path):
    path = write(tmp_path, "[scene]\nname = \n")
    with pytest.raises(SceneError, match=r"broken\.toml: not valid TOML.*line 2"):
        load_scene(path)


def test_missing_scene_file_lists_the_builtin_scenes():
    with pytest.raises(SceneError, match="no_such_scene.*built in: .*stage_planar_1dof"):
        load_scene("no_such_scene.toml")


def collinear_trusses(dof=None):
    """A node held by two rigid collinear trusses: over- and under-constrained at once."""
    nodes = {"A": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
             "B": {"position": [2.0, 0.0], "fixed": ["x", "y"]},
             "C": {"position": [1.0, 0.0], "mass": 1.0}}
    if dof:
        nodes["C"]["dof"] = [dof]
    return {"scene": {"name": "collinear"}, "sections": {"s": {"EA": 1.0}}, "nodes": nodes,
            "elements": {"AC": {"type": "PLTRUSS", "nodes": ["A", "C"], "section": "s"},
                         "CB": {"type": "PLTRUSS", "nodes": ["C", "B"], "section": "s"}}}


def test_over_and_under_constrained_parts_are_named():
    with pytest.raises(ConstraintError) as error:
        build_model(collinear_trusses())
    message = str(error.value)
    assert "over-constrained: the prescribed deformations AC.e1, CB.e1 are mutually dependent" \
        in message
    assert "under-constrained: the coordinates C.y can move" in message


def test_a_listed_dof_that_leaves_the_mechanism_free_is_under_constrained():
    """The planar stage with 3.y listed as its DOF (the right count, 1): the rigid
    elongations already fix 3.y, and the sideways motion has no DOF. A listed set is checked,
    never replaced (a scene that lists none gets one chosen: tests/test_dof_choice.py)."""
    data = scene(lambda d: d["nodes"]["3"].update(dof=["y"]))
    with pytest.raises(ConstraintError) as error:
        build_model(data)
    message = str(error.value)
    assert "under-constrained: the coordinates 3.x, 5.x can move" in message
    # and the other side, so that following the advice keeps the count right
    assert ("the DOF 3.y cannot move without changing the prescribed deformations "
            "leaf_left.e1 (to first order, where the model starts): no DOF here; declare a DOF "
            "among the coordinates that can move (3.x, 5.x) instead") in message


def test_an_exactly_constrained_model_passes():
    model = build_model(collinear_trusses().copy() | {
        "nodes": {**collinear_trusses()["nodes"],
                  "B": {"position": [1.0, 1.0], "fixed": ["x", "y"]}}})
    assert model.dof_count()["ndof"] == 0


def test_cli_reports_a_scene_error_without_traceback(tmp_path, capsys):
    path = write(tmp_path, scene(lambda d: d["nodes"]["3"].update(mass=-1.0)))
    assert main(["analyze", str(path)]) == 2
    err = capsys.readouterr().err
    assert "flexure analyze: error:" in err and "nodes.3.mass" in err
    assert "Traceback" not in err


def test_cli_reports_a_constraint_error_without_traceback(tmp_path, capsys):
    path = write(tmp_path, scene(lambda d: d["elements"]["leaf_right"].update(released=["e2"])))
    assert main(["analyze", str(path), "--json"]) == 2
    err = capsys.readouterr().err
    assert "not exactly constrained" in err and "Traceback" not in err


@pytest.mark.parametrize("keys, fragment", [
    (["nodes.3.mas"], "'nodes.3.mas' is not a key this scene declares"),
    (["elements.bar.type"], "'elements.bar.type' is not a number"),
    ("nodes.3.mass", "expected a list of scene keys"),
])
def test_tunable_keys_must_name_numbers_of_the_scene(keys, fragment):
    data = scene(lambda d: d["scene"].update(tunable=keys))
    with pytest.raises(SceneError, match="scene.tunable") as error:
        build_model(data)
    assert fragment in str(error.value)


def test_tunable_keys_reach_the_model():
    assert load_scene("stage_planar_1dof").tunable == ["sections.bar.rho_A"]


def triple_leaf_guidance():
    """stage_planar_1dof with a third leaf in the middle, its bar in two rigid halves: three
    rigid leaf elongations for the bar's two motions besides the sideways one, one too many."""
    data = copy.deepcopy(BASE)
    nodes, elements = data["nodes"], data["elements"]
    nodes["9"] = {"position": [0.05, 0.0], "fixed": ["x", "y"]}
    nodes["10"] = {"angle": 0.0, "fixed": ["phi"]}
    nodes["11"] = {"position": [0.05, 0.1]}
    nodes["12"] = {"angle": 0.0}
    elements["leaf_mid"] = {**elements["leaf_left"], "nodes": ["9", "10", "11", "12"]}
    bar = elements.pop("bar")
    elements["bar_a"] = {**bar, "nodes": ["3", "4", "11", "12"]}
    elements["bar_b"] = {**bar, "nodes": ["11", "12", "5", "6"]}
    return data


def test_an_over_constraint_comes_with_a_release_that_removes_it():
    """The check names the dependent set and proposes one release from it that the section
    allows (a leaf's elongation, not the stiffness-less bar's); applying the proposal gives an
    exactly constrained guidance with its one DOF."""
    from flexure.core.mechanics.constraints import proposed_releases

    data = triple_leaf_guidance()
    with pytest.raises(ConstraintError) as error:
        build_model(data)
    message = str(error.value)
    assert "over-constrained: the prescribed deformations leaf_left.e1, leaf_right.e1, " \
           "leaf_mid.e1, bar_a.e3, bar_b.e2 are mutually dependent" in message
    assert "a release that removes the over-constraint: leaf_mid.e1 (" in message
    assert proposed_releases(build_model(data, check=False)) == ["leaf_mid.e1"]
    data["elements"]["leaf_mid"]["released"] = ["e1", "e2", "e3"]
    model = build_model(data)
    assert model.declared_dof_count == model.ndof == 1


def test_an_exact_model_needs_no_release():
    from flexure.core.mechanics.constraints import proposed_releases

    assert proposed_releases(load_scene("stage_planar_3dof")) == []
    assert proposed_releases(load_scene("stage_spatial_19dof")) == []


def test_collinear_trusses_get_one_release_proposed():
    """Two rigid collinear trusses: release one elongation (the later, both can be); the
    sideways freedom of C stays, named as under-constrained."""
    with pytest.raises(ConstraintError) as error:
        build_model(collinear_trusses())
    message = str(error.value)
    assert "a release that removes the over-constraint: CB.e1 (" in message
    assert "under-constrained: the coordinates C.y can move" in message


def test_the_quick_regularity_test_clears_only_well_conditioned_matrices():
    """check_exact_constraint skips its SVD when an LU condition estimate clears the
    constraint Jacobian by a margin; a matrix near singular or singular goes to the SVD."""
    from flexure.core.mechanics.constraints import CLEAR_RCOND, RANK_TOLERANCE, clearly_regular

    rng = np.random.default_rng(3)
    u, _ = np.linalg.qr(rng.normal(size=(40, 40)))
    v, _ = np.linalg.qr(rng.normal(size=(40, 40)))
    for smallest, cleared in ((1e-2, True), (1e-8, False), (RANK_TOLERANCE / 10, False),
                              (0.0, False)):
        matrix = u @ np.diag(np.geomspace(1.0, max(smallest, 1e-300), 40)) @ v.T
        if smallest == 0.0:
            matrix[:, -1] = matrix[:, 0]  # exactly dependent columns
        assert clearly_regular(matrix) == cleared, smallest
    assert CLEAR_RCOND >= 50 * RANK_TOLERANCE  # a margin over the SVD threshold
    assert not clearly_regular(np.full((3, 3), np.nan)) and not clearly_regular(np.ones((2, 3)))


def test_the_quick_test_and_the_svd_agree_on_meshed_stages():
    """The condition estimate behind the quick test tracks the SVD's sigma_min / sigma_max
    (within a factor of 2) on meshed spatial stages, the largest of 1 750 free coordinates
    (its ratio 5e-7: cleared without an SVD)."""
    import scipy.linalg

    from flexure.core.mechanics import assembly
    from flexure.core.mechanics.constraints import column_scale
    from flexure.core.mechanics.kinematics import Kinematics
    from flexure.core.scene.building import parse_toml

    for segments in (4, 20):
        data = copy.deepcopy(parse_toml(scene_path("stage_spatial_1dof")))
        for leaf in ("leaf_left", "leaf_right"):
            data["elements"][leaf]["segments"] = segments
        model = build_model(data, check=False)
        kin = Kinematics(model)
        _, De = assembly.deformation_jacobian(model, model.initial_coordinates)
        scale = column_scale(model, kin.length_scale)[kin.free]
        dof_rows = np.zeros((kin.dof_positions.size, kin.free.size))
        dof_rows[np.arange(kin.dof_positions.size), kin.dof_positions] = 1.0
        full = np.vstack([De[np.ix_(kin.constraint_rows, kin.free)] * scale, dof_rows])
        sigma = np.linalg.svd(full, compute_uv=False)
        lu, _ = scipy.linalg.lu_factor(full)
        estimate, _ = scipy.linalg.lapack.dgecon(lu, np.linalg.norm(full, 1), norm="1")
        assert 0.5 < estimate / (sigma[-1] / sigma[0]) < 2.0


def test_a_dated_description_is_refused_before_a_scene_is_written_back(tmp_path, capsys):
    # flexure reduce writes the scene back with scene_toml, which has no TOML dates: the
    # scene is refused on load, in one line, not with a traceback at the writing
    path = tmp_path / "dated.toml"
    path.write_text(scene_path("truss_1dof_x").read_text().replace(
        'description = "', 'description = 1979-05-27\n# "', 1))
    assert main(["reduce", str(path), "--keep", "1", "--out", str(tmp_path / "r.toml")]) == 2
    assert capsys.readouterr().err == (f"flexure reduce: error: {path}: scene.description: "
                                       "expected a string, got datetime.date(1979, 5, 27)\n")


def test_every_mistake_of_a_table_is_named_at_once(tmp_path, capsys):
    """Two wrong nodes and a wrong section: the sections are read first, and their one mistake
    is reported alone; mended, both nodes' mistakes come together, one per line, and the
    elements (which might only repeat them) are not read yet."""
    data = tomllib.loads(scene_path("stage_planar_1dof").read_text())
    data["sections"]["leaf"]["E"] = -1.0
    data["nodes"]["3"]["mass"] = -0.2
    data["nodes"]["5"]["position"] = [0.1]
    data["elements"]["bar"]["nodes"] = ["3", "4", "9", "6"]
    with pytest.raises(SceneError) as one:
        build_model(data, source="s.toml")
    assert str(one.value) == "s.toml: sections.leaf.E: expected a value >= 0.0, got -1.0"
    data["sections"]["leaf"]["E"] = 2.1e11
    with pytest.raises(SceneError) as two:
        build_model(data, source="s.toml")
    assert str(two.value) == (
        "s.toml: 2 mistakes:\n"
        "  nodes.3.mass: expected a value >= 0.0, got -0.2\n"
        "  nodes.5.position: expected a list of 2 numbers, got [0.1]")
    data["nodes"]["3"]["mass"], data["nodes"]["5"]["position"] = 0.0, [0.1, 0.1]
    with pytest.raises(SceneError, match=r"^s\.toml: elements\.bar\.nodes\[2\]: unknown node"):
        build_model(data, source="s.toml")
    path = tmp_path / "broken.toml"
    data["elements"]["bar"]["nodes"] = ["3", "4", "5", "6"]
    data["nodes"]["3"]["mass"], data["nodes"]["5"]["mass"] = -1.0, -2.0
    path.write_text(scene_toml(data))
    assert main(["analyze", str(path)]) == 2
    err = capsys.readouterr().err
    assert "2 mistakes:\n  nodes.3.mass" in err and "nodes.5.mass" in err
    assert "Traceback" not in err
