"""The processor's cycle counter for compiled code (LLVM's readcyclecounter: the TSC on x86,
a constant rate there), for timing calls inside compiled code that has no clock: `cycles()`
in numba code, `read_cycles()` from Python. Wall time, not CPU time: a caller converts with
a rate measured against perf_counter and takes medians."""

import numba
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic


@intrinsic
def cycles(typingctx):
    """The cycle counter (int64) in compiled code."""
    def codegen(context, builder, signature, args):
        function = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.IntType(64), []), "llvm.readcyclecounter")
        return builder.call(function, [])

    return types.int64(), codegen


@numba.njit
def read_cycles():
    """The cycle counter (int) from Python."""
    return cycles()
