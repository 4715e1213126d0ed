"""`sparse_lu.factor` as a C entry point, for the symbolic analysis that runs in Python.

Why an entry: packing a model whose J or augmented system is sparse (`engine.sparse_packing`:
the manipulators, large cantilevers) factors each candidate ordering once from Python
(`StaticLU`). Called as a kernel, that call imports numba and loads numba's dispatcher
(0.3 to 0.7 s of a process's CPU); as a C entry, a process whose cache holds the object code
calls it through ctypes without numba (`object_code`), as it calls the engine's operations.
"""

from .jit import entry
from .native import address_of, as_float_pointer, as_int_pointer, carray, float_address, int_address
from .sparse_lu import factor


@entry("float64(voidptr, int64, voidptr, int64, float64)")
def factor_entry(ints, n_ints, floats, n_floats, threshold):
    """`sparse_lu.factor` on the packed arrays at the addresses given (int64 (n_ints,),
    float64 (n_floats,)); its pivot ratio, REJECTED or CAPACITY."""
    return factor(carray(as_int_pointer(address_of(ints)), (n_ints,)),
                  carray(as_float_pointer(address_of(floats)), (n_floats,)), threshold)


def factor_now(ints, floats, threshold):
    """`sparse_lu.factor` from Python through its C entry: ints (int64) and floats (float64)
    C-contiguous, changed in place as the kernel changes them; the pivot ratio (or REJECTED,
    CAPACITY: `sparse_lu`)."""
    return float(factor_entry.ctypes(int_address(ints), ints.size, float_address(floats),
                                     floats.size, float(threshold)))
