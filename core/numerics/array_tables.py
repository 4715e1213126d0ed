"""Arrays handed to a C entry as one table: for each array its address and shape.

A C entry (`jit.entry`) takes numbers and pointers only. A compiled driver that works on many
arrays (the sampled loop's fourteen of the controller and eight of the integrator) takes the
address of one int64 table instead, (address, rows, columns) per array, made here from Python
(`array_table`) and read back as arrays in compiled code (`floats`, `floats2d`, `ints`), in
the order both sides agree on. The Python side checks each array's kind; the compiled side
trusts the table.
"""

import numpy as np

from .jit import kernel
from .native import as_float_pointer, as_int_pointer, carray

_KINDS = {"f": (np.float64, 1), "F": (np.float64, 2), "i": (np.int64, 1)}


def array_table(arrays, kinds):
    """The int64 table (3 n,) of n arrays: address, rows, columns (0 for a 1-D array) each.

    Parameters
    ----------
    arrays : sequence of ndarray
        C-contiguous; they must outlive every use of the table (it points into them).
    kinds : str
        One letter per array: "f" a 1-D float64 array, "F" a 2-D float64 array, "i" a 1-D
        int64 array.

    Raises
    ------
    TypeError
        An array is not of its kind or not C-contiguous.
    """
    if len(arrays) != len(kinds):
        raise TypeError(f"array_table: {len(arrays)} arrays for {len(kinds)} kinds")
    table = np.zeros(3 * len(arrays), dtype=np.int64)
    for i, (array, kind) in enumerate(zip(arrays, kinds, strict=True)):
        dtype, ndim = _KINDS[kind]
        if not (array.dtype == dtype and array.ndim == ndim and array.flags.c_contiguous):
            raise TypeError(f"array_table: array {i} is {array.dtype.name} with {array.ndim} "
                            f"dimension(s){'' if array.flags.c_contiguous else ', strided'}, "
                            f"not a C-contiguous {np.dtype(dtype).name} array of {ndim}")
        table[3 * i] = array.ctypes.data
        table[3 * i + 1] = array.shape[0]
        table[3 * i + 2] = array.shape[1] if ndim == 2 else 0
    return table


@kernel(inline="always")
def floats(table, i):
    """Array i of the table (a "f" entry): float64 (rows,)."""
    return carray(as_float_pointer(table[3 * i]), (table[3 * i + 1],))


@kernel(inline="always")
def floats2d(table, i):
    """Array i of the table (a "F" entry): float64 (rows, columns)."""
    return carray(as_float_pointer(table[3 * i]), (table[3 * i + 1], table[3 * i + 2]))


@kernel(inline="always")
def ints(table, i):
    """Array i of the table (an "i" entry): int64 (rows,)."""
    return carray(as_int_pointer(table[3 * i]), (table[3 * i + 1],))
