"""flexure's corrected build of pythonfmu 0.7.0's binary (fmu/native): the committed library is
the one its manifest names and is linked as the stock one is; the FMU builder puts it into
FMUs where it fits and falls back to the stock binary otherwise, saying which; and in fmpy it
answers fmi2Error where the stock binary crashed the host (each case in a process of its own,
fmu_abuse_cases.py, so that a crash is observed, not suffered). The stock binary's crashes,
the fallback's datasheet, are in test_fmu_abuse.py (slow tier)."""

import hashlib
import json
import os
import re
import zipfile
from pathlib import Path

import children
import pytest
from fmu_abuse_runs import run

from flexure.fmu import FMUBuildError, build_slave_fmu, pythonfmu_binary
from flexure.fmu.pythonfmu_binary import LIBRARY, MANIFEST, NATIVE, RECORD, choose_binary
from flexure.fmu.pythonfmu_workarounds import PYTHONFMU_LOGGER_LAYOUTS, binary_note

CORRECTED = NATIVE / "linux64" / LIBRARY
# the repository's build script (a source of the repository, not shipped with the package:
# an installed flexure carries the built library only)
BUILD_SCRIPT = Path(__file__).resolve().parents[1] / "fmu" / "native" / "build.sh"


def stock_library():
    import pythonfmu

    return Path(pythonfmu.__file__).parent / "resources" / "binaries" / "linux64" / LIBRARY


def dynamic(path, *arguments):
    return children.run(arguments + (str(path),), capture_output=True, text=True,
                        check=True).stdout


# -- the committed library ---------------------------------------------------------------------


def test_the_committed_library_is_the_one_its_manifest_names():
    manifest = json.loads((NATIVE / "linux64" / MANIFEST).read_text())
    assert hashlib.sha256(CORRECTED.read_bytes()).hexdigest() == manifest["sha256"]
    assert (manifest["pythonfmu"], manifest["python_abi"]) == ("0.7.0", "abi3")
    # log_to_host reads the logger object of a binary it knows by its SHA-256
    assert manifest["sha256"] in PYTHONFMU_LOGGER_LAYOUTS


def test_it_is_linked_as_the_stock_binary():
    """The same libraries needed (no libpython: the Python C-API is taken from the host
    process), the same FMI functions exported, and the stock binary's Python imports plus the
    four stable-ABI functions the patch calls."""
    def needed(path):
        return re.findall(r"\(NEEDED\)\s+Shared library: \[(.+)\]", dynamic(path, "readelf", "-d"))

    def symbols(path, *flags):
        return {line.split()[-1] for line in dynamic(path, "nm", "-D", *flags).splitlines()}

    assert needed(CORRECTED) == needed(stock_library()) == [
        "libstdc++.so.6", "libgcc_s.so.1", "libc.so.6"]
    exported = {s for s in symbols(CORRECTED, "--defined-only") if s.startswith("fmi2")}
    assert exported == {s for s in symbols(stock_library(), "--defined-only")
                        if s.startswith("fmi2")}
    assert len(exported) == 34  # every FMI 2.0 function but the model-exchange ones

    def python(path):
        return {s for s in symbols(path, "--undefined-only") if re.match(r"_?Py", s)}

    assert python(CORRECTED) - python(stock_library()) == {
        "PyErr_SetString", "PyExc_RuntimeError", "PyObject_HasAttrString", "_Py_FalseStruct"}
    assert python(stock_library()) <= python(CORRECTED)


# -- the builder's choice ----------------------------------------------------------------------


def test_a_scene_fmu_carries_the_corrected_binary_and_says_so(scene_fmus):
    with zipfile.ZipFile(scene_fmus("stage_planar_3dof")) as fmu:
        assert fmu.read("binaries/linux64/stage_planar_3dof.so") == CORRECTED.read_bytes()
        entry = json.loads(fmu.read(f"resources/{RECORD}"))["linux64"]
    assert entry["binary"] == "corrected"
    assert entry["sha256"] == hashlib.sha256(CORRECTED.read_bytes()).hexdigest()


def test_the_stock_binary_when_asked_and_its_record(scene_fmus):
    with zipfile.ZipFile(scene_fmus("stage_planar_3dof", "stock")) as fmu:
        assert fmu.read("binaries/linux64/stage_planar_3dof.so") == \
            stock_library().read_bytes()
        entry = json.loads(fmu.read(f"resources/{RECORD}"))["linux64"]
    assert entry == {"binary": "stock", "why": "the stock binary was asked for",
                     "sha256": hashlib.sha256(stock_library().read_bytes()).hexdigest()}


def test_the_environment_chooses_too(monkeypatch):
    monkeypatch.setenv("FLEXURE_FMU_BINARY", "stock")
    assert choose_binary("linux64").kind == "stock"
    monkeypatch.setenv("FLEXURE_FMU_BINARY", "")
    assert choose_binary("linux64").kind == "corrected"


def fake_native(tmp_path, monkeypatch, **changes):
    """A copy of fmu/native/linux64 with its manifest changed; the builder looks there."""
    folder = tmp_path / "native" / "linux64"
    folder.mkdir(parents=True)
    (folder / LIBRARY).write_bytes(CORRECTED.read_bytes())
    manifest = json.loads((NATIVE / "linux64" / MANIFEST).read_text())
    (folder / MANIFEST).write_text(json.dumps({**manifest, **changes}))
    monkeypatch.setattr(pythonfmu_binary, "NATIVE", tmp_path / "native")
    return folder


@pytest.mark.parametrize("changes, why", [
    ({"sha256": "0" * 64}, r"has SHA-256 0690858abe8b, its manifest says 000000000000: "
                           r"rebuild it with fmu/native/build.sh"),
    ({"pythonfmu": "0.6.9"}, r"it is pythonfmu 0.6.9's binary, and pythonfmu 0.7.0 is "
                             r"installed: its C\+\+ half must match the Python half"),
    ({"python_abi": "cpython-27"}, r"it is built for the Python ABI 'cpython-27'; this "
                                   r"Python is cpython \(cpython-3\d+\)"),
])
def test_a_corrected_binary_that_does_not_fit_falls_back_to_the_stock_one(
        tmp_path, monkeypatch, changes, why):
    fake_native(tmp_path, monkeypatch, **changes)
    chosen = choose_binary("linux64", "auto")
    assert chosen.kind == "stock" and chosen.data is None
    assert re.search(why, chosen.reason), chosen.reason
    with pytest.raises(ValueError, match=r"the corrected pythonfmu binary for linux64 cannot "
                                         r"be used: (\S+ )?" + why):
        choose_binary("linux64", "corrected")


def test_a_platform_without_a_build_and_a_broken_manifest(tmp_path, monkeypatch):
    assert choose_binary("win64").reason == ("flexure has no corrected build for win64 "
                                             "(fmu/native/build.sh makes one on Linux x86_64)")
    folder = fake_native(tmp_path, monkeypatch)
    (folder / MANIFEST).write_text("{}")
    assert re.search(r"not a manifest of the build \('sha256'\)",
                     choose_binary("linux64").reason)


def test_an_unknown_choice_or_an_unfit_corrected_binary_stops_the_build(tmp_path, monkeypatch):
    script = tmp_path / "Plain.py"
    script.write_text(RAISER.replace("Raiser", "Plain"))
    with pytest.raises(FMUBuildError, match=r"Plain.py: pythonfmu binary 'patched': expected "
                                            r"one of auto, corrected, stock"):
        build_slave_fmu(script, tmp_path, bundle=(), pythonfmu_binary="patched")
    fake_native(tmp_path, monkeypatch, pythonfmu="0.6.9")
    with pytest.raises(FMUBuildError, match="cannot be used: it is pythonfmu 0.6.9's binary"):
        build_slave_fmu(script, tmp_path, bundle=(), pythonfmu_binary="corrected")
    assert not list(tmp_path.glob("*.fmu"))


def test_the_slave_logs_which_binary(tmp_path):
    resources = tmp_path / "resources"
    resources.mkdir()
    assert binary_note(str(resources)) is None  # an FMU without the record
    (resources / RECORD).write_text(json.dumps({"linux64": {
        "binary": "corrected", "pythonfmu": "0.7.0", "patch": 1, "sha256": "ab" * 32}}))
    assert binary_note(str(resources)) == (
        "pythonfmu binary (linux64): flexure's corrected build of pythonfmu 0.7.0 (patch 1, "
        "SHA-256 abababababab): NULL state handles and freed instances answer fmi2Error")
    (resources / RECORD).write_text(json.dumps({"linux64": {
        "binary": "stock", "why": "asked", "sha256": "cd" * 32}}))
    assert binary_note(str(resources)) == (
        "pythonfmu binary (linux64): pythonfmu's stock build (SHA-256 cdcdcdcdcdcd), not "
        "flexure's corrected one: asked; a NULL state handle or a freed instance crashes the "
        "host (docs/fmu.md)")
    (resources / RECORD).write_text("not json")
    assert binary_note(str(resources)) is None


# -- in fmpy: what the stock binary crashed on -------------------------------------------------


def test_null_state_handles_answer_error_and_the_instance_goes_on(fmus):
    """fmi2SetFMUstate(NULL), fmi2SerializedFMUstateSize(NULL) and every other NULL a state
    call can be given: fmi2Error with a log line (the stock binary: Fatal, then SIGSEGV)."""
    result = run("null_handles", fmus).survived()
    for function, count in [("fmi2SetFMUstate", 1), ("fmi2SerializedFMUstateSize", 2),
                            ("fmi2SerializeFMUstate", 2), ("fmi2GetFMUstate", 1),
                            ("fmi2DeSerializeFMUstate", 2)]:
        assert result.calls(function) == ["ERROR"] * count, function
    logs = result.logs()
    for message in ["fmi2SetFMUstate: the state is NULL",
                    "fmi2SerializedFMUstateSize: the state is NULL",
                    "fmi2SerializeFMUstate: the state is NULL",
                    "fmi2GetFMUstate: the pointer to the state is NULL",
                    "fmi2SerializedFMUstateSize: the pointer to the size is NULL",
                    "fmi2SerializeFMUstate: the byte array is NULL",
                    "fmi2DeSerializeFMUstate: the pointer to the state is NULL",
                    "fmi2DeSerializeFMUstate: the byte array is NULL"]:
        assert message in logs, (message, logs)
    assert result.value("handle-null") == "True"
    assert result.value("unchanged") == "True" and result.value("steps-on") == "OK"


def test_a_freed_state_handle_is_null_and_refused(fmus):
    """fmi2FreeFMUstate sets the host's handle to NULL, so setting or sizing it again is
    refused with fmi2Error."""
    result = run("set_freed_state", fmus).survived()
    assert result.value("handle-null") == "True"
    assert result.calls("fmi2FreeFMUstate") == ["OK"]
    assert result.calls("fmi2SetFMUstate") == ["ERROR"]
    assert result.calls("fmi2SerializedFMUstateSize") == ["ERROR"]
    assert "fmi2SetFMUstate: the state is NULL" in result.logs()
    assert result.value("unchanged") == "True" and result.value("steps-on") == "OK"


def test_serialize_copies_the_state_and_refuses_a_short_array(fmus):
    result = run("serialize_sizes", fmus).survived()
    assert result.calls("fmi2SerializeFMUstate") == ["ERROR", "OK"]
    assert any(re.fullmatch(r"fmi2SerializeFMUstate: the state has (\d+) bytes, the array "
                            r"given \d+ \(fmi2SerializedFMUstateSize says how many\)", m)
               for m in result.logs()), result.logs()
    assert result.value("short-untouched") == "True"
    assert result.value("long-holds-the-state") == "True"
    assert result.value("steps-on") == "OK"


def test_a_freed_instance_answers_error(fmus):
    """A second fmi2FreeInstance is ignored, a call with the freed or a NULL instance answers
    fmi2Error (the stock binary: SIGABRT or SIGSEGV), and a new instance works."""
    result = run("freed_instance", fmus).survived()
    assert "VALUE second-free-done" in result.lines
    assert result.calls("fmi2DoStep") == ["OK", "ERROR", "OK"]
    assert result.calls("fmi2GetReal") == ["ERROR"]
    assert result.calls("fmi2SetFMUstate") == ["ERROR"]
    assert result.value("new-instance-steps") == "OK"


# -- a plain pythonfmu slave whose Python raises -------------------------------------------------

RAISER = '''
import os

from pythonfmu import Fmi2Causality, Fmi2Slave, Real


def _raise_in(where):
    if os.environ.get("RAISE_IN") == where:
        raise RuntimeError(f"{where} broken on purpose")


class Raiser(Fmi2Slave):
    """Steps x by h; raises in the call that RAISE_IN names."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.x = 0.0
        self.register_variable(Real("x", causality=Fmi2Causality.output))

    def do_step(self, t, h):
        _raise_in("do_step")
        self.x = t + h
        return True

    def _get_fmu_state(self):
        _raise_in("get")
        return super()._get_fmu_state()

    def _set_fmu_state(self, state):
        _raise_in("set")
        return super()._set_fmu_state(state)

    def _last_successful_time(self):
        _raise_in("time")
        return "soon" if os.environ.get("RAISE_IN") == "not-a-time" else self.x

    @staticmethod
    def _fmu_state_to_bytes(state):
        if os.environ.get("RAISE_IN") == "size":
            return "not bytes"
        _raise_in("serialize")
        return Fmi2Slave._fmu_state_to_bytes(state)

    @staticmethod
    def _fmu_state_from_bytes(data):
        _raise_in("deserialize")
        return Fmi2Slave._fmu_state_from_bytes(data)
'''


@pytest.fixture(scope="module")
def raiser(tmp_path_factory):
    """The extracted Raiser FMU (no flexure bundled: the host's flexure serves it)."""
    from fmpy import extract

    folder = tmp_path_factory.mktemp("raiser")
    script = folder / "Raiser.py"
    script.write_text(RAISER)
    path = build_slave_fmu(script, folder, bundle=())
    return extract(str(path), unzipdir=str(folder / "Raiser"))


def test_a_python_exception_in_a_state_call_is_an_error_the_instance_survives(raiser):
    result = run("raising_state_calls", (raiser, raiser)).survived()
    assert result.calls("fmi2GetFMUstate") == ["ERROR"]
    assert result.calls("fmi2SetFMUstate") == ["ERROR"] * 3
    assert result.calls("fmi2SerializedFMUstateSize") == ["ERROR"]
    assert result.calls("fmi2SerializeFMUstate") == ["ERROR"]
    assert result.calls("fmi2DeSerializeFMUstate") == ["ERROR"]
    for where in ("get", "set", "time", "not-a-time", "size", "serialize", "deserialize"):
        assert result.value(f"steps-after-{where}") == "OK", where
    logs = " | ".join(result.logs())
    for message in ["Py exception encountered: [_get_fmu_state] PyObject_CallMethod | "
                    "RuntimeError('get broken on purpose')",
                    "[_set_fmu_state] PyObject_CallMethod | RuntimeError('set broken",
                    "fmi2SetFMUstate: the state is restored, but _last_successful_time failed "
                    "| RuntimeError('time broken on purpose')",
                    "the state is restored, but _last_successful_time is not a number | "
                    "'must be real number, not str'",
                    "[SerializedFMUstateSize] PyBytes_Size | 'expected bytes, str found'",
                    "[SerializeFMUstate] PyObject_CallMethod | RuntimeError('serialize broken",
                    "[DeSerializeFMUstate] PyObject_CallMethod | RuntimeError('deserialize"]:
        assert message in logs, (message, logs)
    assert "Fatal" not in logs


def test_after_a_fatal_error_later_calls_answer_fatal_not_a_crash(raiser):
    """A Python exception in doStep is still fmi2Fatal (pythonfmu's answer), but the calls
    after it answer fmi2Fatal again instead of running on released objects, and freeing the
    instance is clean (the stock binary: SIGSEGV, or a corrupted heap at exit)."""
    result = run("raising_step", (raiser, raiser))
    assert result.code == 0 and result.lines[-1] == "SURVIVED", result.out + result.err
    assert result.calls("fmi2DoStep") == ["FATAL", "FATAL"]
    assert result.calls("fmi2GetReal") == ["FATAL"]
    assert result.calls("fmi2Reset") == ["FATAL"]
    assert "VALUE freed" in result.lines
    logs = result.logs()
    assert logs[0].startswith("Fatal py exception encountered: [doStep]") and \
        "do_step broken on purpose" in logs[0]
    assert any("the instance was released after fmi2Fatal" in m for m in logs)
    assert "corrupted" not in result.err and "double free" not in result.err


@pytest.mark.parametrize("python, uname, message", [
    ("/bin/false", None, "build.sh: /bin/false cannot say where its headers are: give a "
                         "Python 3"),
    ("FAKE", None, "build.sh: no Python.h in /nonexistent/include: install the Python headers "
                   "(python3-dev)"),
    ("python3", "Darwin arm64", "build.sh: Darwin arm64 is not a platform this script builds "
                                "(only Linux x86_64); FMUs keep pythonfmu's stock binary there"),
])
def test_the_build_script_refuses_what_it_cannot_build(tmp_path, python, uname, message):
    """build.sh stops before building, saying why: a Python that cannot run, one without
    headers, another platform (the real build: fmu/native/build.sh, a minute of CPU)."""
    (tmp_path / "FAKE").write_text("#!/bin/sh\necho /nonexistent/include\n")
    if uname:
        (tmp_path / "uname").write_text(
            f"#!/bin/sh\ncase $1 in -s) echo {uname.split()[0]};; -m) echo {uname.split()[1]};; "
            "esac\n")
    for fake in tmp_path.iterdir():
        fake.chmod(0o755)
    done = children.run(["sh", str(BUILD_SCRIPT),
                         str(tmp_path / "FAKE") if python == "FAKE" else python],
                        capture_output=True, text=True,
                        env=dict(os.environ, PATH=f"{tmp_path}:{os.environ['PATH']}"))
    assert done.returncode == 1 and done.stderr.strip() == message, done.stderr
    assert not (tmp_path / "linux64").exists()
