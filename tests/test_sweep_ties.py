"""Tied sweep parameters (`flexure sweep --tie KEY=EXPRESSION`, flexure.core.sweep.ties): the
grammar evaluated by hand, never executed, its mistakes in one line, and sweeps whose tied
values are checked against the analytic stage and the tripod's symmetry."""

import csv
import math

import pytest
from cli_runs import run

from flexure.core.errors import UsageError
from flexure.core.sweep.ties import parse_tie, tie_points

H = "sections.leaf.height"
N = "elements.bar.segments"


@pytest.mark.parametrize("expression, point, expected", [
    (H, {H: 0.0004}, 0.0004),                         # a bare key: the value itself
    (N, {N: 3}, 3),
    (f"2*{N}", {N: 3}, 6),                            # a count stays an integer
    (f"1+2*{H}", {H: 0.5}, 2.0),                      # * before +
    (f"(1+2)*{H}", {H: 0.5}, 1.5),                    # brackets first
    (f"-{H}+1", {H: 0.25}, 0.75),                     # unary minus
    (f"{H}/4-1e-3", {H: 0.004}, 0.0),
    (f"2*-{H}", {H: 0.5}, -1.0),
    ("1-2-3", {H: 0.0}, -4),                         # left to right
    ("8/4/2", {H: 0.0}, 1.0),
])
def test_an_expression_is_evaluated_as_arithmetic_reads(expression, point, expected):
    tie = parse_tie(f"sections.leaf.width={expression}", [H, N])
    value = tie.value(point)
    assert value == expected and type(value) is type(expected)


def test_a_computed_value_reads_plainly_as_a_swept_one_does():
    tie = parse_tie(f"sections.leaf.width=36*{H}", [H])
    [point] = tie_points([{H: 0.0004}], [tie])
    assert point == {H: 0.0004, "sections.leaf.width": 0.0144}  # not 0.014400000000000001


@pytest.mark.parametrize("text, message", [
    ("sections.leaf.width", "expected KEY=EXPRESSION"),
    ("=2", "expected KEY=EXPRESSION"),
    (f"{H}=2", "also a --param"),
    ("sections.leaf.width=2*sections.leaf.heigth", "sections.leaf.heigth is not a --param"),
    ("sections.leaf.width=__import__('os').system('true')", "unexpected \"'\""),
    (f"sections.leaf.width={H}**2", "unexpected '\\*'"),
    (f"sections.leaf.width=2*({H}+1", "a '\\(' is not closed"),
    ("sections.leaf.width=2*", "the expression ends"),
    (f"sections.leaf.width=2 {H}", "unexpected 'sections.leaf.height' after a complete"),
    (f"sections.leaf.width={H};1", "unexpected ';'"),
])
def test_a_bad_tie_names_the_option_and_what_is_wrong(text, message):
    with pytest.raises(UsageError, match=f"--tie.*{message}"):
        parse_tie(text, [H])


def test_a_division_by_zero_names_the_point():
    tie = parse_tie(f"sections.leaf.width=1/{H}", [H])
    with pytest.raises(UsageError, match="division by zero at sections.leaf.height=0.0"):
        tie.value({H: 0.0})


def test_a_width_tied_to_the_height_follows_the_analytic_stage(capsys, tmp_path):
    """stage_planar_1dof with massless leaves: f = sqrt(24 E I / L^3 / m) / 2 pi with
    I = w h^3 / 12 and here w = 36 h, so f grows as h^2 (as h^(3/2) with w fixed)."""
    out = tmp_path / "tied.csv"
    code, _, err = run(capsys, "sweep", "stage_planar_1dof", "--set", "sections.leaf.rho=0",
                       "--param", f"{H}=0.3e-3:0.8e-3:3", "--tie",
                       f"sections.leaf.width=36*{H}", "--analyses", "modes", "--modes", "1",
                       "--serial", "--out", out, "--no-plot")
    assert code == 0, err
    rows = list(csv.DictReader(out.open()))
    assert [row[H] for row in rows] == ["0.0003", "0.00055", "0.0008"]
    for row in rows:
        height, width = float(row[H]), float(row["sections.leaf.width"])
        assert width == float(f"{36 * height:.15g}")
        inertia = width * height**3 / 12.0
        f = math.sqrt(24.0 * 2.1e11 * inertia / 0.1**3 / 0.206) / (2.0 * math.pi)
        assert float(row["mode.1 [Hz]"]) == pytest.approx(f, rel=1e-9)


def test_the_tripods_three_wires_are_refined_together(capsys, tmp_path):
    """Each row holds the three wires' segments alike, and its frequencies are those of the
    tripod with the three set by --set, bit for bit; the tripod's two translation modes stay
    equal (its 120-degree symmetry) to 1e-8."""
    out = tmp_path / "tripod.csv"
    wires = [f"elements.wire{k}.segments" for k in (1, 2, 3)]
    code, _, err = run(capsys, "sweep", "wire_tripod", "--param", f"{wires[0]}=1,4",
                       "--tie", f"{wires[1]}={wires[0]}", "--tie", f"{wires[2]}={wires[0]}",
                       "--analyses", "modes", "--modes", "3", "--serial", "--out", out,
                       "--no-plot")
    assert code == 0, err
    rows = list(csv.DictReader(out.open()))
    assert [[row[w] for w in wires] for row in rows] == [["1", "1", "1"], ["4", "4", "4"]]
    for row in rows:
        assert float(row["mode.1 [Hz]"]) == pytest.approx(float(row["mode.2 [Hz]"]), rel=1e-8)
    fixed = tmp_path / "fixed.csv"
    code, _, err = run(capsys, "sweep", "wire_tripod", "--param", f"{wires[0]}=4,8",
                       "--set", f"{wires[1]}=4", "--set", f"{wires[2]}=4", "--analyses",
                       "modes", "--modes", "3", "--serial", "--out", fixed, "--no-plot")
    assert code == 0, err
    same = list(csv.DictReader(fixed.open()))[0]
    assert [same[f"mode.{k} [Hz]"] for k in (1, 2, 3)] == [
        rows[1][f"mode.{k} [Hz]"] for k in (1, 2, 3)]
    assert rows[0]["mode.3 [Hz]"] != rows[1]["mode.3 [Hz]"]  # the refinement did something


@pytest.mark.parametrize("argv, message", [
    (["--tie", "sections.leaf.width=2*sections.leaf.E"], "sections.leaf.E is not a --param"),
    (["--tie", "sections.leaf.width=2", "--tie", "sections.leaf.width=3"], "given 2 times"),
    (["--tie", "sections.leaf.width=2", "--set", "sections.leaf.width=0.01"],
     "also given to --set"),
    (["--tie", "sections.leaf.width=1/(sections.leaf.height-3e-4)"], "division by zero"),
])
def test_the_command_refuses_a_bad_tie_in_one_line(capsys, tmp_path, monkeypatch, argv,
                                                   message):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "sweep", "stage_planar_1dof", "--param", f"{H}=0.3e-3:0.8e-3:3",
                       "--serial", *argv)
    assert code == 2 and message in err, err
    assert not list(tmp_path.iterdir())


def test_the_plot_names_each_parameter_with_its_unit():
    from flexure.core import load_scene
    from flexure.core.cli.sweep import parameter_unit
    from flexure.core.sweep.table import SweepTable

    model = load_scene("wire_tripod")
    units = {key: parameter_unit(key, model) for key in
             ("sections.wire.diameter", "nodes.P.mass", "elements.wire1.segments",
              "elements.wire1.type")}
    assert units == {"sections.wire.diameter": "m", "nodes.P.mass": "kg",
                     "elements.wire1.segments": "1", "elements.wire1.type": ""}
    table = SweepTable(list(units), ["mode.1 [Hz]"], units=units)
    assert table.label("sections.wire.diameter") == "sections.wire.diameter [m]"
    assert table.label("elements.wire1.type") == "elements.wire1.type"
