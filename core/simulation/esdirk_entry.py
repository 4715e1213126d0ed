"""The ESDIRK's `advance` as a C entry point, which Python and the compiled loop both call.

Why an entry: numba links a callee's compiled code into every caller and optimises and
generates its machine code again there. `esdirk_kernels.advance` (with its stages, Newton matrix and
initial step) was compiled once for Python's `Esdirk.advance` and a second time inside the
sampled loop's `_loop_esdirk`; as one C function, compiled once, the loop calls it through
its address (as the engine's operations call each other: `engine.operations`), and Python
through ctypes. The first `flexure loop` compiles about 1.5 s of CPU less; the call by address
costs nanoseconds per sample.

The entry takes one int64 array of the addresses and sizes of advance's arguments
(`arguments`, in the order of the A_... constants) and t_stop (s); it returns advance's
status (`esdirk_layout.OK` or a negative code).
"""

import numpy as np

from ..numerics.jit import entry
from ..numerics.native import (
    address_of,
    as_float_pointer,
    as_int_pointer,
    carray,
    float_address,
    int_address,
)
from . import esdirk_kernels, esdirk_layout

# the entries of the arguments array: the addresses of advance's arrays, then their sizes
(A_TABLE, A_MEMORY, A_FLAGS, A_VECTORS, A_J, A_LU, A_PIVOTS, A_ATOL, A_TABLEAU, A_EW,
 A_PREDICTOR, A_N, A_STAGES, A_SIZE) = range(14)
ADVANCE_ENTRY = "int32(voidptr, float64)"


# A module-level function, not a closure: numba keys a closure's cache entry on its cells'
# pickled contents, which differ in every process (the entry compiled at every start).
@entry(ADVANCE_ENTRY)
def advance_entry(arguments, t_stop):
    """esdirk_kernels.advance on the arrays whose addresses and sizes `arguments` holds."""
    a = carray(as_int_pointer(address_of(arguments)), (A_SIZE,))
    n, s = a[A_N], a[A_STAGES]
    return esdirk_kernels.advance(
        a[A_TABLE], carray(as_float_pointer(a[A_MEMORY]), (esdirk_layout.M_SIZE,)),
        carray(as_int_pointer(a[A_FLAGS]), (esdirk_layout.I_SIZE,)),
        carray(as_float_pointer(a[A_VECTORS]), (esdirk_layout.V_ROWS, n)),
        carray(as_float_pointer(a[A_J]), (n * n,)),
        carray(as_float_pointer(a[A_LU]), (n * n,)),
        carray(as_int_pointer(a[A_PIVOTS]), (n,)),
        carray(as_float_pointer(a[A_ATOL]), (n,)),
        carray(as_float_pointer(a[A_TABLEAU]), (s, s)),
        carray(as_float_pointer(a[A_EW]), (s,)),
        carray(as_float_pointer(a[A_PREDICTOR]), (s, s)), t_stop)


def arguments(address, memory, flags, vectors, J, LU, pivots, atol, tables):
    """The int64 arguments array of `advance_entry` for a packed model's table `address` and
    the integrator's arrays (C-contiguous; kept alive by the caller as long as the array is
    used): memory (M_SIZE,), flags (I_SIZE,), vectors (V_ROWS, n), J, LU (n n,), pivots (n,),
    atol (n,), tables the tableau's (A (s, s), b - b_hat (s,), predictor (s, s))."""
    arrays = (memory, flags, vectors, J, LU, pivots, atol, *tables)
    for array in arrays:
        if not array.flags.c_contiguous:
            raise TypeError("the integrator's arrays must be C-contiguous")
    out = np.zeros(A_SIZE, dtype=np.int64)
    out[A_TABLE] = address
    out[A_MEMORY: A_PREDICTOR + 1] = [array.ctypes.data for array in arrays]
    out[A_N], out[A_STAGES] = pivots.size, tables[0].shape[0]
    return out


@entry("void(int64, voidptr, voidptr, float64, int64)")
def _restart_entry(table, memory, flags, t, inputs_only):
    """`esdirk_kernels.restart` as a C entry, the arrays by address."""
    esdirk_kernels.restart(table, carray(as_float_pointer(memory), (esdirk_layout.M_SIZE,)),
                   carray(as_int_pointer(flags), (esdirk_layout.I_SIZE,)), t, inputs_only != 0)


def restart_now(table, memory, flags, t, inputs_only):
    """`esdirk_kernels.restart` from Python (through its C entry: a process that loads compiled code
    from the cache calls it without numba); memory (M_SIZE,) float64, flags (I_SIZE,) int64."""
    if memory.size != esdirk_layout.M_SIZE or flags.size != esdirk_layout.I_SIZE:
        raise ValueError(f"esdirk restart: memory of {memory.size} and flags of {flags.size} "
                         f"entries, not {esdirk_layout.M_SIZE} and {esdirk_layout.I_SIZE}")
    _restart_entry.ctypes(table, float_address(memory), int_address(flags), float(t),
                          int(bool(inputs_only)))
