"""The command line and the scene loader under bad input: one test per kind of mistake
(the fuzzing is in test_fuzz.py).

Every user mistake is one line naming the file, key or option and what is wrong, with exit
code 2 (argparse's convention, kept for the project's own errors), and never a traceback;
output paths are checked before a run, and results are written atomically.
"""

import errno
import json
import os
import sys
import tomllib
import zipfile
from pathlib import Path

import children
import numpy as np
import pytest

from flexure.core import ConstraintError, SceneError, build_model, load_scene, scene_path
from flexure.core.cli import atomic_output, write_outputs
from flexure.core.errors import OutputError
from flexure.core.reporting.tables import json_text
from tests.cli_runs import StubResult, run

FLEXURE = str(Path(sys.executable).with_name("flexure"))  # the installed console script
SCENES = Path(__file__).resolve().parents[1] / "examples" / "scenes"


def scene(name, edit):
    data = tomllib.loads(scene_path(name).read_text())
    edit(data)
    return data




def refused(capsys, *argv, says):
    code, out, err = run(capsys, *argv)
    assert code == 2, (code, out, err)
    for text in [says] if isinstance(says, str) else says:
        assert text in err, err
    return err


@pytest.fixture
def no_run(monkeypatch):
    """Fail the test if a simulation, study, loop or FMU build starts: the checks come first."""
    def forbidden(*args, **kwargs):
        raise AssertionError("the run started before the arguments were checked")

    import flexure.core.cli.bench as cli_bench
    import flexure.core.simulation.simulation as simulation
    import flexure.fmu.cli as fmu_cli

    monkeypatch.setattr(simulation, "simulate", forbidden)
    monkeypatch.setattr(cli_bench, "work_precision", forbidden)
    monkeypatch.setattr(fmu_cli, "build_scene_fmu", forbidden)


# -- the scene ---------------------------------------------------------------------------------

def test_an_invalid_utf8_byte_names_the_file_line_and_byte(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    text = scene_path("truss_1dof_x").read_bytes()
    path.write_bytes(text.replace(b'name = "truss_1dof_x"', b'name = "truss\xff"'))
    with pytest.raises(SceneError, match=r"bad.toml: line \d+: not UTF-8 text: byte 0xff"):
        load_scene(path)
    refused(capsys, "analyze", path, says="not UTF-8 text")
    refused(capsys, "fmu", "build", path, says="not UTF-8 text")


def test_a_list_where_a_string_belongs():
    data = scene("stage_planar_1dof", lambda d: d["outputs"]["y"].update(quantity=[1.0, 2.0]))
    with pytest.raises(SceneError, match=r"outputs.y.quantity: expected one of position, "
                                         r"velocity, acceleration, got \[1.0, 2.0\]"):
        build_model(data)
    for key, value in (("section", ["leaf"]), ("type", {"a": 1})):
        data = scene("stage_planar_1dof", lambda d, k=key, v=value: d["elements"]["bar"]
                     .update({k: v}))
        with pytest.raises(SceneError, match=f"elements.bar.{key}"):
            build_model(data)


def test_an_absurd_rotation_is_refused():
    data = scene("stage_spatial_1dof", lambda d: d["nodes"]["4"].update(rotation=[0, -1e308, 0]))
    with pytest.raises(SceneError, match=r"nodes.4.rotation\[1\]: expected a magnitude <= 1000 "
                                         r"rad, got -1e\+308"):
        build_model(data)
    data = scene("stage_spatial_1dof", lambda d: d["nodes"]["4"].update(rotation=[800, 800, 0]))
    with pytest.raises(SceneError, match="nodes.4.rotation: expected a rotation vector of "
                                         "magnitude <= 1000 rad"):
        build_model(data)


def test_absurd_numbers_and_overflowing_sections_are_refused():
    data = scene("stage_planar_1dof", lambda d: d["sections"]["leaf"].update(EdA=1e308))
    with pytest.raises(SceneError, match=r"sections.leaf.EdA: expected a magnitude <= 1e\+20"):
        build_model(data)
    data = scene("stage_planar_1dof", lambda d: d["nodes"]["3"].update(position=[10**400, 0]))
    with pytest.raises(SceneError, match=r"nodes.3.position\[0\]: .* an integer of 401 digits"):
        build_model(data)
    data = scene("stage_spatial_1dof", lambda d: d["sections"]["leaf"].update(width=0.0))
    with pytest.raises(SceneError, match=r"sections.leaf.width: expected a value > 0"):
        build_model(data)


def test_duplicated_names_are_refused():
    cases = [
        (lambda d: d["nodes"]["3"].update(dof=["x", "x"]), "nodes.3.dof: 'x' is listed 2 times"),
        (lambda d: d["elements"]["leaf_left"].update(released=["e2", "e2", "e3"]),
         "elements.leaf_left.released: 'e2' is listed 2 times"),
        (lambda d: d["nodes"]["1"].update(fixed=["x", "y", "x"]), "nodes.1.fixed: 'x' is listed"),
        (lambda d: d["scene"].update(tunable=["sections.bar.rho_A", "sections.bar.rho_A"]),
         "scene.tunable: 'sections.bar.rho_A' is listed 2 times"),
        (lambda d: d["outputs"].update(F=d["outputs"].pop("y")),
         "outputs.F: the input inputs.F has the same name"),
    ]
    for edit, message in cases:
        with pytest.raises(SceneError, match=message):
            build_model(scene("stage_planar_1dof", edit))


def test_an_over_constraint_is_reported_once_with_its_count():
    data = scene("stage_spatial_1dof", lambda d: d["elements"]["leaf_right"].pop("released"))
    for node in data["nodes"].values():
        node.pop("dof", None)
    with pytest.raises(ConstraintError) as error:
        build_model(data)
    lines = str(error.value).splitlines()
    assert len(lines) == len(set(lines)), lines
    over = [line for line in lines if "over-constrained" in line]
    assert len(over) == 1 and "so 4 of them are redundant; release 4 of them" in over[0]


# -- numeric options ---------------------------------------------------------------------------

@pytest.mark.parametrize("argv, says", [
    (["simulate", "truss_1dof_x", "--t-end", "1", "--rtol", "1e300"],
     "argument --rtol: expected a number in (0, 1), got '1e300'"),
    (["simulate", "truss_1dof_x", "--t-end", "1", "--samples", "-5"],
     "argument --samples: expected an integer in [1, 1e+06], got '-5'"),
    (["simulate", "truss_1dof_x", "--t-end", "1", "--samples", "10000000"],
     "argument --samples: expected an integer in [1, 1e+06], got '10000000'"),
    (["simulate", "truss_1dof_x", "--t-end", "nan"], "argument --t-end: expected a number > 0"),
    (["simulate", "truss_1dof_x", "--t-end", "1", "--max-step", "1e-12"],
     "--max-step 1e-12 s with --t-end 1 s means at least 1e+12 steps (more than 1e+08): "
     "raise --max-step or shorten --t-end"),
    (["simulate", "truss_1dof_x", "--t-end", "1", "--atol", "-1"],
     "argument --atol: expected a number > 0"),
    (["simulate", "truss_1dof_x", "--t-end", "1", "--input", "F=1", "--input", "F=2"],
     "--input 'F=2': the input 'F' is given twice"),
    (["analyze", "truss_1dof_x", "--modes", "0"], "argument --modes: expected an integer >= 1"),
    (["analyze", "truss_1dof_x", "--modes", "-3"], "argument --modes: expected an integer >= 1"),
    (["analyze", "truss_1dof_x", "--buckling", "0"],
     "argument --buckling: expected an integer >= 1"),
    (["bench", "truss_1dof_x", "--rtols", "1e-3,2"], "argument --rtols: '1e-3,2': expected a "
                                                     "number in (0, 1), got '2'"),
    (["bench", "truss_1dof_x", "--methods", "ida,ida"], "'ida' is listed 2 times"),
    (["bench", "truss_1dof_x", "--samples", "1"], "argument --samples: expected an integer in"),
    (["bench", "truss_1dof_x", "--time-limit", "0"], "argument --time-limit: expected a number"),
    (["loop", "--stroke", "0"], "argument --stroke: expected a nonzero length"),
    (["loop", "--rtol", "1"], "argument --rtol: expected a number in (0, 1)"),
    (["loop", "--fs", "-4000"], "argument --fs: expected a number > 0"),
    (["fmu", "check", "a.fmu", "in.csv", "ref.csv", "--rtol", "inf"],
     "argument --rtol: expected a number in [0, 1)"),
    (["fmu", "check", "a.fmu", "in.csv", "ref.csv", "--interval", "0"],
     "argument --interval: expected a number > 0"),
])
def test_numeric_options_are_checked(capsys, no_run, argv, says):
    refused(capsys, *argv, says=says)


# -- output paths: checked before the run ------------------------------------------------------

@pytest.fixture
def places(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "folder").mkdir()
    (tmp_path / "file").write_text("not a folder")
    return tmp_path


@pytest.mark.parametrize("path, says", [
    ("missing/out.csv", "the folder missing does not exist"),
    ("folder", "folder: is a folder; expected a file name"),
    ("file/out.csv", "file is a file, not a folder"),
    ("file/deeper/out.csv", "file is a file, not a folder"),
    ("/dev/full", "exists and is not a regular file"),
])
def test_simulate_out_is_checked_before_the_run(capsys, places, no_run, path, says):
    refused(capsys, "simulate", "truss_1dof_x", "--t-end", "1", "--out", path,
            says=["argument --out", says])
    refused(capsys, "bench", "truss_1dof_x", "--csv", path, says=["argument --csv", says])


@pytest.mark.parametrize("command", [["simulate", "truss_1dof_x", "--t-end", "1"],
                                     ["analyze", "truss_1dof_x"], ["bench", "truss_1dof_x"]])
def test_plot_gets_no_silent_extension(capsys, places, no_run, command):
    refused(capsys, *command, "--plot", "folder", says="is a folder")
    refused(capsys, *command, "--plot", "result",
            says="expected a file name ending in .png or .pdf or .svg (it has none; no "
                 "extension is added or changed)")
    assert not (places / "result.png").exists() and not (places / "folder.png").exists()


def test_loop_plot_is_checked_before_the_loop(capsys, places, monkeypatch):
    import flexure.controllers.cli as loop_cli

    monkeypatch.setattr(loop_cli, "run_loop", lambda *a, **k: pytest.fail("the loop ran"))
    refused(capsys, "loop", "--plot", "folder", says="--plot folder: is a folder")
    refused(capsys, "loop", "--plot", "missing/loop.png", says="folder missing does not exist")
    refused(capsys, "loop", "--workdir", "file/w", says="--workdir file/w: file is not a folder")


def test_two_outputs_into_one_file_and_an_output_over_an_input(capsys, places, no_run):
    refused(capsys, "bench", "truss_1dof_x", "--csv", "a.csv", "--markdown", "a.csv",
            says="--markdown a.csv: the same file as --csv a.csv")
    scene_file = places / "s.toml"
    scene_file.write_bytes(scene_path("truss_1dof_x").read_bytes())
    refused(capsys, "simulate", scene_file, "--t-end", "1", "--out", scene_file,
            says="is an input of this run")
    assert scene_file.read_bytes() == scene_path("truss_1dof_x").read_bytes()


@pytest.mark.parametrize("path, says", [
    ("missing/x.fmu", "-o missing/x.fmu: the folder missing does not exist"),
    ("file/x.fmu", "file is a file, not a folder"),
    ("/dev/full", "exists and is not a regular file"),
    ("x.zip", "expected a file name ending in .fmu"),
])
def test_fmu_build_output_is_checked_before_the_build(capsys, places, no_run, path, says):
    refused(capsys, "fmu", "build", "truss_1dof_x", "-o", path, says=says)


def test_fmu_build_refuses_tunable_keys_beside_no_tunable(capsys, places, no_run):
    refused(capsys, "fmu", "build", "truss_1dof_x", "--tunable", "nodes.2.mass",
            "--no-tunable", says="--no-tunable and --tunable nodes.2.mass: give one")


def test_fmu_build_into_a_folder_moves_the_fmu_in_at_the_end(capsys, places, monkeypatch):
    import flexure.fmu.cli as fmu_cli

    def fake_build(scene, dest, **kwargs):
        assert Path(dest).resolve().parent == places / "folder"  # beside its destination
        built = Path(dest) / "truss_1dof_x.fmu"
        built.write_bytes(b"PK fake")
        return built

    monkeypatch.setattr(fmu_cli, "build_scene_fmu", fake_build)
    code, out, _ = run(capsys, "fmu", "build", "truss_1dof_x", "-o", "folder")
    assert code == 0 and out.strip() == str(Path("folder") / "truss_1dof_x.fmu")
    assert sorted(p.name for p in (places / "folder").iterdir()) == ["truss_1dof_x.fmu"]


# -- writing: atomic, and one failed file loses no other ----------------------------------------

def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "result.csv"
    target.write_text("previous result\n")

    def full_disk(path):
        Path(path).write_text("half of the new")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(OutputError, match="--out .*result.csv: cannot write: No space left"):
        with atomic_output(target, "--out") as temporary:
            full_disk(temporary)
    assert target.read_text() == "previous result\n"
    assert [p.name for p in tmp_path.iterdir()] == ["result.csv"]


def test_one_failed_output_does_not_lose_the_others(tmp_path, capsys):
    def full_disk(path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    code = write_outputs("flexure simulate", [
        ("--out", tmp_path / "a.csv", full_disk),
        ("--plot", tmp_path / "b.png", lambda path: Path(path).write_bytes(b"png"))])
    out, err = capsys.readouterr()
    assert code == 2
    assert "flexure simulate: error: --out" in err and "No space left on device" in err
    assert f"wrote {tmp_path / 'b.png'}" in out and (tmp_path / "b.png").read_bytes() == b"png"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.png"]


def test_simulate_writes_its_outputs_atomically(capsys, places, monkeypatch):
    import flexure.core.simulation.simulation as simulation

    class Result(StubResult):
        def to_csv(self, path):
            assert Path(path).name.startswith(".out.") and Path(path).parent.samefile(".")
            Path(path).write_text("time,x\n")

        def plot(self, path, **kwargs):
            assert Path(path).suffix == ".png"  # the format follows the temporary's suffix
            Path(path).write_bytes(b"png")

    monkeypatch.setattr(simulation, "simulate", lambda *a, **k: Result())
    code, out, _ = run(capsys, "simulate", "truss_1dof_x", "--t-end", "1", "--out", "out.csv",
                       "--plot", "out.png")
    assert code == 0 and "wrote out.csv" in out and "wrote out.png" in out
    assert sorted(p.name for p in places.iterdir()) == ["file", "folder", "out.csv", "out.png"]


# -- JSON --------------------------------------------------------------------------------------

def strict(text):
    def refuse(token):
        raise ValueError(f"not JSON: {token}")

    return json.loads(text, parse_constant=refuse)


def test_json_has_no_nan_or_infinity(capsys):
    text, replaced = json_text({"a": [1.0, float("inf")], "b": {"c": float("nan")},
                                "d": np.array([-np.inf])})
    assert strict(text) == {"a": [1.0, None], "b": {"c": None}, "d": [None]}
    assert replaced == ["a[1] = inf", "b.c = nan", "d[0] = -inf"]
    code, out, err = run(capsys, "analyze", "truss_1dof_x", "--json", "--modes", "--static")
    assert code == 0 and strict(out)["modes"]["frequencies_hz"] and err == ""


def test_loop_json_writes_an_infinite_margin_as_null(capsys, monkeypatch, tmp_path):
    import flexure.controllers.cli as loop_cli

    class Result:
        def summary(self):
            return {"scene": "s", "gain_margin": float("inf"), "max_abs_error": 1e-7}

    monkeypatch.setattr(loop_cli, "run_loop", lambda *a, **k: Result())
    code, out, err = run(capsys, "loop", "--json", "--no-plot")
    assert code == 0 and strict(out)["gain_margin"] is None
    assert "gain_margin = inf" in err and "written as null" in err


# -- the work-precision study ------------------------------------------------------------------

def test_bench_whose_every_run_fails_exits_2_after_writing_its_table(capsys, places,
                                                                    monkeypatch):
    import flexure.core.cli.bench as cli_bench

    class Study:
        rows = [{"method": m, "rtol": 1e-3, "status": "time limit"} for m in ("ida", "cvode-bdf")]

        def text(self):
            return "table"

        def markdown(self):
            return "| table |"

        def to_csv(self, path):
            Path(path).write_text("csv\n")

        def plot(self, path):
            Path(path).write_bytes(b"png")

    monkeypatch.setattr(cli_bench, "work_precision", lambda *a, **k: Study())
    err = refused(capsys, "bench", "truss_1dof_x", "--csv", "wp.csv",
                  says="every run failed (2 of 2; first: ida rtol 0.001: time limit)")
    assert (places / "wp.csv").read_text() == "csv\n"
    assert "Traceback" not in err


# -- fmu check ---------------------------------------------------------------------------------

MODEL_DESCRIPTION = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="m" guid="{0}"
  variableNamingConvention="structured" numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="m"/>
  <ModelVariables>
    <ScalarVariable name="F" valueReference="0" causality="input" variability="continuous">
      <Real start="0"/></ScalarVariable>
    <ScalarVariable name="x" valueReference="1" causality="output" variability="continuous">
      <Real/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="2"/></Outputs></ModelStructure>
</fmiModelDescription>
"""


@pytest.fixture
def fmu_files(tmp_path):
    """An FMU with a model description only (the CSV checks come before any simulation)."""
    fmu = tmp_path / "m.fmu"
    with zipfile.ZipFile(fmu, "w") as archive:
        archive.writestr("modelDescription.xml", MODEL_DESCRIPTION)
    good_in = tmp_path / "in.csv"
    good_in.write_text("time,F\n0,0\n0.1,1\n")
    good_ref = tmp_path / "ref.csv"
    good_ref.write_text('"time","x"\n0,0\n0.1,0\n')
    return fmu, good_in, good_ref


def test_fmu_check_of_a_file_that_is_not_a_zip(capsys, tmp_path):
    fake = tmp_path / "notes.fmu"
    fake.write_text("not a zip")
    refused(capsys, "fmu", "check", fake, SCENES / "truss_1dof_x_in.csv",
            SCENES / "truss_1dof_x_ref.csv", says="notes.fmu: not an FMU (not a zip archive)")
    broken = tmp_path / "broken.fmu"
    with zipfile.ZipFile(broken, "w") as archive:
        archive.writestr("readme.txt", "no model description")
    refused(capsys, "fmu", "check", broken, SCENES / "truss_1dof_x_in.csv",
            SCENES / "truss_1dof_x_ref.csv", says="broken.fmu: not a valid FMU")


@pytest.mark.parametrize("which, text, says", [
    ("in", "time,F\n0,a\n", "expected a header line \"time,NAME,...\" and rows of numbers: "
                            "could not convert string to float: 'a'"),
    ("in", "", "the file has no rows of samples"),
    ("in", "time,F\n", "the file has no rows of samples"),
    ("in", "time,F\n0\n1,2\n", "expected a header line"),
    ("in", "t,F\n0,0\n", "expected the first column \"time\", got 't'"),
    ("in", "time,F\n0,nan\n", "column 'F', row 2: expected a finite number, got nan"),
    ("in", "time,F\n1,0\n0,0\n", "row 3: time 0 s after 1 s; expected times that never "
                                 "decrease"),
    ("in", "time,G\n0,0\n1,0\n", "column 'G' is not an input of"),
    ("in", b"time,F\n0,\xff\n", "not UTF-8 text"),
    ("ref", "time,x\n0,0.1\n", "expected at least 2 rows of samples, got 1"),
    ("ref", "time,x\n0,0\n0,1\n", "expected times that increase"),
    ("ref", "time,x,x\n0,0,0\n1,0,0\n", "expected a header line"),
])
def test_fmu_check_with_malformed_csv(capsys, fmu_files, which, text, says):
    fmu, good_in, good_ref = fmu_files
    bad = fmu.parent / f"bad_{which}.csv"
    bad.write_bytes(text if isinstance(text, bytes) else text.encode())
    args = (bad, good_ref) if which == "in" else (good_in, bad)
    refused(capsys, "fmu", "check", fmu, *args, says=[str(bad), says])


def test_fmu_check_update_checks_the_reference_path_first(capsys, fmu_files):
    fmu, good_in, _ = fmu_files
    refused(capsys, "fmu", "check", fmu, good_in, fmu.parent, "--update",
            says="REFERENCE_CSV")
    refused(capsys, "fmu", "check", fmu, good_in, good_in, "--update",
            says="is an input of this run")
    assert good_in.read_text() == "time,F\n0,0\n0.1,1\n"


# -- the console script: a handful end to end --------------------------------------------------

@pytest.mark.parametrize("argv, says", [
    (["simulate", "truss_1dof_x", "--t-end", "1", "--out", "/nonexistent/dir/x.csv"],
     "the folder /nonexistent/dir does not exist"),
    (["analyze", "truss_1dof_x", "--modes", "0"], "expected an integer >= 1"),
])
def test_console_script_answers_in_one_line(argv, says):
    completed = children.run([FLEXURE, *argv], capture_output=True, text=True)
    assert completed.returncode == 2
    assert says in completed.stderr and "Traceback" not in completed.stderr
    errors = [line for line in completed.stderr.splitlines() if "error:" in line]
    assert len(errors) == 1 and says in errors[0]  # after argparse's usage lines, if any


def test_fmu_build_refuses_an_output_named_like_the_von_mises_output(capsys, places, no_run):
    data = scene_path("stage_spatial_1dof").read_text().replace("[outputs.x]",
                                                                "[outputs.von_mises_max]")
    (places / "s.toml").write_text(data)
    refused(capsys, "fmu", "build", "s.toml", "--von-mises",
            says="outputs.von_mises_max: --von-mises adds an output of that name")


@pytest.mark.parametrize("command", [["loop"], ["analyze"], ["fmu", "build"], ["reduce"],
                                     ["simulate"], ["sweep"], ["import"]])
def test_help_shows_percent_signs_as_typed(command, capsys):
    """argparse %-formats help strings but not descriptions: a doubled sign in a description
    prints doubled ("0.1 %%" in `loop --help`)."""
    code, out, err = run(capsys, *command, "--help")
    assert code == 0 and "%%" not in out + err


def test_simulate_help_describes_every_method_from_the_registry(capsys):
    from flexure.core.simulation.methods import METHOD_TABLE

    code, out, err = run(capsys, "simulate", "--help")
    text = " ".join(out.split())  # argparse wraps (and breaks at hyphens)
    assert code == 0
    for method in METHOD_TABLE:
        assert " ".join(f"{method.name}, {method.summary}".split()) in text.replace("- ", "-")


@pytest.mark.parametrize("rows, says", [
    ("-1,0\n0,1\n", "row 1 of the samples: time -1 s is before the simulation's start at 0 s"),
    ("0,0\n0.5,1\n0.5,2\n", "row 3 of the samples: expected a time after 0.5 s"),
    ("0,0\n1,nan\n", "row 2 of the samples: expected finite numbers"),
])
def test_an_input_file_out_of_time_is_refused(capsys, tmp_path, no_run, rows, says):
    samples = tmp_path / "force.csv"
    samples.write_text("time,F\n" + rows)
    refused(capsys, "simulate", "truss_1dof_x", "--t-end", "1", "--input", f"F={samples}",
            says=f"{samples}: {says}")


def test_a_sample_rate_far_above_the_plant_is_refused_not_a_traceback(capsys, places):
    """At 1 GHz the 1-DOF stage's sampled poles lie within round-off of z = 1, where the
    margins' frequency response cannot be evaluated: said, with what to do."""
    refused(capsys, "loop", "stage_planar_1dof", "--no-plot", "--fs", "1e9", "--duration",
            "0.001", "--settle", "0",
            says=["its poles lie within round-off of z = 1", "lower the sample rate"])
