"""numba's inliner: a callee's IR made once per function, and copied at the cost of one copy.

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
name).

numba also makes the callee's IR afresh at every call site (`InlineWorker.inline_function`
runs the bytecode translation and the untyped pipeline each time: 77 times for 37 functions in
the first loop, 1.5 s). The IR depends only on the function, the pipeline, the contexts, the
declared locals and the flags, and `inline_ir` copies it before it changes anything, so
`install` keeps it, keyed by all of these, for flexure's own kernels (`IR_OF`); others are
made as numba makes them. Where numba's module lacks what this relies on, nothing is changed
(`install` returns False).
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


# the untyped IR of flexure's inlined kernels, by (function, SSA, flags, pipeline, contexts,
# locals): made once per process
IR_OF = {}


def _ir_made_once(run_untyped_passes, package):
    """numba's `InlineWorker.run_untyped_passes`, kept per function for functions of the
    package `package` (module name prefix)."""

    @functools.wraps(run_untyped_passes)
    def made_once(self, func, enable_ssa=False):
        if not getattr(func, "__module__", "").startswith(package):
            return run_untyped_passes(self, func, enable_ssa)
        self.flags.enable_ssa = enable_ssa  # as numba's does, for the caller's flags
        try:
            key = (func, enable_ssa, self.flags.copy(), self._compiler_pipeline,
                   self.typingctx, self.targetctx, frozenset(self.locals.items()))
            hash(key)
        except TypeError:  # an unhashable local or flag: made as numba makes it
            return run_untyped_passes(self, func, enable_ssa)
        if key not in IR_OF:
            IR_OF[key] = run_untyped_passes(self, func, enable_ssa)
        return IR_OF[key]

    return made_once


@functools.cache
def install():
    """Make numba's inliner copy a callee's blocks with one memo per copy, and make a
    flexure kernel's untyped IR once (once per process). Returns whether it could."""
    from numba.core import inline_closurecall, ir

    worker = getattr(inline_closurecall, "InlineWorker", None)
    if (getattr(inline_closurecall, "copy", None) is not copy or not hasattr(ir, "Block")
            or not all(hasattr(worker, name) for name in ("run_untyped_passes",
                                                           "inline_function", "inline_ir"))):
        return False
    copies = _BlockCopies(ir.Block)
    module = types.ModuleType("copy", "the copy module, with blocks copied as inline_copy says")
    module.__dict__.update({name: getattr(copy, name) for name in copy.__all__})
    module.deepcopy = copies.deepcopy
    inline_closurecall.copy = module
    package = __name__.rsplit(".", 2)[0] + "."  # flexure.core. (or an FMU's bundled copy)
    worker.run_untyped_passes = _ir_made_once(worker.run_untyped_passes, package)
    return True
