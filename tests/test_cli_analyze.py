"""`flexure analyze` end to end: the installed console script, its JSON keys and tables."""

import json
import sys
from pathlib import Path

import children
import numpy as np
import pytest

from flexure.core.cli import main

FLEXURE = str(Path(sys.executable).with_name("flexure"))  # the installed console script
SCENES = Path(__file__).resolve().parents[1] / "examples" / "scenes"


def run_json(*args):
    completed = children.run([FLEXURE, "analyze", *args, "--json"], capture_output=True,
                             text=True, check=True)
    return json.loads(completed.stdout)


def test_modes_json_of_the_3dof_stage_file():
    result = run_json(str(SCENES / "stage_planar_3dof.toml"), "--modes")
    assert result["dof_count"] == {"nx": 12, "nxo": 6, "neo": 3, "ndof": 3}
    assert result["modes"]["frequencies_hz"] == pytest.approx([10.645, 2129.0, 3586.4],
                                                              rel=1e-4)
    assert len(result["modes"]["mass_matrix"]) == 3
    assert len(result["modes"]["stiffness_matrix"]) == 3
    assert "static" not in result and "buckling" not in result and "state_space" not in result


def test_every_analysis_by_builtin_name():
    result = run_json("truss_1dof_x", "--static", "--modes", "1", "--buckling",
                      "--state-space")
    assert result["static"]["coordinates"]["2.x"] == pytest.approx(0.1 + 1 / 945, rel=1e-9)
    assert result["static"]["stress_resultants"]["spring.e1"] == pytest.approx(1.0, abs=1e-9)
    assert result["modes"]["frequencies_hz"] == pytest.approx([10.6584], rel=1e-4)
    assert result["state_space"]["inputs"] == ["F"]
    assert result["state_space"]["outputs"] == ["x"]
    assert result["state_space"]["B"][1][0] == pytest.approx(4.746, rel=5e-4)
    assert result["buckling"]["load_factors"] == []  # a tensile load never buckles the truss


def test_buckling_table_reports_78_75(capsys):
    assert main(["analyze", "stage_planar_1dof", "--buckling"]) == 0
    out = capsys.readouterr().out
    assert "NDOF = NX - NXO - NEO = 12 - 6 - 5 = 1" in out
    assert "78.75" in out


def test_default_analyses_are_static_and_modes(capsys):
    assert main(["analyze", "stage_planar_3dof"]) == 0
    out = capsys.readouterr().out
    assert "static equilibrium: coordinates" in out and "natural frequencies" in out
    assert "2128.97" in out


def test_a_kinematic_scene_is_checked_and_nothing_more(capsys):
    """Without mass or load there is no equilibrium or mode: the default analyses are the
    exact-constraint check alone (the manipulator's end-effector stage, 6 DOFs)."""
    assert main(["analyze", "manipulator_stage"]) == 0
    out = capsys.readouterr().out
    assert "NDOF = NX - NXO - NEO = 42 - 12 - 24 = 6" in out
    assert "exactly constrained; a kinematic model (no mass, no load)" in out
    assert main(["analyze", "manipulator_stage", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert set(result) == {"scene", "dof_count", "dofs", "dofs_chosen"}
    assert result["dof_count"]["ndof"] == 6


# -- an equilibrium Newton finds but the mechanism cannot rest in -----------------------------

def test_past_the_buckling_load_the_equilibrium_is_named_unstable(capsys):
    """stage_planar_1dof buckles at 78.75 N down on the bar; at 100 N Newton still finds the
    straight equilibrium, whose frequency is imaginary (-5.53 Hz): named, in the JSON too."""
    assert main(["analyze", "stage_planar_1dof", "--static", "--modes", "--json", "--set",
                 "nodes.3.force=[0.0,-100.0]"]) == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    assert result["modes"]["frequencies_hz"][0] == pytest.approx(-5.53, abs=0.01)
    (warning,) = result["warnings"]
    assert warning.startswith("unstable equilibrium: the tangent stiffness K0 + G0 has 1 "
                              "negative eigenvalue")
    assert "mode 1 (-5.53 Hz: 3 and 5 along x)" in warning
    assert f"flexure analyze: warning: {warning}" in captured.err


def test_below_the_buckling_load_there_is_no_warning(capsys):
    # 50 N: K = K0 + G0 = 945 - 600 = 345 N/m > 0, a softened but stable stage
    assert main(["analyze", "stage_planar_1dof", "--static", "--modes", "--json", "--set",
                 "nodes.3.force=[0.0,-50.0]"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["warnings"] == [] and "warning" not in captured.err


def test_a_stage_pushed_flat_is_unstable_and_out_of_its_range(capsys):
    """stage_planar_3dof at 100 N sideways: the leaves lie flat (the bar 0.1 m down), an
    unstable state far beyond the range of validity; a static analysis alone names both."""
    assert main(["analyze", "stage_planar_3dof", "--static", "--json", "--set",
                 "nodes.3.force=[100.0,0.0]"]) == 0
    warnings = json.loads(capsys.readouterr().out)["warnings"]
    assert len(warnings) == 2
    assert warnings[0].startswith("unstable equilibrium") and "mode" not in warnings[0]
    assert "beyond the model's range of validity (0.25 x its size 0.141 m)" in warnings[1]


def test_a_singular_stiffness_is_not_mistaken_for_an_unstable_one():
    from flexure.core.analysis.stability import NEGATIVE_RTOL, negative_stiffness

    # a kinematic DOF: eigenvalues 1e3 and a round-off -1e-13
    rotation = np.array([[0.6, -0.8], [0.8, 0.6]])
    K = rotation @ np.diag([1e3, -1e-13]) @ rotation.T
    assert negative_stiffness(K)[0] == 0
    K = rotation @ np.diag([1e3, -10 * NEGATIVE_RTOL * 1e3]) @ rotation.T
    count, lowest, largest = negative_stiffness(K)
    assert count == 1 and lowest == pytest.approx(-1e-5) and largest == pytest.approx(1e3)
    assert negative_stiffness(np.zeros((0, 0))) == (0, 0.0, 0.0)


def test_the_cholesky_shortcut_never_clears_an_unstable_stiffness():
    """`clearly_stable` (one Cholesky of K + tau I) says stable only where the eigenvalues
    say no negative one: random symmetric matrices with a lowest eigenvalue from clearly
    positive to clearly negative, across NEGATIVE_RTOL."""
    from flexure.core.analysis.stability import (
        NEGATIVE_RTOL,
        clearly_stable,
        negative_stiffness,
    )

    rng = np.random.default_rng(3)
    basis, _ = np.linalg.qr(rng.normal(size=(40, 40)))
    for lowest in (1.0, 1e-6, 0.0, -1e-13, -0.1 * NEGATIVE_RTOL * 1e3,
                   -10 * NEGATIVE_RTOL * 1e3, -1.0):
        values = np.concatenate([[lowest], rng.uniform(1.0, 1e3, 38), [1e3]])
        K = basis @ np.diag(values) @ basis.T
        if clearly_stable(K):
            assert negative_stiffness(K)[0] == 0
    assert clearly_stable(np.diag([1.0, 2.0])) and not clearly_stable(np.diag([1.0, -2.0]))
    assert clearly_stable(np.zeros((0, 0)))


def test_the_text_shows_the_free_coordinates_and_the_outputs_the_json_every_one(capsys):
    """The tripod has 49 coordinates, 12 of them free translations; its rotation reads as
    the output about z, not as four Euler parameters."""
    assert main(["analyze", "wire_tripod", "--static"]) == 0
    text = capsys.readouterr().out
    table = text.split("static equilibrium: coordinates")[1].split("\n\n")[0]
    rows = [line.split()[0] for line in table.splitlines()[3:]]
    assert rows == ["P.x", "P.y", "P.z"] + [f"T{k}.{a}" for k in (1, 2, 3) for a in "xyz"]
    assert "(the free ones; 9 fixed and 28 Euler parameters left out" in table
    outputs = text.split("static equilibrium: outputs")[1].split("\n\n")[0]
    assert [line.split()[0] for line in outputs.splitlines()[3:]] == ["x", "y", "z", "rz"]
    assert main(["analyze", "wire_tripod", "--static", "--json"]) == 0
    static = json.loads(capsys.readouterr().out)["static"]
    assert len(static["coordinates"]) == 49 and static["outputs"]["z"] == pytest.approx(0.05)


@pytest.mark.parametrize(("yield_mpa", "named"), [(150.0, ["leaf_left", "leaf_right"]),
                                                  (167.0, ["leaf_left"]), (1000.0, [])])
def test_a_stress_above_the_sections_yield_stress_is_named(capsys, yield_mpa, named):
    """5 N sideways on the stage: 168.7 MPa in the left leaf, 165.2 MPa in the right one
    (the static table's von Mises stresses); each above the yield stress given is named."""
    assert main(["analyze", "stage_planar_1dof", "--static", "--json",
                 "--set", f"sections.leaf.yield_stress={yield_mpa * 1e6}",
                 "--set", "nodes.3.force=[5.0, 0.0]"]) == 0
    result = json.loads(capsys.readouterr().out)
    stresses = {name: max(ends) for name, ends in
                result["static"]["von_mises_pa"].items() if name.startswith("leaf")}
    assert stresses["leaf_left"] == pytest.approx(168.7e6, rel=1e-3)
    yielded = [w.split(":")[0] for w in result["warnings"] if "yield stress" in w]
    assert yielded == named
    assert sorted(yielded) == sorted(n for n, s in stresses.items() if s > yield_mpa * 1e6)


def test_a_yield_stress_must_be_positive(capsys):
    assert main(["analyze", "stage_planar_1dof", "--set", "sections.leaf.yield_stress=0"]) == 2
    assert capsys.readouterr().err.endswith(
        "--set sections.leaf.yield_stress: expected a value > 0, got 0\n")
