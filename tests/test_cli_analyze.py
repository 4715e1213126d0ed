"""`flexure analyze` end to end: the installed console script, its JSON keys and tables."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from flexure.core.cli import main

FLEXURE = str(Path(sys.executable).with_name("flexure"))  # the installed console script
SCENES = Path(__file__).resolve().parents[1] / "examples" / "scenes"


def run_json(*args):
    completed = subprocess.run([FLEXURE, "analyze", *args, "--json"], capture_output=True,
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
