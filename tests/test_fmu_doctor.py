"""`flexure fmu doctor`: what it checks of an FMU in this Python, and what it names when a
requirement is missing or too old, a binary is not there, or the file is not an FMU."""

import json
import re
import sys
import zipfile

import children
import pytest
from cli_runs import run
from test_fmu_requirements import SCENE, requirements_of, without_threadpoolctl


def test_doctor_passes_in_this_python(stage_fmu, capsys):
    code, out, _ = run(capsys, "fmu", "doctor", stage_fmu)
    assert code == 0, out
    lines = out.splitlines()
    assert lines[0].split() == ["check", "status", "found"]
    assert len([line for line in lines[2:] if "  OK  " in line]) == 11
    assert lines[2].startswith("platform ") and f"binary binaries/linux64/{SCENE}.so " in out
    for item in requirements_of(stage_fmu).items:
        needs = f", needs >= {item.minimum}" if item.minimum else ""
        assert f"\n{item.pin()}{needs}  " in out
    assert out.rstrip().endswith(f"{stage_fmu}: every check passed (11)")
    code, out, _ = run(capsys, "fmu", "doctor", stage_fmu, "--json")
    report = json.loads(out)
    assert code == 0 and report["passed"] and len(report["checks"]) == 11
    assert {row["status"] for row in report["checks"]} == {"OK"}


def test_doctor_fails_in_a_python_without_threadpoolctl(stage_fmu, tmp_path):
    doctor = children.run(
        [sys.executable, "-c", "import sys; from flexure.core.cli import main; "
                             "sys.exit(main(sys.argv[1:]))", "fmu", "doctor", str(stage_fmu)],
        capture_output=True, text=True, timeout=300, env=without_threadpoolctl(tmp_path))
    assert doctor.returncode == 1, doctor.stderr
    pin = next(i.pin() for i in requirements_of(stage_fmu).items
               if i.distribution == "threadpoolctl")
    row = next(line for line in doctor.stdout.splitlines() if line.startswith(pin))
    assert row.split()[4:6] == ["MISSING", "import"]
    assert f"  {pin}, needs >= 3.1 (MISSING): python -m pip install '{pin}'" in doctor.stdout
    assert doctor.stdout.rstrip().endswith("1 of 11 checks failed")


def _rewritten(source, target, replace):
    """A copy of the FMU `source` with each member's bytes passed through replace(name, data)
    (None drops the member)."""
    with zipfile.ZipFile(source) as old, zipfile.ZipFile(target, "w") as new:
        for item in old.infolist():
            data = replace(item.filename, old.read(item.filename))
            if data is not None:
                new.writestr(item.filename, data)
    return target


def test_doctor_names_an_old_version_a_missing_package_and_another_platform(stage_fmu, tmp_path,
                                                                           capsys):
    def requirements(name, data):
        if name != "resources/requirements.txt":
            return data
        return (data.decode().replace("needs >=1.26", "needs >=99.1")
                + "no-such-dist==1.0  # import no_such_module; needs >=1.0\n").encode()

    changed = _rewritten(stage_fmu, tmp_path / "changed.fmu", requirements)
    code, out, _ = run(capsys, "fmu", "doctor", changed)
    assert code == 1
    numpy_row = next(line for line in out.splitlines() if line.startswith("numpy=="))
    assert numpy_row.split()[2:4] == [">=", "99.1"] and " OLD " in numpy_row
    assert re.search(r"\nno-such-dist==1\.0, needs >= 1\.0 +MISSING +import no_such_module: "
                     r"ModuleNotFoundError: No module named 'no_such_module'", out)
    assert "no-such-dist==1.0, needs >= 1.0 (MISSING): python -m pip install " \
           "'no-such-dist==1.0'" in out
    assert out.rstrip().endswith("2 of 12 checks failed")

    elsewhere = _rewritten(stage_fmu, tmp_path / "win.fmu", lambda name, data: None if
                           name.startswith("binaries/") else data)
    code, out, _ = run(capsys, "fmu", "doctor", elsewhere)
    assert code == 1
    assert re.search(r"\nplatform +MISSING +this machine is linux64; the FMU has no binary", out)
    assert "\nbinary " not in out  # nothing to load

    old = _rewritten(stage_fmu, tmp_path / "old.fmu", lambda name, data: None if
                     name == "resources/requirements.txt" else data)
    code, out, _ = run(capsys, "fmu", "doctor", old)
    assert code == 1
    assert re.search(r"\nresources/requirements.txt +MISSING +the FMU lists no requirements", out)


@pytest.mark.parametrize("make, message", [
    (lambda p: p, "no such file"),
    (lambda p: (p.write_text("not a zip"), p)[1], "not an FMU: File is not a zip file"),
    (lambda p: zipfile.ZipFile(p, "w").close() or p,
     "not an FMU: it has no modelDescription.xml"),
])
def test_doctor_refuses_what_is_not_an_fmu(make, message, tmp_path, capsys):
    path = make(tmp_path / "x.fmu")
    code, _, err = run(capsys, "fmu", "doctor", path)
    assert (code, err) == (2, f"flexure fmu: error: {path}: {message}\n")


def test_doctor_refuses_a_requirements_file_it_cannot_read(stage_fmu, tmp_path, capsys):
    bad = _rewritten(stage_fmu, tmp_path / "bad.fmu", lambda name, data: b"numpy\n" if
                     name == "resources/requirements.txt" else data)
    code, _, err = run(capsys, "fmu", "doctor", bad)
    assert code == 2
    assert err == (f"flexure fmu: error: {bad}: resources/requirements.txt, line 1: expected "
                   "'NAME==VERSION  # import MODULE; needs >=MINIMUM', got 'numpy'\n")
