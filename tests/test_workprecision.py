"""The work-precision study, the simulate/bench commands and the example scripts, run small."""

import sys
from pathlib import Path

import children
import numpy as np
import pytest

from examples import energy_drift, solver_floor, speed_benchmark, work_precision
from flexure.core import load_scene, natural_frequencies
from flexure.core.simulation.workprecision import work_precision as study_of

FLEXURE = str(Path(sys.executable).with_name("flexure"))


def test_work_precision_errors_fall_with_the_tolerance():
    study = study_of(load_scene("stage_planar_1dof"), 0.1, inputs={"F": 1.0},
                     methods=["cvode-bdf", "scipy-radau"], rtols=[1e-4, 1e-7],
                     reference_rtol=1e-10, samples=21)
    assert [r["status"] for r in study.rows] == ["ok"] * 4
    for method in ("cvode-bdf", "scipy-radau"):
        loose, tight = [r["error"] for r in study.rows if r["method"] == method]
        assert tight < loose < 1e-3
    assert study.markdown().startswith("| method | rtol |")


def test_work_precision_example_writes_table_and_plot(tmp_path):
    study = work_precision.main(["--scene", "stage_planar_1dof", "--t-end", "0.05",
                                 "--rtols", "1e-5", "--reference-rtol", "1e-9",
                                 "--out", str(tmp_path)])
    from flexure.core.simulation.workprecision import DEFAULT_METHODS

    assert len(study.rows) == len(DEFAULT_METHODS) == 12
    assert all(r["status"] == "ok" for r in study.rows)
    for name in ("work_precision.csv", "work_precision.md", "work_precision.png"):
        assert (tmp_path / name).stat().st_size > 100
    assert (tmp_path / "work_precision.csv").read_text().startswith("method,rtol,")


def test_speed_benchmark_example_prints_its_table(capsys):
    rows = speed_benchmark.main(["--t-end", "0.01", "--scenes", "truss_1dof_x,stage_planar_1dof"])
    assert [r["scene"] for r in rows] == ["truss_1dof_x", "stage_planar_1dof"]
    assert all(r["rhs"] >= r["steps"] > 0 and r["us_per_rhs"] > 0 for r in rows)
    assert "x real time" in capsys.readouterr().out


def test_solver_floor_surrogate_is_the_exact_linear_stage():
    """The zero-cost surrogate of examples/solver_floor.py is the stage's linearisation: its
    exact step response settles on the static deflection -A^-1 b, agrees with the matrix
    exponential, and its free vibrations have the stage's natural frequencies."""
    A, b, C, model = solver_floor.surrogate("stage_planar_3dof")
    exact = solver_floor.ExactStep(A, b)
    assert exact.check(0.3) < 1e-9
    static = -np.linalg.solve(A, b)  # by t = 1000 s: the 10.6 Hz mode decays as e^(-0.087 t)
    np.testing.assert_allclose(exact(np.array([1000.0]))[0], static, rtol=1e-9,
                               atol=1e-12 * np.max(np.abs(static)))
    frequencies = [m[0] for m in exact.free_vibration()]
    np.testing.assert_allclose(frequencies, natural_frequencies(model).frequencies_hz,
                               rtol=1e-6)


def test_solver_floor_example_prints_its_tables(capsys):
    rows = solver_floor.main(["--t-end", "0.01", "--rtols", "1e-6"])
    out = capsys.readouterr().out
    assert "s above atol" in out and "x real time" in out
    assert [r["method"] for r in rows] == [*solver_floor.METHODS, "cvode-bdf"]
    assert rows[-1]["model"] == "nonlinear" and rows[-1]["steps"] > 0
    rows, _, stroke = solver_floor.measure(t_end=0.01, nonlinear=False)
    assert 2e-4 < stroke < 3e-4  # F t^2 / (2 m0): 4.7459 m/s^2 N (figures.md) x 1e-4 s^2 / 2
    for row in rows:  # every back-end on the exact linear response: within 10 rtol
        assert row["error"] < 10 * 1e-6 * stroke, row


def test_solver_floor_refuses_what_it_cannot_solve_exactly(capsys):
    """A mode without stiffness has no exact step response of this form: a clear error; an
    unknown scene: exit 2 with the scene's name, no traceback."""
    with pytest.raises(ValueError, match="zero eigenvalue"):
        solver_floor.ExactStep(np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([0.0, 1.0]))
    with pytest.raises(SystemExit) as stop:
        solver_floor.main(["--scene", "no_such_scene", "--t-end", "0.01"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "no_such_scene" in err and "Traceback" not in err


def test_energy_drift_example_runs_short():
    worst = energy_drift.main(["--t-end", "0.05", "--interval", "0.025", "--rtol", "1e-8"])
    assert worst < 1e-5


def test_simulate_command_writes_csv_with_units_and_plot(tmp_path):
    samples = tmp_path / "force.csv"
    samples.write_text("time,F\n0.0,0.0\n0.01,2.0\n")
    out, png = tmp_path / "r.csv", tmp_path / "r.png"
    run = children.run([FLEXURE, "simulate", "stage_planar_1dof", "--t-end", "0.03",
                        "--input", f"F={samples}", "--samples", "30", "--out", str(out),
                        "--plot", str(png)], capture_output=True, text=True, check=True)
    assert "steps" in run.stdout
    lines = out.read_text().splitlines()
    assert lines[0] == "time [s],x [m],y [m]"
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (31, 3) and abs(data[10, 1]) < 1e-15 and data[-1, 1] > 1e-5
    assert png.stat().st_size > 1000


def test_simulate_command_reports_a_bad_input_without_traceback():
    run = children.run([FLEXURE, "simulate", "stage_planar_1dof", "--t-end", "0.1",
                        "--input", "F=inf"], capture_output=True, text=True)
    assert run.returncode == 2
    assert "input 'F' is not finite" in run.stderr and "Traceback" not in run.stderr


def test_bench_command_prints_the_table(tmp_path):
    md = tmp_path / "wp.md"
    run = children.run([FLEXURE, "bench", "stage_planar_1dof", "--t-end", "0.02",
                        "--methods", "cvode-bdf,scipy-dop853", "--rtols", "1e-5",
                        "--reference-rtol", "1e-9", "--markdown", str(md)],
                       capture_output=True, text=True, check=True)
    assert "cvode-bdf" in run.stdout and "scipy-dop853" in run.stdout
    assert md.read_text().count("\n") == 4


def test_bench_refuses_a_reference_no_tighter_than_what_it_judges(capsys):
    from flexure.core.cli import main

    assert main(["bench", "truss_1dof_x", "--rtols", "1e-4,1e-6", "--reference-rtol",
                 "1e-6"]) == 2
    err = capsys.readouterr().err
    assert ("--reference-rtol 1e-06: the reference must be at least 10 times tighter than the "
            "tightest of --rtols (1e-06): give at most 1e-07") in err


def test_order_limits_in_the_study_and_the_commands():
    study = study_of(load_scene("truss_1dof_x"), 0.05, methods=["ida", "ida:2"],
                     rtols=[1e-6], reference_rtol=1e-10, samples=11)
    assert [r["method"] for r in study.rows] == ["ida", "ida:2"]
    assert all(r["status"] == "ok" and r["error"] < 1e-6 for r in study.rows)
    assert study.rows[1]["steps"] > study.rows[0]["steps"]  # order 2 needs smaller steps
    for argv, message in (
            (["simulate", "truss_1dof_x", "--t-end", "0.01", "--max-order", "9"],
             "max_order: expected an integer from 1 to 5 for cvode-bdf, got 9"),
            (["bench", "truss_1dof_x", "--t-end", "0.01", "--methods", "scipy-bdf:2"],
             "unknown method 'scipy-bdf:2'")):
        run = children.run([FLEXURE, *argv], capture_output=True, text=True)
        assert run.returncode == 2
        assert message in run.stderr and "Traceback" not in run.stderr
