"""Design optimisation (`flexure optimize`, flexure.core.analysis.optimize): two problems
whose optimum is known in closed form, the grammar of objectives and constraints, and every
way the command refuses bad input (one line, exit code 2, no traceback)."""

import csv
import math
import re
import tomllib

import pytest
import scipy.optimize
from cli_runs import run

from flexure.core import load_scene, natural_frequencies, optimize
from flexure.core.analysis.optimize import parse_variable
from flexure.core.analysis.optimize_goals import parse_constraint, parse_objective
from flexure.core.errors import SceneError, UsageError

# both stages: steel leaves of L = 0.1 m carrying the 0.206 kg bar (rho_A 2.06 kg/m over
# 0.1 m); massless leaves (rho = 0) so that the bar is the only mass
E, L, BAR = 2.1e11, 0.1, 0.206
MASSLESS = {"sections.leaf.rho": 0.0}


def three_dof_height(width, frequency_hz):
    """The leaf height at which stage_planar_3dof's lowest frequency is `frequency_hz`.

    Linear theory of the bar (mass m, J = m b^2 / 12 about its centre, b = 0.1 m) on two
    clamped leaves whose tops follow it: the bar's x and rotation phi; each leaf's top moves
    x sideways, turns phi and moves +-a phi along the leaf (a = b / 2), so with
    EI = E w h^3 / 12 and EA = E w h

        K = 2 [[12 EI / L^3, 6 EI / L^2], [6 EI / L^2, 4 EI / L + EA a^2 / L]],
        M = diag(m, J)

    (the vertical mode decouples by symmetry). The height solves det(K - w^2 M) = 0 with
    w = 2 pi f, a scalar equation in h, solved by bracketing.
    """
    a, J, lam = 0.05, BAR * 0.1**2 / 12.0, (2.0 * math.pi * frequency_hz) ** 2

    def det(h):
        ei, ea = E * width * h**3 / 12.0, E * width * h
        k11, k12 = 24.0 * ei / L**3, 12.0 * ei / L**2
        k22 = 8.0 * ei / L + 2.0 * ea * a**2 / L
        return (k11 - lam * BAR) * (k22 - lam * J) - k12**2

    return scipy.optimize.brentq(det, 3e-4, 2e-3, xtol=1e-18, rtol=1e-15)


def test_the_parasitic_frequency_is_maximised_at_the_known_optimum():
    """max f2 (the vertical mode, f2 = sqrt(2 E w h / (L m)) / 2 pi) with f1 = 30 +- 1 over
    h and w: f1 ~ sqrt(w h^3) and f2 ~ sqrt(w h), so along f1 = const w h ~ w^(2/3) grows
    with w: the optimum is w at its upper bound and f1 at 31 Hz, h from the 2 x 2 model."""
    model = load_scene("stage_planar_3dof", overrides=MASSLESS)
    seen = []
    found = optimize(model, {"sections.leaf.height": (0.3e-3, 2e-3),
                             "sections.leaf.width": (0.01, 0.03)},
                     "max:frequency[2]", ["frequency[1]=30+-1"], on_iteration=seen.append)
    assert found.success, found.message
    height, width = found.x
    assert width == pytest.approx(0.03, rel=1e-12)
    # the optimiser holds f1 = 31 to its tolerance (1e-9 relative here, measured 5e-11), the
    # 2 x 2 model is exact linear theory: h to the same order
    assert height == pytest.approx(three_dof_height(0.03, 31.0), rel=1e-8)
    assert found.constraint_values[0] == pytest.approx(31.0, rel=1e-8)
    vertical = math.sqrt(2.0 * E * width * height / (L * BAR)) / (2.0 * math.pi)
    assert found.objective_value == pytest.approx(vertical, rel=1e-9)
    assert found.violation < 1e-8
    # the progress callback saw every iteration, the start first, and the history is theirs
    assert seen == found.history and seen[0].number == 0 and len(seen) >= 3
    assert list(seen[0].x) == [0.0005, 0.018]
    # the optimum scene holds the optimum: rebuilt, its f1 is the constrained 31 Hz
    again = load_scene("stage_planar_1dof")  # any model: replaced below
    from flexure.core import build_model

    again = build_model(found.scene)
    assert again.scene["sections"]["leaf"]["height"] == height
    f1 = natural_frequencies(again, 1).frequencies_hz[0]
    assert f1 == pytest.approx(31.0, rel=1e-8)


def test_the_suspension_frequency_is_minimised_under_a_buckling_bound():
    """min f1 of stage_planar_1dof over h with buckling[1] >= 100: both grow with h, f1 ~
    h^(3/2) and the load factor ~ EI ~ h^3 exactly (the reference load's normal forces do not
    depend on h), 78.75 at h = 0.5 mm, so h* = 0.5 mm (100 / 78.75)^(1/3) and f1 there is
    the guided leaves' sqrt(24 E I / L^3 / m) / 2 pi. SLSQP meets the active bound to its
    tolerance; trust-constr's interior point stops inside it, by its barrier (measured 3.6e-6
    relative in the load factor, so 1.2e-6 in h, asserted to 1e-5)."""
    model = load_scene("stage_planar_1dof", overrides=MASSLESS)
    expected = 0.0005 * (100.0 / scipy_factor(model)) ** (1.0 / 3.0)
    for method, rel in (("SLSQP", 1e-8), ("trust-constr", 1e-5)):
        found = optimize(model, {"sections.leaf.height": (0.2e-3, 1e-3)}, "min:frequency[1]",
                         ["buckling[1]>=100"], method=method)
        assert found.success, found.message
        assert found.x[0] == pytest.approx(expected, rel=rel)
        assert found.constraint_values[0] >= 100.0 * (1.0 - 1e-9)  # feasible, to round-off
        inertia = 0.018 * found.x[0] ** 3 / 12.0
        guided = math.sqrt(24.0 * E * inertia / L**3 / BAR) / (2.0 * math.pi)
        assert found.objective_value == pytest.approx(guided, rel=1e-9)


def scipy_factor(model):
    """The stage's first buckling factor at its scene's height (78.75 for the course's
    stage, checked in tests/test_modal.py)."""
    from flexure.core import buckling_load_factors

    factor = float(buckling_load_factors(model, 1)[0])
    assert factor == pytest.approx(78.75, rel=1e-6)
    return factor


def test_an_unconstrained_objective_goes_to_its_bound():
    found = optimize(load_scene("stage_planar_1dof", overrides=MASSLESS),
                     {"sections.leaf.width": (0.01, 0.02)}, "max:frequency[1]")
    assert found.success and found.x[0] == pytest.approx(0.02, rel=1e-12)


# -- the grammar ----------------------------------------------------------------------------

def test_the_grammar_reads_what_the_docs_show():
    goal = parse_objective("max:frequency[2]")
    assert (goal.sense, goal.quantity.kind, goal.quantity.index) == ("max", "frequency", 2)
    band = parse_constraint("frequency[1] = 30 +- 1")
    assert (band.lower, band.upper) == (29.0, 31.0)
    assert (parse_constraint("buckling[1]>=3").lower, parse_constraint("buckling[1]>=3").upper
            ) == (3.0, None)
    stress = parse_constraint("von_mises<=0.5*yield", yield_stress=1.1e9)
    assert (stress.lower, stress.upper, stress.uses_yield) == (None, 0.55e9, True)
    assert parse_constraint("von_mises<=yield", yield_stress=2e8).upper == 2e8
    assert parse_constraint("output[x]<=-1e-3").upper == -1e-3
    assert parse_constraint("dc_gain[F->x]>=1e-4").quantity.name == "F->x"
    assert parse_variable("sections.leaf.height=0.3e-3:2e-3") == (
        "sections.leaf.height", 0.0003, 0.002)


@pytest.mark.parametrize("parse, text, message", [
    (parse_objective, "frequency[2]", "expected max:QUANTITY or min:QUANTITY"),
    (parse_objective, "maximise:frequency[2]", "expected max:QUANTITY"),
    (parse_objective, "max:", "expected max:QUANTITY"),
    (parse_objective, "max:frequency", "unknown quantity 'frequency'"),
    (parse_objective, "max:frequency[0]", "K counts from 1"),
    (parse_objective, "max:__import__('os')", "unknown quantity"),
    (parse_constraint, "buckling[1]", "expected QUANTITY<=BOUND"),
    (parse_constraint, "mass<=3", "unknown quantity 'mass'"),
    (parse_constraint, "buckling[1]>=three", "the bound must be a finite number"),
    (parse_constraint, "buckling[1]>=inf", "the bound must be a finite number"),
    (parse_constraint, "buckling[1]>=2**10", "the bound must be a finite number"),
    (parse_constraint, "frequency[1]=30", "an equality needs its tolerance"),
    (parse_constraint, "frequency[1]==30+-1", "the operators are <=, >="),
    (parse_constraint, "frequency[1]<3", "expected QUANTITY<=BOUND"),
    (parse_constraint, "frequency[1]=30+-0", "the tolerance must be > 0"),
    (parse_constraint, "frequency[1]=30+-x", "the tolerance must be a finite number"),
    (parse_constraint, "von_mises<=0.5*yield", "add --yield PA (e.g. --yield 1.1e9), or give "
                                               "the scene's sections yield_stress"),
    (parse_constraint, "frequency[1]<=0.5*yield", "bounds von_mises, not frequency"),
    (parse_variable, "sections.leaf.height", "expected KEY=LO:HI"),
    (parse_variable, "sections.leaf.height=1e-3", "expected KEY=LO:HI"),
    (parse_variable, "sections.leaf.height=2e-3:1e-3", "LO < HI"),
    (parse_variable, "sections.leaf.height=a:1", "LO < HI"),
])
def test_a_bad_goal_names_its_option_and_what_is_wrong(parse, text, message):
    with pytest.raises(UsageError, match=re.escape(message)):
        parse(text)


def test_yield_defaults_to_the_sections_yield_stress():
    """The stage under 1 N sideways, its leaves given a yield stress: "von_mises<=0.5*yield"
    bounds the stress at half of it; two sections with different ones are refused."""
    from flexure.core.analysis.optimize_goals import scene_yield_stress

    model = load_scene("stage_planar_1dof", overrides={
        "nodes.3.force": [1.0, 0.0], "sections.leaf.yield_stress": 4e8})
    found = optimize(model, {"sections.leaf.width": (0.01, 0.02)}, "max:frequency[1]",
                     ["von_mises<=0.5*yield"])
    assert found.constraints[0].upper == 2e8 and found.constraints[0].uses_yield
    two = {"sections": {"a": {"yield_stress": 1e8}, "b": {"yield_stress": 2e8}}}
    with pytest.raises(UsageError, match=r"different yield stresses \(a: 1e\+08 Pa, b: "
                                         r"2e\+08 Pa\): say which with --yield PA"):
        scene_yield_stress(two)
    assert scene_yield_stress({"sections": {"a": {"E": 1.0}}}) is None


def test_the_api_refuses_what_the_model_cannot_give():
    model = load_scene("stage_planar_1dof")
    with pytest.raises(UsageError, match=r"--objective 'max:frequency\[3\]': the model has no "
                                         r"frequency\[3\]"):
        optimize(model, {"sections.leaf.width": (0.01, 0.02)}, "max:frequency[3]")
    with pytest.raises(SceneError, match="--vary sections.leaf.thickness"):
        optimize(model, {"sections.leaf.thickness": (0.01, 0.02)}, "max:frequency[1]")
    with pytest.raises(UsageError, match="--method 'Nelder-Mead'"):
        optimize(model, {"sections.leaf.width": (0.01, 0.02)}, "max:frequency[1]",
                 method="Nelder-Mead")


# -- the command ----------------------------------------------------------------------------

def test_the_command_writes_the_optimum_scene_the_history_and_its_plot(capsys, tmp_path):
    out, history = tmp_path / "best.toml", tmp_path / "history.csv"
    code, printed, err = run(
        capsys, "optimize", "stage_planar_1dof", "--set", "sections.leaf.rho=0",
        "--vary", "sections.leaf.height=0.2e-3:1e-3", "--objective", "min:frequency[1]",
        "--constraint", "buckling[1] >= 100", "--out", out, "--history", history)
    assert code == 0, err
    assert "iteration   0  frequency[1] = " in err  # a progress line per iteration
    assert "converged" in printed and "history" in printed
    scene = tomllib.loads(out.read_text())
    rows = list(csv.reader(history.open()))
    assert rows[0] == ["iteration", "evaluations", "sections.leaf.height [m]",
                       "frequency[1] [Hz]", "buckling[1] [1]", "violation [-]"]
    # the scene holds the history's last height, bit for bit (both written as repr)
    assert scene["sections"]["leaf"]["height"] == float(rows[-1][2])
    assert scene["sections"]["leaf"]["rho"] == 0  # the --set values stay in the scene
    assert float(rows[-1][4]) == pytest.approx(100.0, rel=1e-6)
    assert history.with_suffix(".png").stat().st_size > 10_000


@pytest.mark.parametrize("argv, message", [
    (["--vary", "sections.leaf.height", "--objective", "max:frequency[1]"],
     "--vary 'sections.leaf.height': expected KEY=LO:HI"),
    (["--vary", "sections.leaf.width=0.01:0.02", "--vary", "sections.leaf.width=0.01:0.03",
      "--objective", "max:frequency[1]"], "--vary sections.leaf.width: given twice"),
    (["--vary", "sections.leaf.width=0.01:0.02", "--set", "sections.leaf.width=0.01",
      "--objective", "max:frequency[1]"], "also given to --set"),
    (["--vary", "sections.leaf.widht=0.01:0.02", "--objective", "max:frequency[1]"],
     "--vary sections.leaf.widht"),
    (["--vary", "elements.bar.type=1:2", "--objective", "max:frequency[1]"],
     "--vary elements.bar.type"),
    (["--vary", "sections.leaf.width=0.01:0.02", "--objective", "frequency[1]"],
     "--objective 'frequency[1]': expected max:QUANTITY"),
    (["--vary", "sections.leaf.width=0.01:0.02", "--objective", "max:frequency[2]"],
     "the model has no frequency[2]"),
    (["--vary", "sections.leaf.width=0.01:0.02", "--objective", "max:frequency[1]",
      "--constraint", "von_mises<=0.5*yield"], "add --yield PA"),
    (["--vary", "sections.leaf.width=0.01:0.02", "--objective", "max:frequency[1]",
      "--constraint", "buckling[1]=>3"], "the operators are <=, >= and =TARGET+-TOL"),
    (["--vary", "sections.leaf.width=0.01:0.02", "--objective", "max:frequency[1]",
      "--yield", "-1"], "--yield: expected a number > 0"),
    (["--vary", "sections.leaf.width=0.01:0.02", "--objective", "max:frequency[1]",
      "--out", "optimum.csv"], "--out"),
])
def test_the_command_refuses_bad_input_in_one_line(capsys, tmp_path, monkeypatch, argv,
                                                   message):
    monkeypatch.chdir(tmp_path)
    code, printed, err = run(capsys, "optimize", "stage_planar_1dof", *argv)
    assert code == 2
    assert message in err, err
    assert not list(tmp_path.iterdir())  # nothing written
