"""FMU under careless or hostile hosts: each abuse case runs in a subprocess of its own.

Each abuse case (fmu_abuse_cases.py) runs in a subprocess of its own, in fmpy, and prints one
line per event: each FMI call with its status, each message the FMU logs, the values it
observed, and "SURVIVED" when it ran to its end. The tests assert on its exit code and output
(fmu_abuse_runs.py), so a crash is observed, not suffered. Memory and the freeing of
instances: test_fmu_memory.py.

What pythonfmu 0.7.0's C layer allows (see flexure.fmu.slave): only doStep can answer
anything but fmi2OK without fmi2Fatal, so refused calls answer fmi2OK with a log line at
status error (3), and a refused setter or parameter puts the instance into the error state,
seen as fmi2Discard at the next doStep. flexure's corrected build of the binary (fmu/native,
test_fmu_native.py) also answers a refused state with fmi2Error, and a NULL state handle or a
freed instance; with pythonfmu's stock binary, the fallback (`stock_fmus`), those crash the
host, as the cases marked "stock" show (docs/fmu.md's datasheet).
"""

import re
import signal
from pathlib import Path

import pytest
from fmu_abuse_runs import refused_then_unchanged, run

pytestmark = pytest.mark.slow  # the slow tier (each case in its own host process); .ci/run runs it


def test_crafted_pickle_state_runs_nothing(fmus, tmp_path):
    marker = tmp_path / "pwned"
    result = run("pickle_state", fmus, env={"ABUSE_MARKER": str(marker)}).survived()
    assert not marker.exists() and result.value("marker-exists") == "False"
    refused_then_unchanged(result, r"not a flexure FMU state \(it starts with b'\\x80")


def test_no_pickle_in_the_state_path():
    sources = Path(__file__).resolve().parents[1] / "fmu"
    for name in ("slave.py", "scene_slave.py", "state_format.py"):
        text = (sources / name).read_text()
        assert not re.search(r"^\s*(import|from)\s+(c?pickle|marshal|shelve|dill)\b", text,
                             re.MULTILINE), name
        assert "eval(" not in text and "exec(" not in text, name


def test_flipped_byte_is_refused_by_the_checksum(fmus):
    result = run("flipped_byte", fmus).survived()
    refused_then_unchanged(result, "checksum mismatch")
    assert len(result.calls("fmi2SetFMUstate")) == 3


def test_a_refused_state_answers_ok_with_the_stock_binary(stock_fmus):
    """The fallback ignores the slave's refusal: fmi2OK, the reason logged all the same."""
    refused_then_unchanged(run("flipped_byte", stock_fmus).survived(), "checksum mismatch",
                           answer="OK")


def test_truncated_state_is_refused(fmus):
    result = run("truncated_state", fmus).survived()
    refused_then_unchanged(result, r"truncated: \d+ bytes")
    assert len(result.calls("fmi2SetFMUstate")) == 4


def test_empty_state_is_refused(fmus):
    refused_then_unchanged(run("empty_state", fmus).survived(), "empty: no bytes given")


def test_garbage_state_is_refused(fmus):
    result = run("garbage_state", fmus).survived()
    refused_then_unchanged(result, "not a flexure FMU state|state format version")
    assert any("state format version" in m for m in result.logs())  # magic, then garbage


def test_state_of_another_scene_is_refused_by_name(fmus):
    result = run("other_scene_state", fmus).survived()
    refused_then_unchanged(result, r"the state is of 'truss_1dof_x' \(build [0-9a-f]{12}\); "
                                   r"this FMU is 'stage_planar_3dof'")


def test_valid_state_still_restores_in_another_instance(fmus):
    assert run("state_round_trip", fmus).survived().value("same") == "True"


# -- values ------------------------------------------------------------------------------------


def test_unknown_value_reference(fmus):
    """Reads answer NaN with an error log (three in a row: once two Fatals and a SIGSEGV); a
    write enters the error state: doStep answers Discard until fmi2Reset."""
    result = run("unknown_vr", fmus).survived()
    assert result.calls("fmi2GetReal").count("OK") == len(result.calls("fmi2GetReal"))
    assert [line for line in result.lines if line.startswith("VALUE read")] == \
        ["VALUE read [nan]"] * 3
    logs = result.logs()
    assert sum("fmi2GetReal: unknown value reference 99999" in m for m in logs) == 3
    assert any("fmi2GetString: 'x' (value reference 1) is a Real, not a String" in m
               for m in logs)
    assert result.value("unchanged") == "True" and result.value("steps-on") == "OK"
    assert any("fmi2SetReal refused: unknown value reference 99999" in m for m in logs)
    assert result.value("after-set") == "DISCARD"
    assert any(m.startswith("a: step refused: fmi2SetReal refused") for m in logs)
    assert result.value("after-reset") == "OK"


def test_set_real_on_an_output_is_refused(fmus):
    result = run("set_output", fmus).survived()
    assert result.calls("fmi2SetReal") == ["OK"]
    assert any("'x' (value reference 1) is an output: it cannot be set" in m
               for m in result.logs())
    assert result.value("unchanged") == "True"
    assert result.value("after-set") == "DISCARD"


def test_invalid_and_late_parameters_are_refused(fmus):
    result = run("bad_parameters", fmus).survived()
    logs = " ".join(result.logs())
    assert "integrator.atol = -1.0: expected a finite number >= 0" in logs
    assert "integrator.rtol = 0.0: expected a finite number in (0, 1)" in logs
    assert "integrator.rtol = nan" in logs
    assert "'integrator.rtol' (value reference 4) is a fixed parameter" in logs
    for key in ("integrator.atol -1.0", "integrator.rtol 0.0", "integrator.rtol nan", "late"):
        assert result.value(key) == "DISCARD", key


# -- the call sequence ----------------------------------------------------------------------


def test_do_step_before_initialization_is_refused(fmus):
    result = run("step_before_init", fmus).survived()
    assert result.calls("fmi2DoStep") == ["DISCARD"] * 3 + ["OK"]
    illegal = [m for m in result.logs() if "illegal call sequence" in m]
    assert [m.split(";")[0] for m in illegal] == [
        "a: fmi2DoStep: illegal call sequence: the instance is in state instantiated",
        "a: fmi2DoStep: illegal call sequence: the instance is in state instantiated",
        "a: fmi2DoStep: illegal call sequence: the instance is in state initialization mode",
        "a: fmi2SetupExperiment: illegal call sequence: the instance is in state "
        "initialization mode"]


def test_do_step_after_terminate_is_refused(fmus):
    result = run("step_after_terminate", fmus).survived()
    assert result.calls("fmi2DoStep") == ["OK", "DISCARD"]
    logs = result.logs()
    assert any("fmi2DoStep: illegal call sequence: the instance is in state terminated" in m
               for m in logs)
    assert any("fmi2Terminate: illegal call sequence" in m for m in logs)
    assert result.value("read") == "True"


def test_what_used_to_be_fatal_is_survivable(fmus):
    result = run("fatal_history", fmus).survived()
    assert result.calls("fmi2DoStep") == ["OK"] * 3


# -- instances in one process ---------------------------------------------------------------


def test_ten_instances_in_one_process(fmus):
    assert run("many_instances", fmus).survived().value("freed") == "10"


def test_interleaved_instances_of_two_scenes(fmus):
    result = run("interleaved", fmus).survived()
    assert result.calls("fmi2DoStep") == ["OK"] * 16
    refusals = [m for m in result.logs() if "fmi2SetFMUstate refused" in m]
    assert len(refusals) == 1 and refusals[0].startswith("c: ")  # a's state in b is fine


# -- what only pythonfmu's C layer can answer --------------------------------------------


def test_double_free_is_ignored(fmus):
    """The corrected binary knows its live instances: a second free is ignored."""
    result = run("double_free", fmus).survived()
    assert "VALUE second-free-done" in result.lines


def test_double_free_crashes_with_the_stock_binary(stock_fmus):
    """Stock fmi2FreeInstance deletes the C++ component without calling Python: a second free
    is a double delete the FMU's Python side never sees. Observed: the host dies in that
    call."""
    result = run("double_free", stock_fmus)
    assert "VALUE first-free-done" in result.lines
    assert "VALUE second-free-done" not in result.lines
    assert result.code < 0, (result.code, result.out[-2000:], result.err[-2000:])
    assert -result.code in (signal.SIGABRT, signal.SIGSEGV, signal.SIGBUS)


def test_step_after_free_answers_error(fmus):
    result = run("step_after_free", fmus).survived()
    assert result.calls("fmi2DoStep") == ["OK", "ERROR"]


def test_step_after_free_crashes_with_the_stock_binary(stock_fmus):
    """Stock fmi2DoStep on a freed component dereferences freed C++ memory before any Python
    runs."""
    result = run("step_after_free", stock_fmus)
    assert "VALUE free-done" in result.lines and "SURVIVED" not in result.lines
    assert result.code < 0 and -result.code in (signal.SIGSEGV, signal.SIGABRT, signal.SIGBUS)


# -- invalid state handles ------------------------------------------------------------------


def test_a_freed_state_handle_is_refused_not_a_crash_with_the_stock_binary(stock_fmus):
    """Stock fmi2FreeFMUstate leaves the host's handle as it was: the FMU keeps the freed
    handle's object valid, so setting it is refused by name (it was SIGSEGV) and its
    serialized size is 0. (The corrected binary NULLs the handle: test_fmu_native.py.)"""
    result = run("set_freed_state", stock_fmus).survived()
    assert result.value("handle-null") == "False"  # the binary does not NULL it
    assert result.calls("fmi2SetFMUstate") == ["OK"]
    assert result.calls("fmi2SerializedFMUstateSize") == ["OK"]
    assert result.value("size") == "0"
    assert "a: fmi2SetFMUstate refused: the state was freed by fmi2FreeFMUstate; the " \
           "instance is unchanged" in result.logs()
    assert result.value("unchanged") == "True" and result.value("steps-on") == "OK"


@pytest.mark.parametrize("binary", ["corrected", "stock"])
def test_freeing_a_state_twice_is_survived(fmus, stock_fmus, binary):
    """A second fmi2FreeFMUstate of one handle: the corrected binary NULLed the handle at the
    first, so the second is ignored; with the stock one it only counts down the references
    the FMU keeps (it was a heap corruption at exit: "malloc(): unsorted double linked list
    corrupted")."""
    result = run("free_state_twice", fmus if binary == "corrected" else stock_fmus).survived()
    assert result.calls("fmi2FreeFMUstate") == ["OK", "OK"]
    assert result.value("steps-on") == "OK"


@pytest.mark.parametrize("binary", ["corrected", "stock"])
def test_freeing_a_null_state_is_ignored(fmus, stock_fmus, binary):
    result = run("free_null_state", fmus if binary == "corrected" else stock_fmus).survived()
    assert result.calls("fmi2FreeFMUstate") == ["OK"] and result.value("steps-on") == "OK"


@pytest.mark.parametrize("case, function", [("set_null_state", "fmi2SetFMUstate"),
                                            ("size_null_state", "fmi2SerializedFMUstateSize")])
def test_a_null_state_handle_answers_error(fmus, case, function):
    """The corrected binary refuses a NULL state before Python: fmi2Error, and the next
    doStep steps."""
    result = run(case, fmus).survived()
    assert result.calls(function) == ["ERROR"]
    assert f"{function}: the state is NULL" in result.logs()
    assert "VALUE step-done" in result.lines and result.calls("fmi2DoStep") == ["OK", "OK"]


@pytest.mark.parametrize("case, function", [("set_null_state", "fmi2SetFMUstate"),
                                            ("size_null_state", "fmi2SerializedFMUstateSize")])
def test_a_null_state_handle_crashes_with_the_stock_binary(stock_fmus, case, function):
    """Stock: a NULL state never reaches Python: the binary's Py_BuildValue refuses it, the
    binary answers fmi2Fatal, releases the instance's objects, and the next doStep runs on
    freed memory (docs/fmu.md's datasheet). Observed: Fatal, then the host dies by SIGSEGV."""
    result = run(case, stock_fmus)
    assert result.calls(function) == ["FATAL"]
    assert any("NULL object passed to Py_BuildValue" in m for m in result.logs())
    assert "SURVIVED" not in result.lines and "VALUE step-done" not in result.lines
    assert result.code < 0 and -result.code in (signal.SIGSEGV, signal.SIGABRT, signal.SIGBUS)


# -- memory ---------------------------------------------------------------------------------
