"""A kernel is compiled for linking only; an entry optimises what it links; Python calls a
kernel through code compiled as numba compiles it (core/numerics/linked_code.py). Observed
in numba's libraries and in the LLVM IR: the module pipeline is what inlines one compiled
function into another, so a kernel keeps its call to the kernel it calls, while an entry,
and numba code that is not flexure's, have it inlined."""

import ctypes
import os
import sys
import textwrap

import children
import numba
import numpy as np
import pytest

from flexure.core.numerics import dense, jit, linked_code


@jit.kernel(cache=False)  # compiled in each test process, so its IR is there to read
def _twice_plus_one(x):
    return 2.0 * x + 1.0


@jit.kernel(cache=False)
def _sum_of_twice_plus_one(a):
    s = 0.0
    for i in range(a.shape[0]):
        s += _twice_plus_one(a[i])
    return s


def _entry_function(x):
    return _twice_plus_one(x)


def _sum_entry_function(pointer, n):
    return _sum_of_twice_plus_one(numba.carray(pointer, (n,)))


@numba.njit(cache=False)
def _host_twice_plus_one(x):
    return 2.0 * x + 1.0


@numba.njit(cache=False)
def _host_sum(a):
    s = 0.0
    for i in range(a.shape[0]):
        s += _host_twice_plus_one(a[i])
    return s


def _calls(ir_text, caller, callee):
    """Whether the body of the function whose name has `caller` (not a wrapper of it) in the
    IR calls a function whose name has `callee`."""
    body = []
    inside = False
    for line in ir_text.splitlines():
        if line.startswith("define"):
            name = line.split("@", 1)[1].split("(", 1)[0]
            inside = caller in name and "cpython" not in name and "cfunc" not in name
        elif inside and line.startswith("}"):
            inside = False
        elif inside:
            body.append(line)
    assert body, f"no function named like {caller!r} in the IR"
    return any("call" in line and callee in line for line in body)


def _sum_entry(tmp_path, monkeypatch):
    # an entry outside flexure's core is cached by numba's own locators: a fresh folder, so
    # that this process compiles it and has its IR
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    entry = jit.CompiledEntry(_sum_entry_function, "float64(CPointer(float64), int64)")
    return ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_void_p, ctypes.c_int64)(
        entry.compiled.address)


def test_a_kernel_that_an_entry_calls_is_compiled_for_linking_only(tmp_path, monkeypatch):
    a = np.array([1.0, 2.0, 3.0])
    function = _sum_entry(tmp_path, monkeypatch)
    assert function(a.ctypes.data, 3) == pytest.approx(15.0, rel=1e-15)
    dispatcher = _sum_of_twice_plus_one.dispatcher
    (signature,) = dispatcher.signatures
    result = dispatcher.overloads[signature]
    library = result.library
    assert getattr(library, linked_code.MARK)
    assert not linked_code.has_function(library, result.fndesc.llvm_cpython_wrapper_name)
    # no module pipeline: the kernel keeps its call, for the entry to inline
    assert _calls(library.get_llvm_str(), "_sum_of_twice_plus_one", "_twice_plus_one")
    with pytest.raises(TypeError, match="_sum_of_twice_plus_one: compiled for linking"):
        dispatcher(a)
    assert not linked_code.COMPILING  # every compilation's frame is gone again


def test_python_calls_a_kernel_through_code_compiled_as_numba_compiles_it():
    a = np.array([1.0, 2.0, 3.0])
    assert _sum_of_twice_plus_one(a) == pytest.approx(15.0, rel=1e-15)
    python = _sum_of_twice_plus_one.python_dispatcher
    (signature,) = python.signatures
    library = python.overloads[signature].library
    assert not getattr(library, linked_code.MARK, False)
    # optimised as numba optimises: the callee inlined
    assert not _calls(library.get_llvm_str(), "_sum_of_twice_plus_one", "_twice_plus_one")


def test_the_code_python_calls_is_cached_apart_from_the_linking_only_code():
    function = dense.lu_factor.py_func
    linking, line = jit.cache_location(function, function.__code__.co_filename)
    python, same_line = jit.cache_location(linked_code.python_callable(function),
                                            function.__code__.co_filename)
    assert line == same_line and linking != python
    assert os.path.relpath(python, jit.package_cache_folder()).startswith("python-calls")


def test_numba_code_that_is_not_flexures_is_optimised_as_numba_does_it():
    a = np.array([1.0, 2.0, 3.0])
    assert _host_sum(a) == pytest.approx(15.0, rel=1e-15)
    ir = _host_sum.inspect_llvm(_host_sum.signatures[0])
    assert not _calls(ir, "_host_sum", "_host_twice_plus_one")
    assert not linked_code.COMPILING


def test_an_entry_inlines_the_kernels_it_links(tmp_path, monkeypatch):
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    entry = jit.CompiledEntry(_entry_function, "float64(float64)")
    function = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_double)(entry.compiled.address)
    assert function(3.0) == pytest.approx(7.0, rel=1e-15)
    assert not _calls(entry.compiled.inspect_llvm(), "_entry_function", "_twice_plus_one")
    assert not linked_code.COMPILING


_CACHED_KERNEL_SCRIPT = textwrap.dedent("""
    import ctypes, sys
    import numba, numpy as np
    from flexure.core.numerics import jit, linked_code

    numba.config.CACHE_DIR = sys.argv[1]

    @jit.kernel
    def triple(x):
        return 3.0 * x

    def entry_function(x):
        return triple(x) + 1.0

    entry = jit.CompiledEntry(entry_function, "float64(float64)")
    if sys.argv[2] == "load":  # the kernel from the cache; the entry compiled again
        triple.dispatcher.compile((numba.float64,))
        (signature,) = triple.dispatcher.signatures
        hits = triple.dispatcher.stats.cache_hits[signature]
        assert hits == 1, hits
        assert getattr(triple.dispatcher.overloads[signature].library, linked_code.MARK)
        with linked_code.compiling(False):
            address = numba.cfunc("float64(float64)", cache=False)(entry_function).address
    else:
        address = entry.compiled.address
    value = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_double)(address)(2.0)
    print(value, triple(2.0))
""")


@pytest.mark.slow  # 4 s, a second process; the caches' separation stays in the default tier
def test_a_kernel_compiled_for_linking_is_cached_and_loaded_as_such(tmp_path):
    script = tmp_path / "cached_kernel.py"
    script.write_text(_CACHED_KERNEL_SCRIPT)
    cache = tmp_path / "cache"
    runs = [children.run([sys.executable, str(script), str(cache), mode], capture_output=True,
                         text=True) for mode in ("compile", "load")]
    for run in runs:
        assert run.returncode == 0, run.stderr
        assert [float(v) for v in run.stdout.split()] == pytest.approx([7.0, 6.0], rel=1e-15)
