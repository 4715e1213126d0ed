"""SPACAR input files (.dat): the course notes' models read from their SPACAR input give the
results of the built-in scenes; `flexure import` writes a scene that loads the same; every
mistake is refused in one line that names the file and the line."""

import tomllib
from pathlib import Path

import numpy as np
import pytest

from flexure.core import (
    SceneError,
    buckling_load_factors,
    linearize,
    load_scene,
    natural_frequencies,
    state_space,
    static_equilibrium,
)
from flexure.core.cli import main
from flexure.core.scene.building import parse_toml, scene_path
from flexure.core.scene.spacar_input import read_spacar

SPACAR = Path(__file__).resolve().parents[1] / "examples" / "spacar"
RTOL = 1e-9

# each .dat file of examples/spacar/ and the built-in scene it mirrors, with a load that moves
# the stage (set on both: the .dat carries the buckling example's 1 N down, which its rigid
# bar and unstretchable springs take without a displacement)
PAIRS = [
    ("truss_1dof_x", {}),
    ("truss_1dof_e", {}),
    ("stage_planar_1dof", {"nodes.3.force": [0.5, -1.0]}),
    ("stage_planar_3dof", {"nodes.3.force": [0.5, -1.0]}),
    ("stage_spatial_1dof", {"nodes.3.force": [0.5, -1.0, 0.0]}),
]


def results(model):
    """DOF count and names, static displacements (m, rad), frequencies (Hz) and the
    state-space matrices: what the comparison compares."""
    solution = static_equilibrium(model)
    lin = linearize(model, solution)
    plant = state_space(model, linear_model=lin)
    return {"count": model.dof_count(), "dofs": model.dof_names,
            "coordinates": model.coordinate_names,
            "displacement": solution.x - model.initial_coordinates,
            "hz": natural_frequencies(model, linear_model=lin).frequencies_hz,
            "ABCD": [plant.A, plant.B, plant.C, plant.D]}


def relative(a, b):
    """|a - b| / |b| over all entries (0 for two zero arrays)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.linalg.norm(b)
    return np.linalg.norm(a - b) / scale if scale else np.linalg.norm(a)


@pytest.mark.parametrize("name, loads", PAIRS, ids=[p[0] for p in PAIRS])
def test_the_course_notes_models_read_from_spacar_input_give_the_scenes_results(name, loads):
    dat = results(load_scene(SPACAR / f"{name}.dat", overrides=loads))
    toml = results(load_scene(name, overrides=loads))
    assert dat["count"] == toml["count"]
    # nodes keep their numbers; elements are SPACAR's numbers here, named in the scene
    renamed = dict(zip(read_spacar(SPACAR / f"{name}.dat")["elements"],
                       parse_toml(scene_path(name))["elements"], strict=True))
    dofs = [f"{renamed[owner]}.{what}" if what[0] == "e" else f"{owner}.{what}"
            for owner, what in (dof.split(".") for dof in dat["dofs"])]
    assert dofs == toml["dofs"] and dat["coordinates"] == toml["coordinates"]
    assert np.linalg.norm(toml["displacement"]) > 1e-8  # the load moves something
    assert relative(dat["displacement"], toml["displacement"]) < RTOL
    assert dat["hz"] == pytest.approx(toml["hz"], rel=RTOL)
    for a, b in zip(dat["ABCD"], toml["ABCD"], strict=True):
        assert a.shape == b.shape and relative(a, b) < RTOL
    # the .dat's own load is the scene's buckling reference
    assert buckling_load_factors(load_scene(SPACAR / f"{name}.dat")) == \
        pytest.approx(buckling_load_factors(load_scene(name)), rel=RTOL)


def test_the_published_figures_come_out():
    """The course notes' numbers: 10.6584 Hz and x = 0.1011 m for pf1dtrx, the load factor
    78.75 of pf2db, 10.6 / 2129 / 3585 Hz for the 3-DOF stage."""
    truss = load_scene(SPACAR / "truss_1dof_x.dat")
    assert natural_frequencies(truss).frequencies_hz == pytest.approx([10.6584], rel=1e-5)
    assert static_equilibrium(truss).coordinates()["2.x"] == pytest.approx(0.1 + 1 / 945,
                                                                           rel=1e-9)
    assert buckling_load_factors(load_scene(SPACAR / "stage_planar_1dof.dat")) == \
        pytest.approx([78.75], rel=2e-3)
    stage = natural_frequencies(load_scene(SPACAR / "stage_planar_3dof.dat")).frequencies_hz
    assert stage == pytest.approx([10.6, 2129.0, 3585.0], rel=5e-3)


# -- the mapping --------------------------------------------------------------------------------
MAPPED = """\
# a made-up planar model that uses every keyword: lower case, comments, a Fortran exponent
pltruss 5  1 2          % a truss
PLBEAM  6  2 3 4 7      # a beam: p, rotational p, q, rotational q
x 1 0 0
X 2 1.0 0.0
X 4 1.0 1.0D0
FIX 1
fix 3
INPUTX 2 2
DYNX 4 1
DYNX 7 1
RLSE 5 1
DYNE 6 3
RLSE 6 1 2
END
HALT
ESTIFF 5 10.0
ESTIFF 6 20.0 0.5
EDAMP 6 0.1 0.01
EM 6 2.0 0
XM 4 0.3
XM 7 -0.01
XF 4 1.0 -2.0
XF 7 0.25
GRAVITY 0 -9.81
ITERSTEP 10 1 0.0000005 1 1 0
END
HALT
INPUTF 2 7 1
INPUTF 1 4 2
OUTXP 2 4 1
OUTX 1 7 1
END
END
VISUALIZATION           % SPAVISUAL's part: not read
BEAMPROPS 6
"""


def test_every_keyword_maps_to_its_scene_key(tmp_path):
    path = tmp_path / "my-model.dat"
    path.write_text(MAPPED)
    assert read_spacar(path) == {
        "scene": {"name": "my_model", "dimension": 2, "gravity": [0.0, -9.81],
                  "description": "imported from the SPACAR input file my-model.dat; INPUTX "
                                 "held at the X position: 2.y"},
        "sections": {"5": {"EA": 10.0}, "6": {"EA": 20.0, "EI": 0.5, "EdA": 0.1, "EdI": 0.01,
                                              "rho_A": 2.0}},
        "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "2": {"position": [1.0, 0.0], "fixed": ["y"]},
                  "3": {"angle": 0.0, "fixed": ["phi"]},
                  "4": {"position": [1.0, 1.0], "dof": ["x"], "mass": 0.3,
                        "force": [1.0, -2.0]},
                  "7": {"angle": 0.0, "dof": ["phi"], "inertia": -0.01, "moment": 0.25}},
        "elements": {"5": {"type": "PLTRUSS", "nodes": ["1", "2"], "section": "5",
                           "released": ["e1"]},
                     "6": {"type": "PLBEAM", "nodes": ["2", "3", "4", "7"], "section": "6",
                           "released": ["e1", "e2"], "dof": ["e3"]}},
        "inputs": {"u1": {"node": "4", "coordinate": "y"},
                   "u2": {"node": "7", "coordinate": "phi"}},
        "outputs": {"y1": {"node": "7", "coordinate": "phi", "quantity": "position"},
                    "y2": {"node": "4", "coordinate": "x", "quantity": "velocity"}}}


def test_spatial_nodes_map_to_rotation_fixed_and_inertia_tensor(tmp_path):
    path = tmp_path / "2beam.dat"
    path.write_text("BEAM 1 1 2 3 4 0 0 1\nX 1 0 0 0\nX 3 1 0 0\nFIX 1\nFIX 2 1 2 3 4\n"
                    "END\nXM 4 1 0.1 0.2 2 0.3 3\nGRAVITY 0 0 -9.81\nEND\n")
    data = read_spacar(path)
    assert data["scene"]["name"] == "spacar_2beam" and data["scene"]["dimension"] == 3
    assert data["nodes"]["2"] == {"rotation": [0.0, 0.0, 0.0], "fixed": True}
    assert data["nodes"]["4"] == {"rotation": [0.0, 0.0, 0.0],
                                  "inertia": [[1.0, 0.1, 0.2], [0.1, 2.0, 0.3], [0.2, 0.3, 3.0]]}
    assert data["elements"]["1"]["y_axis"] == [0.0, 0.0, 1.0]
    assert data["sections"]["1"] == {}


# -- flexure import -----------------------------------------------------------------------------
def test_import_writes_a_scene_that_loads_to_the_same_model(tmp_path, capsys):
    source = SPACAR / "stage_planar_3dof.dat"
    out = tmp_path / "stage.toml"
    assert main(["import", str(source), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {out}" in printed and "NDOF = NX - NXO - NEO = 12 - 6 - 3 = 3" in printed
    text = out.read_text()
    assert text.startswith("# Imported by `flexure import` from the SPACAR input file "
                           "stage_planar_3dof.dat")
    assert tomllib.loads(text) == read_spacar(source)  # floats written exactly
    assert parse_toml(source) == read_spacar(source)  # every command's reader takes a .dat
    imported = natural_frequencies(load_scene(out)).frequencies_hz
    assert imported == pytest.approx(natural_frequencies(load_scene(source)).frequencies_hz,
                                     rel=1e-12)


def test_import_writes_next_to_where_it_runs_by_default(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["import", str(SPACAR / "truss_1dof_x.dat")]) == 0
    assert tomllib.loads((tmp_path / "truss_1dof_x.toml").read_text())["scene"]["name"] == \
        "truss_1dof_x"


def test_import_refuses_a_file_that_is_not_dat(capsys):
    assert main(["import", str(SPACAR.parent / "scenes" / "truss_1dof_x.toml")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("flexure import: error: ") and "expected a SPACAR input file" in err


@pytest.mark.parametrize("command", ["import", "analyze"])
def test_cli_reports_a_mistake_in_one_line_with_exit_code_2(command, tmp_path, capsys):
    path = tmp_path / "bad.dat"
    path.write_text(TRUSS.replace("X 2 0.1 0.0", "X 2 0.1 O.0"))
    assert main([command, str(path)]) == 2
    assert capsys.readouterr().err == (f"flexure {command}: error: {path}: line 3: X: "
                                       "coordinate: expected a number, got 'O.0'\n")


# -- mistakes -----------------------------------------------------------------------------------
TRUSS = """\
PLTRUSS 1 1 2
X 1 0.0 0.0
X 2 0.1 0.0
FIX 1
FIX 2 2
RLSE 1 1
DYNX 2 1
END
HALT
ESTIFF 1 94.5
EM 1 0.1413
XM 2 0.206
XF 2 1.0 0.0
END
HALT
INPUTF 1 2 1
OUTX 1 2 1
END
END
"""
BEAM = """\
BEAM 1 1 2 3 4 1 0 0
BEAM 2 3 4 5 6 0 1 0
X 1 0 0 0
X 3 0 0.1 0
X 5 0.1 0.1 0
FIX 1
FIX 2
RLSE 1 5 6
DYNX 3 1
END
ESTIFF 1 1.89e6 0.0595 51.03 0.039375 0 0
EM 1 0.07065 1.909e-06 1.9075e-06 1.5e-09 0
END
"""


def edit(text, old, new):
    assert old in text
    return text.replace(old, new, 1)


# (case, base text, the text with its mistake, the line named, a fragment of the message)
MISTAKES = [
    ("unknown keyword", TRUSS, edit(TRUSS, "FIX 1\n", "FOO 1\n"), 4,
     "FOO: unknown keyword (flexure reads"),
    ("unsupported keyword", TRUSS, edit(TRUSS, "XF 2 1.0 0.0", "DELXF 2 1.0 0.0"), 13,
     "DELXF: a load increment over the load steps is not supported"),
    ("a number for a keyword", TRUSS, edit(TRUSS, "FIX 1\n", "1 0.0\n"), 4,
     "a line must start with a keyword"),
    ("too few values", TRUSS, edit(TRUSS, "X 2 0.1 0.0", "X 2 0.1"), 3,
     "X: expected 3 values (node number and 2 coordinates in this 2-D model), got 2"),
    ("too many values", TRUSS, edit(TRUSS, "ESTIFF 1 94.5", "ESTIFF 1 94.5 2.0"), 10,
     "expected 2 values (element number, then EA for a PLTRUSS), got 3"),
    ("no values", TRUSS, edit(TRUSS, "FIX 1\n", "FIX\n"), 4, "expected at least 1 value"),
    ("a DOF without a direction", TRUSS, edit(TRUSS, "DYNX 2 1", "DYNX 2"), 7,
     "DYNX: expected at least 2 values (node number and one or more directions), got 1"),
    ("a spatial inertia of three values", BEAM, edit(BEAM, "END\n", "END\nXM 4 1 2 3\n"), 11,
     "expected 7 values (node number, then Ixx Ixy Ixz Iyy Iyz Izz), got 4"),
    ("unknown node", TRUSS, edit(TRUSS, "FIX 1\n", "FIX 9\n"), 4,
     "FIX: unknown node 9: no X line and no element has it"),
    ("unknown element", TRUSS, edit(TRUSS, "RLSE 1 1", "RLSE 3 1"), 6,
     "unknown element 3: no element line defines it"),
    ("non-numeric value", TRUSS, edit(TRUSS, "XM 2 0.206", "XM 2 0,206"), 12,
     "XM: mass: expected a number, got '0,206'"),
    ("not a number: nan", TRUSS, edit(TRUSS, "XM 2 0.206", "XM 2 nan"), 12,
     "expected a number, got 'nan'"),
    ("a fractional node number", TRUSS, edit(TRUSS, "FIX 2 2", "FIX 2.0 2"), 5,
     "expected a node number (a positive integer of at most 9 digits), got '2.0'"),
    ("a node number of 5000 digits", TRUSS, edit(TRUSS, "FIX 2 2", "FIX " + "9" * 5000 + " 2"),
     5, "expected a node number (a positive integer of at most 9 digits), got '9999"),
    ("a direction fixed twice", TRUSS, edit(TRUSS, "FIX 2 2", "FIX 2 2 2"), 5,
     "FIX: y of node 2 is already fixed (FIX, line 5)"),
    ("a node fixed twice", TRUSS, edit(TRUSS, "FIX 2 2", "FIX 2 2\nFIX 2 2"), 6,
     "FIX: y of node 2 is already fixed (FIX, line 5)"),
    ("too large", TRUSS, edit(TRUSS, "ESTIFF 1 94.5", "ESTIFF 1 1e30"), 10,
     "EA: expected a magnitude <= 1e+20"),
    ("negative stiffness", TRUSS, edit(TRUSS, "ESTIFF 1 94.5", "ESTIFF 1 -94.5"), 10,
     "EA: expected a value >= 0, got -94.5"),
    ("negative mass", TRUSS, edit(TRUSS, "XM 2 0.206", "XM 2 -0.206"), 12,
     "mass: expected a value >= 0"),
    ("direction out of range", TRUSS, edit(TRUSS, "FIX 2 2", "FIX 2 3"), 5,
     "node 2 is translational with directions 1 to 2 (x, y); got 3"),
    ("deformation out of range", TRUSS, edit(TRUSS, "RLSE 1 1", "RLSE 1 2"), 6,
     "element 1 (PLTRUSS) has deformations 1 to 1; got 2"),
    ("fixed and a DOF", TRUSS, edit(TRUSS, "FIX 2 2", "FIX 2 1"), 7,
     "DYNX: x of node 2 is already fixed (FIX, line 5)"),
    ("released and a DOF", TRUSS, edit(TRUSS, "DYNX 2 1", "DYNE 1 1"), 7,
     "deformation 1 of element 1 is already released (RLSE, line 6)"),
    ("released without stiffness", TRUSS, edit(TRUSS, "ESTIFF 1 94.5", "ESTIFF 1 0"), 6,
     "RLSE: deformation 1 of element 1 is released but has no stiffness: flexure needs "
     "ESTIFF 1 with EA > 0"),
    ("element twice", TRUSS, edit(TRUSS, "X 1 0.0 0.0", "PLTRUSS 1 2 1\nX 1 0.0 0.0"), 2,
     "element 1 is defined twice (first on line 1)"),
    ("X twice", TRUSS, edit(TRUSS, "FIX 1\n", "X 1 0.0 0.0\n"), 4,
     "node 1 has an X line already (line 2)"),
    ("ESTIFF twice", TRUSS, edit(TRUSS, "EM 1 0.1413", "ESTIFF 1 94.5"), 11,
     "ESTIFF: element 1: given twice (first on line 10)"),
    ("gravity twice", TRUSS, edit(TRUSS, "XM 2 0.206", "GRAVITY 0 -9.81\nGRAVITY 0 -9.81"), 13,
     "GRAVITY: given twice (first on line 12)"),
    ("gravity of the wrong dimension", TRUSS, edit(TRUSS, "XM 2 0.206", "GRAVITY 0 -9.81 0"),
     12, "expected 2 values (2 components in this 2-D model)"),
    ("a translational node without X", TRUSS, edit(TRUSS, "X 2 0.1 0.0\n", ""), 1,
     "node 2 of element 1 is a translational node without an X line"),
    ("X on a rotational node", TRUSS, edit(TRUSS, "PLTRUSS 1 1 2", "PLBEAM 1 1 2 3 4\nX 3 1 1")
     .replace("X 2 0.1 0.0", "X 2 0 0"), 4, "node 2 is the rotational node of PLBEAM on line 1"),
    ("node of two kinds", TRUSS, edit(TRUSS, "PLTRUSS 1 1 2", "PLTRUSS 1 1 2\nPLBEAM 2 2 1 5 6"),
     2, "node 1 is rotational here but translational in PLTRUSS on line 1"),
    ("a node twice in an element", TRUSS, edit(TRUSS, "PLTRUSS 1 1 2", "PLTRUSS 1 1 1"), 1,
     "a node appears twice among [1, 1]"),
    ("planar and spatial mixed", TRUSS, edit(TRUSS, "X 1 0.0 0.0", "TRUSS 2 1 2\nX 1 0.0 0.0"),
     2, "a 3-D element in a 2-D model (PLTRUSS, line 1)"),
    ("no element", TRUSS, edit(TRUSS, "PLTRUSS 1 1 2\n", ""), None,
     "no element (PLTRUSS, PLBEAM, TRUSS or BEAM)"),
    ("missing END", TRUSS, TRUSS.replace("END\n", "").replace("HALT\n", ""), None,
     "no END: a SPACAR input file closes its kinematic block"),
    ("empty", TRUSS, "% nothing here\n", None, "no keyword line and no END"),
    ("a block without END", TRUSS, TRUSS[:TRUSS.index("INPUTF")] + "INPUTF 1 2 1\n", 16,
     "the block that starts here has no END before the end of the file"),
    ("HALT not after END", TRUSS, edit(TRUSS, "FIX 1\n", "HALT\n"), 4, "HALT must follow an END"),
    ("END with a value", TRUSS, edit(TRUSS, "END\nHALT\nESTIFF", "END 1\nHALT\nESTIFF"), 8,
     "END takes no values"),
    ("kinematics after END", TRUSS, edit(TRUSS, "XM 2 0.206", "FIX 2 1"), 12,
     "FIX: belongs to the kinematic block, before the first END"),
    ("dynamics before END", TRUSS, edit(TRUSS, "DYNX 2 1", "DYNX 2 1\nXM 2 0.1"), 8,
     "XM: belongs after the kinematic block's END"),
    ("an input value for a DOF", TRUSS, edit(TRUSS, "XM 2 0.206", "INPUTX 2 1 0.2"), 12,
     "INPUTX: x of node 2 is not a kinematic input: it is a DOF (DYNX, line 7); declare it "
     "with INPUTX 2 1 before the first END"),
    ("an input number twice", TRUSS, edit(TRUSS, "OUTX 1 2 1", "INPUTF 1 2 2"), 17,
     "number 1 is given twice (first in INPUTF on line 16)"),
    ("a gap in the outputs", TRUSS, edit(TRUSS, "OUTX 1 2 1", "OUTXP 2 2 1"), 17,
     "number 2 without a number 1"),
    ("a negative shear term", BEAM, edit(BEAM, "0.039375 0 0", "0.039375 -1e-6 0"), 11,
     "ESTIFF: EIy/GAs_z: expected a value >= 0, got -1e-6"),
    ("a shear term without its bending stiffness", BEAM,
     edit(BEAM, "51.03 0.039375 0 0", "0 0.039375 1e-6 0"), 11,
     "ESTIFF: element 1: the shear term EIy/GAs_z = 1e-06 m^2 needs EIy > 0"),
    ("a shear term that makes no number", BEAM, edit(BEAM, "0.039375 0 0", "0.039375 0 1e-30"),
     11, "ESTIFF: element 1: the shear term EIz/GAs_y = 1e-30 m^2 gives GAs_y = 3.9375e+28 N"),
    ("a damping shear term", BEAM, edit(BEAM, "EM 1", "EDAMP 1 0.1 0 0 0 0 1e-6\nEM 1"), 12,
     "EDAMP: flexure's damping has no shear terms of its own"),
    ("torsional inertia", BEAM, edit(BEAM, "0.07065 1.909e-06", "0.07065 2.0e-06"), 12,
     "Jxx/L = 2.0e-06 is not Jyy/L + Jzz/L"),
    ("product of inertia", BEAM, edit(BEAM, "1.5e-09 0", "1.5e-09 1e-9"), 12,
     "Jyz/L must be 0"),
    ("a BEAM without its axis", BEAM, edit(BEAM, "BEAM 1 1 2 3 4 1 0 0", "BEAM 1 1 2 3 4"), 1,
     "expected 8 values (element number, nodes p rp q rq and the principal y' axis"),
    ("a spatial rotation partly fixed", BEAM, edit(BEAM, "FIX 2\n", "FIX 2 2\n"), 7,
     "node 2 is a spatial rotational node: flexure fixes its orientation as a whole"),
    ("a spatial rotation as a DOF", BEAM, edit(BEAM, "DYNX 3 1", "DYNX 4 2"), 9,
     "node 4 is a spatial rotational node: its Euler parameters cannot be DOFs"),
    ("a moment in space", BEAM, edit(BEAM, "END\n", "END\nXF 4 0 0 1\n"), 11,
     "node 4 is a spatial rotational node: flexure applies no moments there"),
    ("an output on an Euler parameter", BEAM, edit(BEAM, "END\n", "END\nOUTX 1 4 1\n"), 11,
     "inputs and outputs on its Euler parameters are not supported"),
    ("rotational inertia of a planar beam", TRUSS,
     edit(TRUSS, "PLTRUSS 1 1 2", "PLTRUSS 1 1 2\nPLBEAM 2 2 3 5 6\nX 5 0.2 0")
     .replace("EM 1 0.1413", "EM 2 0.1413 0.001"), 13,
     "flexure's PLBEAM neglects the section's rotational inertia"),
]


@pytest.mark.parametrize("case, base, text, line, fragment", MISTAKES,
                         ids=[m[0] for m in MISTAKES])
def test_a_mistake_is_refused_naming_the_file_and_the_line(case, base, text, line, fragment,
                                                           tmp_path):
    path = tmp_path / "model.dat"
    path.write_text(base)
    read_spacar(path)  # the base reads: the mistake is what is refused
    path.write_text(text)
    with pytest.raises(SceneError) as raised:
        read_spacar(path)
    message = str(raised.value)
    where = f"{path}: line {line}: " if line is not None else f"{path}: "
    assert message.startswith(where), message
    assert fragment in message, message
    assert "\n" not in message


def test_an_unreadable_file_is_refused(tmp_path):
    with pytest.raises(SceneError, match=r"missing\.dat: cannot read the SPACAR input file: "
                                         r"No such file or directory"):
        read_spacar(tmp_path / "missing.dat")
    folder = tmp_path / "folder.dat"
    folder.mkdir()
    with pytest.raises(SceneError, match=r"folder\.dat: cannot read the SPACAR input file: "
                                         r"Is a directory"):
        read_spacar(folder)


def test_bytes_that_are_not_text_are_named_in_their_line(tmp_path):
    path = tmp_path / "binary.dat"
    path.write_bytes(TRUSS.encode().replace(b"X 2 0.1 0.0", b"X 2 0.1 \xff\xfe"))
    with pytest.raises(SceneError, match=r"line 3: X: coordinate: expected a number"):
        read_spacar(path)
    path.write_bytes(b"% caf\xe9: a Latin-1 comment\n" + TRUSS.encode())  # comments are free
    assert read_spacar(path)["nodes"]["2"]["position"] == [0.1, 0.0]


def test_an_fmu_builds_from_a_spacar_file_and_steps_like_the_scenes_fmu(tmp_path):
    """`flexure fmu build FILE.dat` (build_scene_fmu) reads the file as load_scene does and
    carries the scene written back as TOML: stepped by fmpy under the same force step, the
    FMU of pf2db and the FMU of the built-in stage_planar_1dof, given pf2db's 1 N downward load
    (its XF; the scene has it as the buckling reference only), give the same position to
    round-off (the same model, integrator and tolerance)."""
    from fmpy import simulate_fmu

    from flexure.fmu import build_scene_fmu

    results = []
    for scene, force, overrides in ((SPACAR / "stage_planar_1dof.dat", "u1", None),
                                    ("stage_planar_1dof", "F", {"nodes.3.force": [0.0, -1.0]})):
        fmu = build_scene_fmu(scene, tmp_path / f"{len(results)}.fmu", overrides=overrides)
        signal = np.array([(0.0, 1.0)], dtype=[("time", np.float64), (force, np.float64)])
        run = simulate_fmu(str(fmu), stop_time=0.02, output_interval=1e-3, input=signal)
        results.append(run[run.dtype.names[1]])
    assert np.ptp(results[1]) > 1e-6  # it moves
    np.testing.assert_allclose(results[0], results[1], rtol=0, atol=1e-12)


def test_a_large_import_says_how_long_it_will_take_before_it_starts(tmp_path, capsys,
                                                                    monkeypatch):
    """A chain of PLBEAMs whose estimate (SECONDS_PER_ELEMENT per element) passes SAY_FROM_S:
    the count and the estimate on stderr before the work; a small file says nothing."""
    from flexure.core.cli import spacar_import

    lines = [f"X {2 * i + 1} {i * 1e-3} 0.0" for i in range(11)]
    lines += [f"PLBEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * i + 3} {2 * i + 4}"
              for i in range(10)]
    lines += ["FIX 1", "FIX 2", "END", "HALT"]
    lines += [f"ESTIFF {i + 1} 1.0D6 1.0" for i in range(10)] + ["END", "END"]
    source = tmp_path / "chain.dat"
    source.write_text("\n".join(lines) + "\n")
    monkeypatch.chdir(tmp_path)
    assert main(["import", str(source)]) == 0
    assert "about" not in capsys.readouterr().err
    monkeypatch.setattr(spacar_import, "SECONDS_PER_ELEMENT", 1.0)  # as if 10 s
    assert main(["import", str(source), "-o", "again.toml"]) == 0
    err = capsys.readouterr().err
    assert err.startswith("flexure import: 10 elements and 22 nodes: about 10 s to build and "
                          "write\n")
