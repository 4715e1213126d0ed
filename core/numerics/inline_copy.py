"""numba's inliner copies a function's scope once per function, not once per block.

numba inlines a kernel declared `inline="always"` (flexure's one-line accessors and kernels
of few call sites, docs/benchmarks.md) by copying the callee's IR at every call site, twice
(`InlineWorker.inline_ir`'s `copy_ir`: one copy to splice in, one kept unchanged). It copies
block by block, each with `copy.deepcopy` and a fresh memo, and every variable of a block
refers to the function's one scope, which holds every variable of the function: so each block
copies the whole scope again, and a copy costs blocks x variables. On an empty cache the
first `flexure loop` spent 3.2 s of CPU in these copies.

`install` gives the blocks of one `copy_ir` call one memo: the scope is copied once and all
the copied blocks share it, as the original blocks share theirs (numba's inliner checks that
a callee has one scope; it compared the per-block copies by value). Everything else is
copied as before. Only `copy_ir`'s calls are changed (recognised by the caller's code object
name), and where numba's module lacks what this relies on, nothing is (`install` returns
False).
"""

import copy
import functools
import sys
import types


class _BlockCopies:
    """`copy.deepcopy` for numba's inliner: the blocks that one `copy_ir` call copies share
    a memo (the call is recognised by its frame; the frame is kept until the next call, so a
    new call cannot reuse its identity)."""

    def __init__(self, block_class):
        self.block_class = block_class
        self.frame = self.memo = None

    def deepcopy(self, value, memo=None):
        if memo is not None or not isinstance(value, self.block_class):
            return copy.deepcopy(value, memo)
        caller = sys._getframe(1)
        if caller.f_code.co_name != "copy_ir":
            return copy.deepcopy(value)
        if caller is not self.frame:
            self.frame, self.memo = caller, {}
        return copy.deepcopy(value, self.memo)


@functools.cache
def install():
    """Make numba's inliner copy a callee's blocks with one memo per copy (once per process).
    Returns whether it could."""
    from numba.core import inline_closurecall, ir

    if getattr(inline_closurecall, "copy", None) is not copy or not hasattr(ir, "Block"):
        return False
    copies = _BlockCopies(ir.Block)
    module = types.ModuleType("copy", "the copy module, with blocks copied as inline_copy says")
    module.__dict__.update({name: getattr(copy, name) for name in copy.__all__})
    module.deepcopy = copies.deepcopy
    inline_closurecall.copy = module
    return True
