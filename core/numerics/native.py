"""Pointer casts and C calls for compiled (numba) code: the glue between flexure's kernels and
the SUNDIALS C library.

Compiled callbacks receive SUNDIALS' vectors and our model data as raw addresses, and the
compiled sampled loop calls CVODE's C functions through their addresses. numba has no
built-in for either, so intrinsics emit the few LLVM instructions needed
(`native_intrinsics`). Every function here takes addresses as int64 arguments (never as
compile-time constants), so the compiled code that uses them can be cached on disk and reused
by any process.

Each name here is a `jit.CompiledName`: the intrinsic (or numba's `carray`) is made when numba
first types compiled code that calls it. A process that only loads compiled code from the
cache (`object_code`) so never imports numba, nor llvmlite's IR builder.

- as_float_pointer(address), as_int_pointer(address): a float64* or int64* (for `carray`);
- nvector_data(vector), dense_matrix_data(matrix): the data of a serial N_Vector or of a
  dense SUNMatrix given as void pointers;
- call_solve, call_with_time, call_reinit, call_get_real, call_get_long: CVODE's functions of
  those shapes by address;
- call_deformations, call_inertia: an element's entries (`jit.DEFORMATIONS_ENTRY`,
  `jit.INERTIA_ENTRY`) by address; call_engine(operations, op, ...): an engine operation
  through the table of their addresses; call_stepper(function, arguments, t): an
  integrator's advance entry;
- address_of(pointer): the address (int64) of a pointer;
- carray: numba.carray.

`float_address` and `int_address` give Python callers of a C entry an array's address.
"""

import numpy as np

from .jit import CompiledName

NVECTOR_DATA_OFFSET = 8  # bytes: int32 length + int32 own_data (scikit-sundae's build)


def _intrinsic(name):
    def make():
        from . import native_intrinsics

        return getattr(native_intrinsics, name)

    return CompiledName(make, name)


def _carray():
    from .jit import numba_module

    return numba_module().carray


as_float_pointer = _intrinsic("as_float_pointer")
as_int_pointer = _intrinsic("as_int_pointer")
nvector_data = _intrinsic("nvector_data")
dense_matrix_data = _intrinsic("dense_matrix_data")
call_solve = _intrinsic("call_solve")
call_with_time = _intrinsic("call_with_time")
call_reinit = _intrinsic("call_reinit")
call_get_real = _intrinsic("call_get_real")
call_get_long = _intrinsic("call_get_long")
call_deformations = _intrinsic("call_deformations")
call_inertia = _intrinsic("call_inertia")
call_engine = _intrinsic("call_engine")
call_stepper = _intrinsic("call_stepper")
address_of = _intrinsic("address_of")
carray = CompiledName(_carray, "carray")


def float_address(array):
    """The address (int) of a C-contiguous float64 array's data, for a C entry called from
    Python (ctypes)."""
    return _address(array, np.float64)


def int_address(array):
    """The address (int) of a C-contiguous int64 array's data, as `float_address`."""
    return _address(array, np.int64)


def _address(array, dtype):
    if not (array.dtype == dtype and array.flags.c_contiguous):
        raise TypeError(f"a C entry's array must be C-contiguous {np.dtype(dtype).name}, "
                        f"not {array.dtype.name} ({'' if array.flags.c_contiguous else 'not '}"
                        "contiguous)")
    return array.ctypes.data
