"""SPACAR's kinematic inputs and element outputs read from its input files: INPUTX with its
start value and DELINPX, INPUTE with DELINPE, INX, OUTE and OUTF. Each small file is imported
and checked against closed forms (a chain of springs along a line, where the elongations are
exactly linear in the displacements; a guided leaf), and against the same model written by
hand as a scene; every mistake is refused naming the file, the line and the keyword."""

import tomllib

import numpy as np
import pytest

from flexure.core import SceneError, build_model, load_scene, static_equilibrium
from flexure.core.analysis.motion_statespace import motion_state_space
from flexure.core.cli import main
from flexure.core.scene.spacar_input import import_spacar, read_spacar

EA1, EA2, L = 94.5, 189.0, 0.1  # N, N, m: two trusses of 0.1 m in a row along x
K1, K2 = EA1 / L, EA2 / L  # N/m
DELTA = 1e-3  # m, the prescribed increment
SERIES = K1 * K2 / (K1 + K2)  # N/m: the chain's stiffness at its moved end

# ground 1 -- truss 1 (K1) -- node 2 (a DOF) -- truss 2 (K2) -- node 3, moved DELTA along x
CHAIN = f"""\
% two trusses in a row, the free end moved by a prescribed input
PLTRUSS  1   1 2
PLTRUSS  2   2 3
X        1   0.0  0.0
X        2   0.1  0.0
X        3   0.2  0.0
FIX      1
FIX      2   2
FIX      3   2
INPUTX   3   1
DYNX     2   1
RLSE     1   1
RLSE     2   1
END
HALT
ESTIFF   1   {EA1}
ESTIFF   2   {EA2}
XM       2   0.206
DELINPX  3   1   {DELTA}
END
HALT
INX      1   3   1
OUTE     1   2   1
OUTF     2   2   1
OUTF     3   1   1
OUTX     4   2   1
END
END
"""

# the same chain written by hand as a scene: what the import must give the numbers of
CHAIN_SCENE = {
    "scene": {"name": "chain", "dimension": 2},
    "sections": {"1": {"EA": EA1}, "2": {"EA": EA2}},
    "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
              "2": {"position": [0.1, 0.0], "fixed": ["y"], "dof": ["x"], "mass": 0.206},
              "3": {"position": [0.2, 0.0], "fixed": ["y"]}},
    "elements": {"1": {"type": "PLTRUSS", "nodes": ["1", "2"], "section": "1",
                       "released": ["e1"]},
                 "2": {"type": "PLTRUSS", "nodes": ["2", "3"], "section": "2",
                       "released": ["e1"]}},
    "inputs": {"X": {"kind": "motion", "node": "3", "coordinate": "x", "value": 0.2 + DELTA}},
    "outputs": {"e2": {"element": "2", "deformation": "e1", "quantity": "deformation"},
                "s2": {"element": "2", "deformation": "e1", "quantity": "stress"},
                "s1": {"element": "1", "deformation": "e1", "quantity": "stress"},
                "x2": {"node": "2", "coordinate": "x"}}}


def write(tmp_path, text, name="model.dat"):
    path = tmp_path / name
    path.write_text(text)
    return path


def edit(text, old, new):
    assert old in text
    return text.replace(old, new, 1)


# -- INPUTX with DELINPX, INX, OUTE, OUTF ---------------------------------------------------------
def test_delinpx_moves_a_chain_whose_effort_and_element_outputs_are_the_closed_form(tmp_path):
    data, notes = import_spacar(write(tmp_path, CHAIN))
    assert data["inputs"] == {"u1": {"kind": "motion", "node": "3", "coordinate": "x",
                                     "value": 0.2 + DELTA}}
    assert data["outputs"]["y1"] == {"element": "2", "deformation": "e1",
                                     "quantity": "deformation"}
    assert data["outputs"]["y2"]["quantity"] == data["outputs"]["y3"]["quantity"] == "stress"
    assert "fixed" not in data["nodes"]["3"] or "x" not in data["nodes"]["3"]["fixed"]
    assert notes == ["INPUTX 3 1 -> the kinematic input u1: from 0.2 m by 0.001 m (DELINPX) "
                     "to 0.201 m, where a static solution holds it"]
    model = build_model(data)
    assert model.dof_count() == {"nx": 6, "nxo": 4, "neo": 0, "nki": 1, "ndof": 1}
    solution = static_equilibrium(model)
    # along a line every elongation is the difference of the x's: the chain is linear
    x2 = K2 / (K1 + K2) * DELTA
    assert solution.efforts()["u1"] == pytest.approx(SERIES * DELTA, rel=1e-12)
    assert solution.coordinates()["3.x"] == pytest.approx(0.2 + DELTA, rel=1e-15)
    outputs = solution.element_outputs()
    assert outputs["y1"] == pytest.approx(DELTA - x2, rel=1e-12)  # OUTE: truss 2's elongation
    assert outputs["y2"] == pytest.approx(K2 * (DELTA - x2), rel=1e-12)  # OUTF: its force
    assert outputs["y3"] == pytest.approx(K1 * x2, rel=1e-12)  # the same force through truss 1
    # the increment recorded: start (the X position) and value
    assert model.motion_starts[0] == 0.2
    assert model.motion_values[0] - model.motion_starts[0] == pytest.approx(DELTA, rel=1e-12)


def test_inx_gives_the_state_space_from_the_position_with_the_springs_stiffness(tmp_path):
    """INX: the state space's input is the prescribed position; at DC the effort per metre
    is the chain's series stiffness, OUTE / OUTF per metre the spring's share; one truss alone
    between the ground and the moved node has no state and D = EA / L exactly."""
    space = motion_state_space(load_scene(write(tmp_path, CHAIN)))
    assert space.inputs == ["u1"]
    assert space.outputs == ["y4", "y1", "y2", "y3", "u1.effort"]
    dc = space.frequency_response(0.0)[:, 0].real
    share = K1 / (K1 + K2)  # node 3's displacement taken by truss 2
    np.testing.assert_allclose(dc, [K2 / (K1 + K2), share, K2 * share, K2 * share, SERIES],
                               rtol=1e-12)
    truss = edit(edit(CHAIN, "PLTRUSS  2   2 3\n", ""), "DYNX     2   1\n", "")
    truss = edit(edit(truss, "FIX      3   2\nINPUTX   3   1", "INPUTX   2   1"),
                 "RLSE     2   1\n", "")
    truss = truss.replace("ESTIFF   2   189.0\n", "").replace("INX      1   3   1",
                                                               "INX      1   2   1")
    truss = truss[:truss.index("OUTE")] + "OUTF     1   1   1\nEND\nEND\n"
    truss = truss.replace("X        3   0.2  0.0\n", "").replace("DELINPX  3", "DELINPX  2")
    space = motion_state_space(load_scene(write(tmp_path, truss, "truss.dat")))
    assert space.A.shape == (0, 0)
    np.testing.assert_allclose(space.D[:, 0], [K1, K1], rtol=1e-15)  # OUTF and the effort


def test_the_chain_as_a_scene_gives_the_same_numbers(tmp_path):
    """The import against the chain written by hand: statics, efforts, element outputs and
    the state space from the position, to round-off."""
    dat, toml = load_scene(write(tmp_path, CHAIN)), build_model(CHAIN_SCENE)
    a, b = static_equilibrium(dat), static_equilibrium(toml)
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=1e-16)
    assert a.efforts()["u1"] == pytest.approx(b.efforts()["X"], rel=1e-14)
    assert list(a.element_outputs().values()) == pytest.approx(
        [b.element_outputs()[n] for n in ("e2", "s2", "s1")], rel=1e-14)
    sa, sb = motion_state_space(dat), motion_state_space(toml)
    for name in ("A", "B", "C", "D", "D1", "D2"):
        np.testing.assert_allclose(getattr(sa, name), getattr(sb, name), rtol=1e-14,
                                   atol=1e-14 * np.abs(getattr(sb, name)).max(initial=1.0))


def test_an_inputx_start_value_and_its_increment(tmp_path):
    """INPUTX n dir x after the kinematic block is the run's start (an absolute coordinate, as
    SPACAR Light writes the X position plus an initial displacement): statics hold
    start + DELINPX, and the scene records both."""
    text = edit(CHAIN, "DELINPX  3   1   0.001", "INPUTX   3   1   0.2005\nDELINPX  3   1   0.001")
    data, notes = import_spacar(write(tmp_path, text))
    assert data["inputs"]["u1"] == {"kind": "motion", "node": "3", "coordinate": "x",
                                    "start": 0.2005, "value": 0.2005 + DELTA}
    assert "from 0.2005 m by 0.001 m (DELINPX) to 0.2015 m" in notes[0]
    solution = static_equilibrium(build_model(data))
    assert solution.efforts()["u1"] == pytest.approx(SERIES * 1.5e-3, rel=1e-11)
    from flexure.core.cli.analyze import analyze  # --json: the value, its start and effort

    held_input = analyze(build_model(data), static=True)["static"]["kinematic_inputs"]["u1"]
    assert held_input["start"] == 0.2005 and held_input["value"] == 0.2005 + DELTA
    assert held_input["effort"] == pytest.approx(SERIES * 1.5e-3, rel=1e-11)
    # a start value alone holds the input there
    held = edit(CHAIN, "DELINPX  3   1   0.001", "INPUTX   3   1   0.2005")
    data, notes = import_spacar(write(tmp_path, held))
    assert data["inputs"]["u1"]["start"] == data["inputs"]["u1"]["value"] == 0.2005
    assert notes == ["INPUTX 3 1 -> the kinematic input u1: held at 0.2005 m (no DELINPX)"]


# -- a guided leaf, moved sideways -----------------------------------------------------------------
EI, LEAF = 0.5, 0.1  # N m^2, m

LEAF_DAT = f"""\
% a leaf spring along y, clamped at its foot, its tip guided (no rotation) and moved along x
PLBEAM   1   1 2 3 4
X        1   0.0  0.0
X        3   0.0  {LEAF}
FIX      1
FIX      2
FIX      4
INPUTX   3   1
RLSE     1   2 3
END
HALT
ESTIFF   1   2.0e6  {EI}
DELINPX  3   1   1e-7
END
END
"""


def test_delinpx_on_a_leaf_spring_gives_12_ei_over_l_cubed(tmp_path):
    """The guided leaf's lateral stiffness 12 EI / L^3, within its geometric nonlinearity
    ((delta / L)^2 = 1e-12) and the statics' tolerance."""
    model = load_scene(write(tmp_path, LEAF_DAT, "leaf.dat"))
    name = model.kinematic_inputs[0].name
    assert name == "inputx_3_x"
    effort = static_equilibrium(model).efforts()[name]
    assert effort == pytest.approx(12 * EI / LEAF**3 * 1e-7, rel=1e-9)


# -- INPUTE with DELINPE -------------------------------------------------------------------------
K_WALL = 2000.0  # N/m: the spring truss's EA / L
PUSH = f"""\
% an actuator truss 1, its length prescribed, pushes node 2 against the spring truss 2
PLTRUSS  1   1 2
PLTRUSS  2   2 3
X        1   0.0  0.0
X        2   0.1  0.0
X        3   0.2  0.0
FIX      1
FIX      2   2
FIX      3
INPUTE   1   1
RLSE     2   1
END
HALT
ESTIFF   2   {K_WALL * 0.1}
DELINPE  1   1   {DELTA}
END
HALT
OUTF     1   1   1
OUTE     2   2   1
END
END
"""


def test_inpute_pushes_a_truss_whose_effort_is_ea_over_l_times_delta(tmp_path):
    data, notes = import_spacar(write(tmp_path, PUSH))
    assert data["inputs"] == {"inpute_1_e1": {"kind": "motion", "element": "1",
                                              "deformation": "e1", "value": DELTA}}
    assert notes == ["INPUTE 1 1 -> the kinematic input inpute_1_e1: from 0.0 m by 0.001 m "
                     "(DELINPE) to 0.001 m, where a static solution holds it"]
    model = build_model(data)
    assert model.dof_count() == {"nx": 6, "nxo": 5, "neo": 0, "nki": 1, "ndof": 0}
    solution = static_equilibrium(model)
    assert solution.efforts()["inpute_1_e1"] == pytest.approx(K_WALL * DELTA, rel=1e-12)
    outputs = solution.element_outputs()
    assert outputs["y1"] == pytest.approx(-K_WALL * DELTA, rel=1e-12)  # it pushes: compressed
    assert outputs["y2"] == pytest.approx(-DELTA, rel=1e-12)  # the spring truss, shortened
    # an INPUTE start value: the run starts with the actuator 0.5 mm long
    text = edit(PUSH, f"DELINPE  1   1   {DELTA}",
                f"INPUTE   1   1   5e-4\nDELINPE  1   1   {DELTA}")
    data = read_spacar(write(tmp_path, text))
    assert data["inputs"]["inpute_1_e1"]["start"] == 5e-4
    assert static_equilibrium(build_model(data)).efforts()["inpute_1_e1"] == \
        pytest.approx(K_WALL * 1.5e-3, rel=1e-12)


# -- held inputs -----------------------------------------------------------------------------------
def test_an_input_the_file_only_holds_stays_fixed_and_the_file_simulates(tmp_path):
    """INPUTX without an INPUTX value, DELINPX or INX: SPACAR holds it at its X position,
    and so does a fixed coordinate; the model keeps no kinematic input (so it simulates) and
    the import says so. INPUTE alone: the deformation prescribed zero."""
    text = CHAIN.replace("DELINPX  3   1   0.001\n", "").replace("INX      1   3   1\n", "")
    data, notes = import_spacar(write(tmp_path, text))
    assert "inputs" not in data
    assert data["nodes"]["3"]["fixed"] == ["x", "y"]
    assert data["scene"]["description"].endswith("INPUTX held at the X position: 3.x")
    assert notes == ["INPUTX 3 1 -> the fixed coordinate 3.x: held at its X position (no "
                     "INPUTX value, DELINPX or INX moves it)"]
    model = build_model(data)
    assert not model.kinematic_inputs and model.dof_count()["ndof"] == 1
    data, notes = import_spacar(write(tmp_path, PUSH.replace(f"DELINPE  1   1   {DELTA}\n", "")))
    assert "inputs" not in data and "dof" not in data["elements"]["1"]
    assert "released" not in data["elements"]["1"]  # e1 prescribed zero: rigid
    assert data["scene"]["description"].endswith("INPUTE held at zero: 1.e1")
    assert notes == ["INPUTE 1 1 -> the deformation 1.e1 prescribed zero: held (no INPUTE "
                     "value or DELINPE moves it)"]
    assert not build_model(data).kinematic_inputs
    # INX alone makes it an input of the state space, held at its X position
    inx = CHAIN.replace("DELINPX  3   1   0.001\n", "")
    data = read_spacar(write(tmp_path, inx))
    assert data["inputs"]["u1"] == {"kind": "motion", "node": "3", "coordinate": "x"}


def test_force_and_kinematic_inputs_share_the_numbering_of_u(tmp_path):
    text = edit(CHAIN, "INX      1   3   1", "INPUTF   1   2   1\nINX      2   3   1")
    data = read_spacar(write(tmp_path, text))
    assert list(data["inputs"]) == ["u1", "u2"]
    assert data["inputs"]["u1"] == {"node": "2", "coordinate": "x"}
    assert data["inputs"]["u2"]["kind"] == "motion"


# -- flexure import ----------------------------------------------------------------------------
def test_import_says_what_each_input_became_and_warns_of_the_simulation(tmp_path, capsys):
    path, out = write(tmp_path, CHAIN), tmp_path / "chain.toml"
    assert main(["import", str(path), "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert "NDOF = NX - NXO - NEO - NKI = 6 - 4 - 0 - 1 = 1" in captured.out
    assert "INPUTX 3 1 -> the kinematic input u1: from 0.2 m by 0.001 m (DELINPX)" in \
        captured.out
    assert captured.err.startswith(f"flexure import: warning: {path}: 1 kinematic input(s)")
    assert "`flexure simulate` (its --motion-duration), `flexure loop`" in captured.err
    assert "`flexure loop` (its --motion-duration, on the in-process plant)" in captured.err
    assert tomllib.loads(out.read_text()) == read_spacar(path)
    solution = static_equilibrium(load_scene(out))
    assert solution.efforts()["u1"] == pytest.approx(SERIES * DELTA, rel=1e-12)


# -- mistakes --------------------------------------------------------------------------------------
MISTAKES = [
    ("DELINPX without its INPUTX", edit(CHAIN, "DELINPX  3   1", "DELINPX  2   2"), 19,
     "DELINPX: y of node 2 is not a kinematic input: it is fixed (FIX, line 8); declare it "
     "with INPUTX 2 2 before the first END"),
    ("DELINPX on a coordinate no line names",
     edit(edit(CHAIN, "FIX      3   2\n", ""), "DELINPX  3   1", "DELINPX  3   2"), 18,
     "DELINPX: y of node 3 is not a kinematic input: the kinematic block does not make it an "
     "input; declare it with INPUTX 3 2 before the first END"),
    ("DELINPX on a free coordinate", edit(CHAIN, "DELINPX  3   1", "DELINPX  2   1"), 19,
     "DELINPX: x of node 2 is not a kinematic input: it is a DOF (DYNX, line 11)"),
    ("DELINPX twice", edit(CHAIN, "DELINPX  3   1   0.001", "DELINPX  3   1   0.001\n"
                                                           "DELINPX  3   1   0.002"), 20,
     "DELINPX: the increment of x of node 3 is given twice (first on line 19)"),
    ("DELINPX in the kinematic block", edit(CHAIN, "DYNX     2   1", "DELINPX  3   1   0.001"),
     11, "DELINPX: belongs after the kinematic block's END"),
    ("DELINPX without its value", edit(CHAIN, "DELINPX  3   1   0.001", "DELINPX  3   1"), 19,
     "DELINPX: expected 3 values (node number, direction and value), got 2"),
    ("DELINPX not a number", edit(CHAIN, "DELINPX  3   1   0.001", "DELINPX  3   1   1mm"), 19,
     "DELINPX: increment: expected a number, got '1mm'"),
    ("DELINPX on an unknown node", edit(CHAIN, "DELINPX  3   1", "DELINPX  9   1"), 19,
     "DELINPX: unknown node 9"),
    ("an INPUTX value with its rates", edit(CHAIN, "DELINPX  3   1   0.001",
                                            "INPUTX   3   1   0.2 0.1 0.0"), 19,
     "INPUTX: expected 3 values (node number, direction and value), got 5"),
    ("DELINPE without its INPUTE", edit(CHAIN, "DELINPX  3   1   0.001", "DELINPE  1   1   0.1"),
     19, "DELINPE: deformation 1 of element 1 is not a kinematic input: it is released (RLSE, "
         "line 12); declare it with INPUTE 1 1 before the first END"),
    ("DELINPE on a deformation out of range",
     edit(CHAIN, "DELINPX  3   1   0.001", "DELINPE  1   2   0.1"), 19,
     "DELINPE: element 1 (PLTRUSS) has deformations 1 to 1; got 2"),
    ("INPUTE and RLSE", edit(CHAIN, "RLSE     2   1", "RLSE     2   1\nINPUTE   2   1"), 14,
     "INPUTE: deformation 1 of element 2 is already released (RLSE, line 13)"),
    ("INX on a DOF", edit(CHAIN, "INX      1   3   1", "INX      1   2   1"), 22,
     "INX: x of node 2 is not a kinematic input: it is a DOF (DYNX, line 11); declare it with "
     "INPUTX 2 1 before the first END"),
    ("INX twice on one input", edit(CHAIN, "INX      1   3   1", "INX      1   3   1\n"
                                                               "INX      5   3   1"), 23,
     "INX: x of node 3 is an input of the state space already (INX, line 22)"),
    ("INX and INPUTF with one number", edit(CHAIN, "INX      1   3   1", "INPUTF   1   2   1\n"
                                                                           "INX      1   3   1"),
     23, "INX: number 1 is given twice (first in INPUTF on line 22)"),
    ("OUTE on an unknown element", edit(CHAIN, "OUTE     1   2   1", "OUTE     1   7   1"), 23,
     "OUTE: unknown element 7: no element line defines it"),
    ("OUTF with a bad deformation number", edit(CHAIN, "OUTF     3   1   1",
                                                "OUTF     3   1   3"), 25,
     "OUTF: element 1 (PLTRUSS) has deformations 1 to 1; got 3"),
    ("OUTF with a deformation number of 0", edit(CHAIN, "OUTF     3   1   1",
                                                 "OUTF     3   1   0"), 25,
     "OUTF: expected a deformation number (a positive integer of at most 9 digits), got '0'"),
    ("OUTE without its deformation", edit(CHAIN, "OUTE     1   2   1", "OUTE     1   2"), 23,
     "OUTE: expected 3 values (number, element number and deformation number), got 2"),
    ("OUTE and OUTX with one number", edit(CHAIN, "OUTX     4   2   1", "OUTX     1   2   1"),
     26, "OUTX: number 1 is given twice (first in OUTE on line 23)"),
    ("a gap among the outputs", edit(CHAIN, "OUTX     4   2   1", "OUTX     6   2   1"), 26,
     "OUTX: number 6 without a number 4"),
]


@pytest.mark.parametrize("case, text, line, fragment", MISTAKES, ids=[m[0] for m in MISTAKES])
def test_a_mistake_is_refused_naming_the_file_line_and_keyword(case, text, line, fragment,
                                                               tmp_path):
    path = write(tmp_path, text)
    with pytest.raises(SceneError) as raised:
        read_spacar(path)
    message = str(raised.value)
    assert message.startswith(f"{path}: line {line}: "), message
    assert fragment in message, message


def test_an_input_on_an_euler_parameter_is_refused(tmp_path):
    text = ("BEAM 1 1 2 3 4 1 0 0\nX 1 0 0 0\nX 3 0 0.1 0\nFIX 1\nFIX 2\nINPUTX 3 1\nEND\n"
            "ESTIFF 1 1.89e6 0.0595 51.03 0.039375\nDELINPX 4 2 0.01\nEND\n")
    with pytest.raises(SceneError, match=r"line 9: DELINPX: node 4 is a spatial rotational "
                                         "node: its Euler parameters cannot be inputs"):
        read_spacar(write(tmp_path, text))


# -- the recorded move as a path in time -----------------------------------------------------------
def test_the_recorded_increment_as_a_path_drives_inverse_dynamics(tmp_path):
    """increment_path: the quintic from start to value, at rest at both ends, its rate and
    acceleration the derivatives of its value; a mass m on a truss k moved along it takes
    F = m u'' + k (u - X) from inverse dynamics (the truss massless: EM absent)."""
    from flexure.core.analysis.inverse_dynamics import inverse_dynamics
    from flexure.core.analysis.motion_paths import increment_path

    mass, duration, t0 = 0.206, 0.05, 0.01
    text = ("PLTRUSS 1 1 2\nX 1 0.0 0.0\nX 2 0.1 0.0\nFIX 1\nFIX 2 2\nINPUTX 2 1\nRLSE 1 1\n"
            f"END\nESTIFF 1 {EA1}\nXM 2 {mass}\nINPUTX 2 1 0.1002\nDELINPX 2 1 {DELTA}\nEND\n")
    model = load_scene(write(tmp_path, text))
    path = increment_path(model, duration, t0=t0)
    for t, value in ((0.0, 0.1002), (t0, 0.1002), (t0 + duration, 0.1012), (1.0, 0.1012)):
        u, rate, acceleration = path(t)
        assert u[0] == pytest.approx(value, rel=1e-15) and rate[0] == acceleration[0] == 0.0
    h = 1e-6  # s: central differences of the quintic, exact to O(h^2) of its derivatives
    peak_rate, peak_acceleration = 1.875 * DELTA / duration, 5.78 * DELTA / duration**2
    for t in np.linspace(t0 + 0.1 * duration, t0 + 0.9 * duration, 5):
        assert path(t)[1][0] == pytest.approx((path(t + h)[0][0] - path(t - h)[0][0]) / (2 * h),
                                              abs=1e-6 * peak_rate)
        assert path(t)[2][0] == pytest.approx((path(t + h)[1][0] - path(t - h)[1][0]) / (2 * h),
                                              abs=1e-6 * peak_acceleration)
    times = np.linspace(0.0, t0 + 1.2 * duration, 31)
    result = inverse_dynamics(model, times, path)
    u = np.array([path(t)[0][0] for t in times])
    a = np.array([path(t)[2][0] for t in times])
    expected = mass * a + K1 * (u - 0.1)
    effort = result.efforts[:, 0]
    assert np.max(np.abs(effort - expected)) < 1e-12 * np.max(np.abs(expected))
    with pytest.raises(SceneError, match="duration must be a finite number of seconds > 0"):
        increment_path(model, 0.0)


def test_a_scenes_start_key_is_checked_and_defaults_value(tmp_path):
    """[inputs.NAME] start: a number (m, rad), the default of value; --set reaches it."""
    data = read_spacar(write(tmp_path, CHAIN))
    data["inputs"]["u1"] = {"kind": "motion", "node": "3", "coordinate": "x", "start": 0.2004}
    model = build_model(data)
    assert model.motion_starts[0] == model.motion_values[0] == 0.2004
    data["inputs"]["u1"]["start"] = "far"
    with pytest.raises(SceneError, match=r"inputs\.u1\.start: expected a number"):
        build_model(data)
    moved = load_scene(write(tmp_path, CHAIN), overrides={"inputs.u1.start": 0.1999})
    assert moved.motion_starts[0] == 0.1999 and moved.motion_values[0] == 0.2 + DELTA


def test_delinpx_on_a_planar_angle_gives_4_ei_over_l(tmp_path):
    """A beam clamped at its foot, its tip held in place and turned by 1 urad: the moment
    4 EI / L theta (N m), within (theta)^2 of geometric nonlinearity."""
    text = (LEAF_DAT.replace("FIX      4\nINPUTX   3   1", "FIX      3\nINPUTX   4   1")
            .replace("DELINPX  3   1   1e-7", "DELINPX  4   1   1e-6")
            .replace("RLSE     1   2 3", "RLSE     1   1 2 3"))  # the tip held: e1 elastic
    data, notes = import_spacar(write(tmp_path, text))
    assert notes == ["INPUTX 4 1 -> the kinematic input inputx_4_phi: from 0.0 rad by 1e-06 rad "
                     "(DELINPX) to 1e-06 rad, where a static solution holds it"]
    model = build_model(data)
    assert model.kinematic_inputs[0].unit == "rad"
    effort = static_equilibrium(model).efforts()["inputx_4_phi"]
    assert effort == pytest.approx(4 * EI / LEAF * 1e-6, rel=1e-9)
