"""Sweeps with the registered analyses: `simulate` (core) and `loop` (flexure.controllers,
through the entry-point group flexure.sweep_analyses): a step response against the analytic
oscillator, the loop against run_loop, failures in their rows, Dask equal to the serial run,
and core still importing nothing of controllers."""

import ast
import csv
import math
import tomllib
from pathlib import Path

import pytest
from cli_runs import run

from flexure.core import load_scene, scene_path
from flexure.core.errors import UsageError
from flexure.core.sweep import analyses as sweep_analyses
from flexure.core.sweep.grid import analysis_names, columns, evaluate_point

REPO = Path(__file__).resolve().parents[1]
TRUSS = tomllib.loads(scene_path("truss_1dof_x").read_text())
STAGE = tomllib.loads(scene_path("stage_planar_1dof").read_text())
SHORT_LOOP = {"duration": 0.05, "settle": 0.02}  # s: a short move, same design as the default


def test_simulate_is_the_step_response_of_the_truss_oscillator():
    """truss_1dof_x along x is exactly linear: m0 x'' + c x' + k x = F with k = EA / L,
    c = EdA / L and m0 = the node's mass + rho_A L / 3 (the truss's consistent mass); 1 N held
    from rest (the scene's own load set to zero), over about half a period."""
    k, c, length = 94.5 / 0.1, 0.0036494 / 0.1, 0.1
    for mass in (0.206, 0.5):
        row = evaluate_point(TRUSS, {"nodes.2.force": [0.0, 0.0], "nodes.2.mass": mass},
                             analyses=("simulate",),
                             settings={"simulate": {"t_end": 0.05, "rtol": 1e-10}})
        m0 = mass + 0.1413 * length / 3
        omega, zeta = math.sqrt(k / m0), c / (2 * math.sqrt(k * m0))
        damped = omega * math.sqrt(1 - zeta**2)

        def x(t, omega=omega, zeta=zeta, damped=damped):
            return (1 - math.exp(-zeta * omega * t) * (math.cos(damped * t) + zeta / math.sqrt(
                1 - zeta**2) * math.sin(damped * t))) / k

        peak = max(x(0.05 * i / 100_000) for i in range(100_001))
        assert row["status"] == "ok"
        assert row["simulate.x.final [m]"] == pytest.approx(x(0.05), rel=1e-7)
        # the peak over the integrator's steps, which straddle the true one
        assert row["simulate.x.peak [m]"] == pytest.approx(peak, rel=1e-5)
        assert row["simulate.x.peak [m]"] <= peak * (1 + 1e-12)
    assert columns(load_scene("truss_1dof_x"), ("simulate",)) == [
        "simulate.x.final [m]", "simulate.x.peak [m]"]


def test_the_loop_columns_are_those_of_run_loop():
    from flexure.controllers import run_loop

    row = evaluate_point(STAGE, {"nodes.3.mass": 0.1}, analyses=("loop",),
                         settings={"loop": SHORT_LOOP})
    summary = run_loop("stage_planar_1dof", overrides={"nodes.3.mass": 0.1},
                       **SHORT_LOOP).summary()
    assert row["status"] == "ok"
    assert row["loop.error_ratio [-]"] == summary["error_ratio"] < 1e-3  # the loop's target
    assert row["loop.max_abs_error [m]"] == summary["max_abs_error"]
    assert row["loop.max_abs_force [N]"] == summary["max_abs_force"]
    assert row["loop.phase_margin [deg]"] == summary["phase_margin_deg"]
    assert 0 < row["loop.wall_time [s]"] < 60


def test_the_loop_on_the_linear_plant_is_run_loops_on_it():
    """--loop-plant linear: the columns of run_loop(plant="linear") at the point, and on the
    nearly linear stage the nonlinear loop's error ratio to within 1e-5."""
    from flexure.controllers import run_loop

    settings = {"loop": {**SHORT_LOOP, "plant": "linear"}}
    row = evaluate_point(STAGE, {"nodes.3.mass": 0.1}, analyses=("loop",), settings=settings)
    summary = run_loop("stage_planar_1dof", overrides={"nodes.3.mass": 0.1}, plant="linear",
                       **SHORT_LOOP).summary()
    nonlinear = evaluate_point(STAGE, {"nodes.3.mass": 0.1}, analyses=("loop",),
                               settings={"loop": SHORT_LOOP})
    assert row["loop.error_ratio [-]"] == summary["error_ratio"]
    assert row["loop.max_abs_force [N]"] == summary["max_abs_force"]
    assert abs(row["loop.error_ratio [-]"] - nonlinear["loop.error_ratio [-]"]) < 1e-5


def test_a_loop_that_cannot_be_closed_is_the_status_of_its_point():
    row = evaluate_point(STAGE, {}, analyses=("static", "loop"),
                         settings={"loop": {**SHORT_LOOP, "fs": 100.0}})
    assert row["status"].startswith("stage_planar_1dof: the closed loop at cross-over 300 "
                                    "rad/s and 100 Hz is unstable: pole z = ")
    assert row["status"].endswith("Lower the cross-over or raise the sample rate")
    assert "static.x [m]" in row and not any(key.startswith("loop.") for key in row)


def test_the_registry_names_simulate_and_loop_and_refuses_the_unknown(monkeypatch):
    assert analysis_names() == ("static", "modes", "buckling", "stress", "simulate", "loop")
    loop = sweep_analyses.find("loop")
    assert loop.defaults() == {"stroke": 1e-3, "duration": 1.0, "settle": 0.25, "fs": 4000.0,
                               "crossover": 300.0, "plant": "inprocess"}
    assert columns(load_scene("stage_planar_1dof"), ("loop",)) == [
        "loop.error_ratio [-]", "loop.max_abs_error [m]", "loop.max_abs_force [N]",
        "loop.phase_margin [deg]", "loop.wall_time [s]"]
    with pytest.raises(UsageError, match="unknown sweep analysis 'stress'; registered: "
                                         "simulate, loop"):
        sweep_analyses.find("stress")
    with pytest.raises(UsageError, match="loop: unknown option 'gain'; expected one of stroke"):
        sweep_analyses.option_values(loop, {"gain": 2})
    with pytest.raises(UsageError, match="loop option fs: expected a number > 0, got '-1'"):
        sweep_analyses.option_values(loop, {"fs": "-1"})

    import importlib.metadata

    broken = importlib.metadata.EntryPoint("broken_probe", "no_such_package.sweep:X",
                                           sweep_analyses.ENTRY_POINT_GROUP)
    real = importlib.metadata.entry_points
    monkeypatch.setattr(importlib.metadata, "entry_points", lambda group: (
        [*real(group=group), broken] if group == sweep_analyses.ENTRY_POINT_GROUP
        else real(group=group)))
    assert "broken_probe" not in sweep_analyses.available()  # the others still load
    with pytest.raises(UsageError, match="sweep analysis 'broken_probe' could not be loaded: "
                                         "no_such_package.sweep:X: ModuleNotFoundError"):
        sweep_analyses.find("broken_probe")


def test_core_imports_nothing_of_controllers_or_fmu():
    """The loop reaches the sweep through the registry, not through an import."""
    for path in (REPO / "core").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([alias.name for alias in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            for name in names:
                assert not name.startswith(("flexure.controllers", "flexure.fmu")), (
                    f"{path.relative_to(REPO)} imports {name}")


# -- the command ----------------------------------------------------------------------------

ARGV = ["sweep", "stage_planar_1dof", "--param", "sections.leaf.height=0,0.5e-3",
        "--param", "nodes.3.mass=0.2", "--analyses", "static,simulate,loop",
        "--simulate-t-end", "0.02", "--loop-duration", "0.05", "--loop-settle", "0.02",
        "--no-plot"]


def read(path):
    with open(path, newline="") as handle:
        return list(csv.reader(handle))


@pytest.mark.slow  # 5 s on a Dask cluster: test_sweep.py runs Dask, the tests above these analyses
def test_dask_gives_the_serial_table_with_simulate_and_loop(tmp_path, capsys):
    serial, dask = tmp_path / "serial.csv", tmp_path / "dask.csv"
    assert run(capsys, *ARGV, "--serial", "--out", serial)[0] == 0
    code, out, _ = run(capsys, *ARGV, "--workers", "2", "--out", dask)
    assert code == 0 and "a local Dask cluster of 2 processes" in out
    rows, other = read(serial), read(dask)
    assert rows[0] == ["sections.leaf.height", "nodes.3.mass", "static.x [m]", "static.y [m]",
                       "simulate.x.final [m]", "simulate.x.peak [m]", "simulate.y.final [m]",
                       "simulate.y.peak [m]", "loop.error_ratio [-]",
                       "loop.max_abs_error [m]", "loop.max_abs_force [N]",
                       "loop.phase_margin [deg]", "loop.wall_time [s]", "status"]
    wall = rows[0].index("loop.wall_time [s]")
    assert other[0] == rows[0]
    # every cell the same text (the same bits), but the wall time
    assert [row[:wall] + row[wall + 1:] for row in other] == \
        [row[:wall] + row[wall + 1:] for row in rows]
    failed, good = rows[1:]
    assert failed[-1] == "--set sections.leaf.height: expected a value > 0, got 0"
    assert failed[2:-1] == [""] * 11  # height 0: refused by the scene, no quantity
    assert good[-1] == "ok" and float(good[wall]) > 0
    assert float(good[rows[0].index("loop.error_ratio [-]")]) < 1e-3  # the loop's target
    assert float(good[rows[0].index("simulate.x.peak [m]")]) > 0  # 1 N pushes the bar on


@pytest.mark.parametrize("argv, message", [
    (["--analyses", "static", "--loop-stroke", "1e-4"],
     "--loop-stroke: loop is not among --analyses static"),
    (["--analyses", "simulate", "--simulate-input", "G=1"],
     "--simulate-input G: the scene has no input 'G'; its inputs: F"),
])
def test_analysis_options_that_do_not_fit_are_one_line(argv, message, tmp_path, capsys):
    code, _, err = run(capsys, "sweep", "stage_planar_1dof", "--param", "nodes.3.mass=0,1",
                       *argv, "--out", tmp_path / "s.csv")
    assert (code, err) == (2, f"flexure sweep: error: {message}\n")
    assert not (tmp_path / "s.csv").exists()


@pytest.mark.parametrize("argv, message", [
    (["--simulate-rtol", "2"], "argument --simulate-rtol: expected a number in (0, 1), got '2'"),
    (["--simulate-method", "rk4"], "argument --simulate-method: expected one of cvode-bdf"),
    (["--simulate-input", "F"], "argument --simulate-input: expected NAME=VALUE[,NAME=VALUE"),
    (["--loop-fs", "0"], "argument --loop-fs: expected a number > 0, got '0'"),
    (["--loop-plant", "fmu"], "argument --loop-plant: expected inprocess or linear, got 'fmu'"),
    (["--analyses", "static,strain"], "unknown analysis 'strain'; expected some of static, "
                                      "modes, buckling, stress, simulate, loop"),
])
def test_bad_analysis_options_are_refused_by_the_parser(argv, message, capsys):
    code, _, err = run(capsys, "sweep", "stage_planar_1dof", "--param", "nodes.3.mass=0,1",
                       "--analyses", "simulate,loop", *argv)
    assert code == 2 and message in err
