"""Entry points loaded as object code without numba (core/numerics/object_code.py): the
loader's checks on small objects that llvmlite compiles here, its CPU target against numba's
own, a simulation through loaded code against the same through numba, bit for bit; and the
tables through which Python hands a C entry its arrays (core/numerics/array_tables.py)."""

import ctypes
import json
import os
import sys

import children
import numpy as np
import pytest

from flexure.core.numerics import object_code
from flexure.core.numerics.array_tables import array_table

ANSWER = """
define double @answer(double %x) {
  %y = fadd double %x, 40.0
  ret double %y
}
"""
MISSING = """
declare double @flexure_test_missing_symbol(double)
define double @calls_missing(double %x) {
  %y = call double @flexure_test_missing_symbol(double %x)
  ret double %y
}
"""


def _object(ir_text):
    """An ELF object of the LLVM IR, compiled for this process's target."""
    ll = object_code.llvm_binding()
    module = ll.parse_assembly(ir_text)
    triple, cpu, features = object_code.code_target()
    module.triple = triple
    machine = ll.Target.from_triple(triple).create_target_machine(
        cpu=cpu, features=features, reloc="static", codemodel="jitdefault")
    return machine.emit_object(module)


@pytest.fixture
def entry_file(tmp_path, monkeypatch):
    """The object-code file every function is filed under in the test."""
    path = tmp_path / "entry.fxo"
    monkeypatch.setattr(object_code, "file_of", lambda function: str(path))
    monkeypatch.delenv("FLEXURE_OBJECT_CODE", raising=False)
    return path


def test_the_undefined_symbols_are_what_the_object_calls_but_does_not_define():
    assert object_code.undefined_symbols(_object(ANSWER)) == set()
    assert object_code.undefined_symbols(_object(ANSWER + MISSING)) == {
        "flexure_test_missing_symbol"}


def test_an_object_that_is_not_elf_is_refused():
    with pytest.raises(ValueError, match="ELF"):
        object_code.undefined_symbols(b"MZ\x90\x00" + bytes(60))


def test_a_written_file_loads_and_its_function_runs(entry_file):
    object_code.write(str(entry_file), _object(ANSWER), "answer")
    address = object_code.load(test_a_written_file_loads_and_its_function_runs)
    assert address
    assert ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_double)(address)(2.0) == 42.0


def _corrupt(path):
    header, code = path.read_bytes().split(b"\n", 1)
    path.write_bytes(header + b"\n" + code[:-1] + bytes([code[-1] ^ 1]))


def _other_target(path):
    header, code = path.read_bytes().split(b"\n", 1)
    described = json.loads(header)
    described["target"] = "0" * 16
    path.write_bytes(json.dumps(described).encode() + b"\n" + code)


@pytest.mark.parametrize("spoil", [
    pytest.param(_corrupt, id="a changed byte"),
    pytest.param(_other_target, id="another CPU target"),
    pytest.param(lambda path: path.write_bytes(b"not json\n" + bytes(8)), id="no header"),
    pytest.param(lambda path: path.unlink(), id="no file"),
])
def test_a_file_that_does_not_match_is_not_loaded(entry_file, spoil):
    object_code.write(str(entry_file), _object(ANSWER), "answer")
    spoil(entry_file)
    assert object_code.load(test_a_file_that_does_not_match_is_not_loaded) is None


def test_an_object_with_an_unresolved_symbol_is_not_loaded(entry_file):
    # LLVM's loader would leave a null call in its place without a word
    object_code.write(str(entry_file), _object(MISSING), "calls_missing")
    assert object_code.load(test_an_object_with_an_unresolved_symbol_is_not_loaded) is None


def test_the_switch_and_numba_settings_turn_the_loading_off(entry_file, monkeypatch):
    object_code.write(str(entry_file), _object(ANSWER), "answer")
    monkeypatch.setenv("FLEXURE_OBJECT_CODE", "0")
    assert not object_code.enabled()
    assert object_code.load(test_the_switch_and_numba_settings_turn_the_loading_off) is None
    monkeypatch.delenv("FLEXURE_OBJECT_CODE")
    monkeypatch.setenv("NUMBA_OPT", "1")  # code this module cannot vouch for
    assert not object_code.enabled()


TARGETS = """
import json, sys
from flexure.core.numerics import object_code
from numba.core.registry import cpu_target
print(json.dumps([list(object_code.code_target()),
                  list(cpu_target.target_context.codegen().magic_tuple())]))
"""


@pytest.mark.parametrize("cpu", [None, "generic"])
def test_the_code_target_is_numbas_own(cpu):
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CPU")}
    if cpu:
        env["NUMBA_CPU_NAME"] = cpu
    ours, numbas = json.loads(children.run([sys.executable, "-c", TARGETS], env=env,
                                           capture_output=True, text=True,
                                           check=True).stdout)
    assert ours == numbas


RUN = """
import sys
from flexure.core.cli import main
from flexure.core.engine import engine
sys.argv = ["flexure", "simulate", "stage_planar_3dof", "--t-end", "0.004", "--input", "F=1",
            "--method", sys.argv[1], "--out", sys.argv[2]]
main()
used = [e for e in set(engine.ENTRIES) if e.is_compiled]
print("LOADED", all(e._compiled is None for e in used), len(used))
"""


# CVODE's and IDA's runs in the slow tier (1.2 s of CPU each): in the default tier the esdirk
# run checks the loaded entries against numba's bit for bit, and tests/test_startup.py that a
# warm CVODE or IDA simulation runs on loaded code without importing numba
@pytest.mark.parametrize("method", [pytest.param("cvode-bdf", marks=pytest.mark.slow),
                                    pytest.param("ida", marks=pytest.mark.slow), "esdirk"])
def test_a_simulation_through_loaded_code_is_numbas_bit_for_bit(tmp_path, method):
    def run(name, **env):
        out = tmp_path / f"{name}.csv"
        result = children.run([sys.executable, "-c", RUN, method, str(out)],
                              env={**os.environ, **env}, capture_output=True, text=True,
                              check=True)
        return out.read_bytes(), result.stdout.split("LOADED ")[1].split()

    # The first run loads through numba where no file is there yet, and writes them; where
    # it found them all (it loaded every entry as object code) it is the loaded run itself.
    loaded, (all_loaded, count) = run("first")
    if all_loaded != "True":
        loaded, (all_loaded, count) = run("loaded")
    through_numba, (none_loaded, _) = run("numba", FLEXURE_OBJECT_CODE="0")
    assert all_loaded == "True" and int(count) >= 8
    assert none_loaded == "False"
    assert loaded == through_numba  # the same machine code: the same numbers


def test_an_array_table_holds_each_arrays_address_and_shape():
    floats, matrix, ints = np.arange(3.0), np.ones((2, 5)), np.arange(4, dtype=np.int64)
    table = array_table((floats, matrix, ints), "fFi")
    assert table.tolist() == [floats.ctypes.data, 3, 0, matrix.ctypes.data, 2, 5,
                              ints.ctypes.data, 4, 0]


@pytest.mark.parametrize("array, kind", [
    pytest.param(np.arange(3), "f", id="int64 for float64"),
    pytest.param(np.ones((2, 2)), "f", id="2-D for 1-D"),
    pytest.param(np.ones((4, 4))[:, 1], "f", id="strided"),
    pytest.param(np.ones(3, dtype=np.float32), "f", id="float32"),
])
def test_an_array_table_refuses_an_array_of_another_kind(array, kind):
    with pytest.raises(TypeError, match="array 0 is"):
        array_table((array,), kind)


MIXED = """
import sys
import numpy as np
from flexure.core import Simulator, load_scene
from flexure.core.simulation import esdirk_layout, esdirk_newton

def final(method):
    sim = Simulator(load_scene("stage_planar_3dof"), method=method, rtol=1e-8)
    sim.set_inputs([1.0])
    sim.advance_to(0.004)
    return sim.outputs()[0]

first = final("cvode-bdf")
if sys.argv[1] == "mixed":  # numba now imported and loading a kernel beside the object code
    flags = np.zeros(esdirk_layout.I_SIZE, dtype=np.int64)
    assert esdirk_newton.factor(2.0 * np.eye(2).ravel(), np.zeros(4),
                                 np.zeros(2, dtype=np.int64), 0.1, flags)
    assert "numba" in sys.modules
print(repr(first), repr(final("ida")))
"""


def test_numba_imported_after_loaded_object_code_runs_beside_it():
    """A process that loaded entries as object code and then imports numba (a kernel called
    from Python) keeps one runtime: later simulations there give the numbers of a process
    that loaded everything through numba."""
    def run(mode, **env):
        return children.run([sys.executable, "-c", MIXED, mode], env={**os.environ, **env},
                            capture_output=True, text=True, check=True).stdout.split()

    run("plain")  # the object code written
    assert run("mixed") == run("plain", FLEXURE_OBJECT_CODE="0")
