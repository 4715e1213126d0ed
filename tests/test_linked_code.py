"""A kernel's own code skips LLVM's module pipelines; an entry optimises what it links
(core/numerics/linked_code.py). Observed in the LLVM IR: the module pipeline is what inlines
one compiled function into another, so a kernel keeps its call to the kernel it calls, while
an entry, and numba code that is not flexure's, have it inlined."""

import ctypes

import numba
import numpy as np
import pytest

from flexure.core.numerics import jit, linked_code


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


def test_a_kernel_keeps_its_calls_for_the_entry_that_links_it():
    a = np.array([1.0, 2.0, 3.0])
    assert _sum_of_twice_plus_one(a) == pytest.approx(15.0, rel=1e-15)
    ir = _sum_of_twice_plus_one.inspect_llvm(_sum_of_twice_plus_one.signatures[0])
    assert _calls(ir, "_sum_of_twice_plus_one", "_twice_plus_one")


def test_numba_code_that_is_not_flexures_is_optimised_as_numba_does_it():
    a = np.array([1.0, 2.0, 3.0])
    assert _host_sum(a) == pytest.approx(15.0, rel=1e-15)
    ir = _host_sum.inspect_llvm(_host_sum.signatures[0])
    assert not _calls(ir, "_host_sum", "_host_twice_plus_one")
    assert not linked_code._COMPILING  # every compilation's frame is gone again


def test_an_entry_inlines_the_kernels_it_links(tmp_path, monkeypatch):
    # an entry outside flexure's core is cached by numba's own locators: a fresh folder, so
    # that this process compiles it and has its IR
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    entry = jit.CompiledEntry(_entry_function, "float64(float64)")
    function = ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_double)(entry.compiled.address)
    assert function(3.0) == pytest.approx(7.0, rel=1e-15)
    assert not _calls(entry.compiled.inspect_llvm(), "_entry_function", "_twice_plus_one")
    assert not linked_code._COMPILING
