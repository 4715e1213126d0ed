"""numba's inliner (core/numerics/inline_copy.py): a callee's scope copied once per copy, not
once per block (the copied blocks share one scope, equal to the original and apart from it;
other callers of deepcopy keep a fresh memo per call); a flexure kernel's untyped IR made once
for all its call sites, anyone else's at each; inlined kernels compute their plain formulas."""

import inspect

import numba
import numpy as np
from numba.core import inline_closurecall, ir
from numba.core.compiler import run_frontend

from flexure.core.numerics import array_tables, inline_copy, jit


def _branchy(x, n):
    total = 0.0
    for i in range(n):
        if x[i] > 0.0:
            total += x[i]
        else:
            total -= 2.0 * x[i]
    return total


def _blocks():
    function_ir = run_frontend(_branchy)
    assert len(function_ir.blocks) >= 4  # the test is about copying several blocks
    return function_ir.blocks


def _copied_blocks(blocks):
    # named as numba's own copier is, which is how the installed deepcopy recognises it
    def copy_ir(blocks):
        copied = {}
        for label, block in blocks.items():
            copied[label] = inline_closurecall.copy.deepcopy(block)
        return copied

    return copy_ir(blocks)


def test_installed_with_this_numba():
    assert jit.numba_module() is numba
    assert inline_copy.install()
    assert inline_closurecall.copy.deepcopy.__self__.__class__.__name__ == "_BlockCopies"
    # numba's copier is still the nested copy_ir that calls copy.deepcopy block by block
    source = inspect.getsource(inline_closurecall.InlineWorker.inline_ir)
    assert "def copy_ir(" in source and "copy.deepcopy(" in source


def test_the_blocks_of_one_copy_share_one_scope():
    inline_copy.install()
    blocks = _blocks()
    first, second = _copied_blocks(blocks), _copied_blocks(blocks)
    original_scope = next(iter(blocks.values())).scope
    for copied in (first, second):
        scopes = {id(block.scope) for block in copied.values()}
        assert len(scopes) == 1
        scope = next(iter(copied.values())).scope
        assert scope is not original_scope and scope == original_scope
        for label, block in copied.items():
            assert block is not blocks[label]
            assert [str(i) for i in block.body] == [str(i) for i in blocks[label].body]
    # two copies (two call sites) share nothing
    assert next(iter(first.values())).scope is not next(iter(second.values())).scope


def test_other_callers_copy_as_before():
    inline_copy.install()
    blocks = _blocks()
    copies = [inline_closurecall.copy.deepcopy(block) for block in blocks.values()]
    assert len({id(block.scope) for block in copies}) == len(copies)
    assert isinstance(copies[0], ir.Block)


@jit.kernel(inline="always", cache=False)
def _clipped(v, low, high):
    if v < low:
        return low
    if v > high:
        return high
    return v


@jit.kernel(cache=False)
def _clipped_sum(a, low, high):
    s = 0.0
    for i in range(a.shape[0]):
        s += _clipped(a[i], low, high) + _clipped(2.0 * a[i], low, high)
    return s


def test_an_inlined_kernel_computes_its_formula():
    a = np.linspace(-3.0, 3.0, 61)
    expected = np.clip(a, -1.0, 1.5).sum() + np.clip(2.0 * a, -1.0, 1.5).sum()
    assert abs(_clipped_sum(a, -1.0, 1.5) - expected) <= 1e-12 * abs(expected)


@jit.kernel(cache=False)
def _sum_of_two_table_reads(table):
    # array_tables.floats (a flexure kernel, inline="always") at two call sites
    s = 0.0
    for i in range(array_tables.floats(table, 0).size):
        s += array_tables.floats(table, 0)[i] * array_tables.floats(table, 1)[i]
    return s


def test_a_kernels_untyped_ir_is_made_once_for_its_call_sites():
    a, b = np.linspace(0.0, 1.0, 11), np.linspace(2.0, 3.0, 11)
    table = array_tables.array_table([a, b], "ff")
    floats = array_tables.floats.py_func
    for key in [key for key in inline_copy.IR_OF if key[0] is floats]:
        del inline_copy.IR_OF[key]  # made by other tests' compilations in this process
    assert abs(_sum_of_two_table_reads(table) - a @ b) <= 1e-12 * abs(a @ b)
    made = [key for key in inline_copy.IR_OF if key[0] is floats]
    assert len(made) == 1  # three call sites, one untyped pipeline
    # a function of anyone else's (here the tests') is made at each call site, as numba does
    assert not [key for key in inline_copy.IR_OF if key[0] is _clipped.py_func]
