"""The stroke as a sweep axis (`flexure sweep --param stroke.NODE.AXIS=...`,
flexure.core.sweep.stroke): the force, stiffness, shortening and stress of the guided leaves
and the tripod's wires against their closed forms, and every refusal in one line."""

import csv
import math
import tomllib

import pytest
from cli_runs import run

from flexure.core import scene_path
from flexure.core.sweep.grid import evaluate_point

STAGE = tomllib.loads(scene_path("stage_planar_1dof").read_text())
E, H, W, L = 2.1e11, 0.0005, 0.018, 0.1
EI = E * W * H**3 / 12.0  # 0.039375 N m^2
STIFFNESS = 24.0 * EI / L**3  # two clamped-guided leaves: 945 N/m
MASSLESS = {"sections.leaf.rho": 0.0}


@pytest.mark.parametrize("stroke", [1e-5, 1e-4, 1e-3])
def test_the_guided_leaves_across_their_stroke(stroke):
    """At a stroke d of the bar: the force k d (k = 24 EI / L^3), the tangent stiffness k,
    the bar's drop 3 d^2 / (5 L) (the inextensible leaves' shortening, to (d/L)^2), and the
    largest stress, at the leaves' ends: M/W + N/A with M = 6 EI d / L^2, W = w h^2 / 6
    and the normal force N = 2 M / b = F / 2 of the couple that keeps the bar (b = L = 0.1 m)
    level, so sigma = 3 E h d / L^2 (1 + h / (3 L)) to first order in d."""
    row = evaluate_point(STAGE, {**MASSLESS, "stroke.3.x": stroke},
                         analyses=("static", "modes", "stress"), modes=1)
    assert row["status"] == "ok"
    assert row["static.x [m]"] == pytest.approx(stroke, abs=1e-10 * L)
    assert row["force.F [N]"] == pytest.approx(STIFFNESS * stroke, rel=1e-9)
    assert row["stiffness.3.x [N/m]"] == pytest.approx(STIFFNESS, rel=1e-9)
    drop = -0.6 * stroke**2 / L
    assert row["static.y [m]"] == pytest.approx(drop, rel=3 * (stroke / L) ** 2 + 1e-6)
    bending = 3.0 * E * H * stroke / L**2
    # measured 2e-5 relative beyond the first-order N/A share at d = 1e-5 m; the share of the
    # normal force in the end moment grows as d
    assert row["stress.max [Pa]"] == pytest.approx(bending * (1 + H / (3 * L)),
                                                   rel=1e-4 + 5 * stroke / L)
    # the suspension frequency falls with the stroke (the leaves' geometric stiffness)
    at_rest = math.sqrt(STIFFNESS / 0.206) / (2 * math.pi)
    assert row["mode.1 [Hz]"] < at_rest * (1 + 1e-12)


def test_the_tripods_stiffness_and_forces_over_its_workspace(capsys, tmp_path):
    """The platform on three wires, each clamped-guided, 12 EI / L^3 with EI = E pi d^4 / 64:
    3 x 12 EI / L^3 = 2968.8 N/m in x and in y at the centre; the forces of -d and +d are
    opposite (the tripod is symmetric under x -> -x), the other inputs' near zero."""
    out = tmp_path / "workspace.csv"
    code, _, err = run(capsys, "sweep", "wire_tripod", "--param", "stroke.P.x=-2e-3:2e-3:5",
                       "--param", "stroke.P.y=0", "--param", "stroke.Pr.rz=0",
                       "--analyses", "static,modes,stress", "--modes", "3", "--serial",
                       "--out", out, "--no-plot")
    assert code == 0, err
    rows = list(csv.DictReader(out.open()))
    assert list(rows[0])[:9] == [
        "stroke.P.x", "stroke.P.y", "stroke.Pr.rz", "force.F [N]", "force.Fy [N]",
        "force.M [N.m]", "stiffness.P.x [N/m]", "stiffness.P.y [N/m]",
        "stiffness.Pr.rz [N.m/rad]"]
    wire = 3 * 12.0 * 2.1e11 * math.pi * 0.001**4 / 64.0 / 0.05**3
    centre = rows[2]
    assert float(centre["stroke.P.x"]) == 0.0
    assert float(centre["stiffness.P.x [N/m]"]) == pytest.approx(wire, rel=1e-9)
    assert float(centre["stiffness.P.y [N/m]"]) == pytest.approx(wire, rel=1e-9)
    for low, high in ((rows[0], rows[4]), (rows[1], rows[3])):
        assert float(low["force.F [N]"]) == pytest.approx(-float(high["force.F [N]"]),
                                                          rel=1e-12)
        assert abs(float(high["force.Fy [N]"])) < 1e-12 * abs(float(high["force.F [N]"]))
        assert float(low["stress.max [Pa]"]) == pytest.approx(float(high["stress.max [Pa]"]),
                                                              rel=1e-9)
    # the stress grows with the stroke, the first mode softens
    assert float(rows[4]["stress.max [Pa]"]) > float(rows[3]["stress.max [Pa]"]) > 1e6
    assert float(rows[4]["mode.1 [Hz]"]) < float(rows[2]["mode.1 [Hz]"])


@pytest.mark.parametrize("argv, message", [
    (["--param", "stroke.3.x=0,1e-3", "--param", "stroke.3.y=0"],
     "2 stroke target(s) for 1 input(s) (F): inverse statics needs as many; sweep fewer"),
    (["--param", "stroke.9.x=0,1e-3"], "--param stroke.9.x: model 'stage_planar_1dof' has no "
                                       "coordinate '9.x'"),
    (["--param", "stroke.3.x=0,1e-3", "--analyses", "modes,buckling"],
     "the analyses at a stroke are static, modes, stress; not buckling"),
    (["--param", "stroke.3.x=0,1e-3", "--stroke-inputs", "G"],
     "--stroke-inputs: no input named G; the scene's inputs are F"),
    (["--param", "sections.leaf.height=1e-3,2e-3", "--stroke-inputs", "F"],
     "--stroke-inputs: no --param stroke.NODE.AXIS to drive"),
    (["--param", "stroke.3.x=0,1e-3", "--stroke-inputs", "F,F"], "each once"),
])
def test_a_stroke_that_cannot_be_run_is_refused_in_one_line(capsys, tmp_path, monkeypatch,
                                                            argv, message):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "sweep", "stage_planar_1dof", "--serial", *argv)
    assert code == 2 and message in err, err
    assert not list(tmp_path.iterdir())


def test_fewer_targets_than_inputs_says_to_hold_one(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "sweep", "wire_tripod", "--serial", "--param",
                       "stroke.P.x=0,1e-3")
    assert code == 2
    assert "hold another coordinate where it is (--param stroke.NODE.AXIS=0)" in err


def test_a_stroke_the_inputs_cannot_reach_fails_its_point_only():
    """A point whose inverse statics fails (the leaves cannot be pulled past their length)
    gives the reason in its status; the sweep goes on."""
    row = evaluate_point(STAGE, {"stroke.3.x": 0.5}, analyses=("static",))
    assert row["status"].startswith("static equilibrium of 'stage_planar_1dof' did not "
                                    "converge"), row["status"]
    assert "beyond the reach of the mechanism" in row["status"]
    assert "static.x [m]" not in row
