"""The intrinsics of `native` (pointer casts and C calls by address), made with numba and
llvmlite when compiled code first uses one; `native` describes them.

The layout of a serial N_Vector is SUNDIALS' (7.x): `N_Vector` points to a struct whose first
member is the `content` pointer; the serial content is {sunindextype length; sunbooleantype
own_data; sunrealtype *data}. `flexure.core.simulation.sundials` checks the data offset against
N_VGetArrayPointer when it loads the library, so a build with another layout is refused there
instead of being read wrongly here.
"""

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from .native import NVECTOR_DATA_OFFSET

_I8P = ir.IntType(8).as_pointer()
_I32 = ir.IntType(32)
_DOUBLE = ir.DoubleType()


def _cast(builder, value, pointer_type):
    """An address (an integer, or a pointer such as void*) as a pointer of pointer_type."""
    if isinstance(value.type, ir.PointerType):
        return builder.bitcast(value, pointer_type)
    return builder.inttoptr(value, pointer_type)


@intrinsic
def as_float_pointer(typingctx, address):
    """A float64 pointer (for numba.carray) from an address (int64 or void*)."""
    sig = types.CPointer(types.float64)(address)

    def codegen(context, builder, signature, args):
        return _cast(builder, args[0], _DOUBLE.as_pointer())

    return sig, codegen


@intrinsic
def as_int_pointer(typingctx, address):
    """An int64 pointer (for numba.carray) from an address (int64 or void*)."""
    sig = types.CPointer(types.int64)(address)

    def codegen(context, builder, signature, args):
        return _cast(builder, args[0], ir.IntType(64).as_pointer())

    return sig, codegen


def _content_data(builder, pointer, offset):
    """The double* at byte `offset` of the content struct of a SUNDIALS object (an N_Vector or
    a SUNMatrix: a pointer to a struct whose first member is `content`)."""
    content = builder.load(builder.bitcast(pointer, _I8P.as_pointer()))
    field = builder.gep(content, [ir.Constant(ir.IntType(64), offset)])
    return builder.load(builder.bitcast(field, _DOUBLE.as_pointer().as_pointer()))


@intrinsic
def nvector_data(typingctx, vector):
    """The sunrealtype* data of a serial N_Vector given as a void pointer."""
    sig = types.CPointer(types.float64)(vector)

    def codegen(context, builder, signature, args):
        return _content_data(builder, args[0], NVECTOR_DATA_OFFSET)

    return sig, codegen


@intrinsic
def dense_matrix_data(typingctx, matrix):
    """The column-major sunrealtype* data of a dense SUNMatrix given as a void pointer.

    SUNMatrix -> content -> {M, N (sunindextype), data, ...}: data follows two int32."""
    sig = types.CPointer(types.float64)(matrix)

    def codegen(context, builder, signature, args):
        return _content_data(builder, args[0], 8)

    return sig, codegen


@intrinsic
def call_solve(typingctx, function, memory, tout, vector, tret, task):
    """int CVode(void *mem, sunrealtype tout, N_Vector yout, sunrealtype *tret, int itask)
    through its address; memory, vector and tret are addresses (int64)."""
    sig = types.int32(function, memory, tout, vector, tret, task)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(_I32, [_I8P, _DOUBLE, _I8P, _DOUBLE.as_pointer(), _I32])
        callee = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(callee, [builder.inttoptr(args[1], _I8P), args[2],
                                     builder.inttoptr(args[3], _I8P),
                                     builder.inttoptr(args[4], _DOUBLE.as_pointer()),
                                     builder.trunc(args[5], _I32)])

    return sig, codegen


@intrinsic
def call_with_time(typingctx, function, memory, t):
    """int f(void *mem, sunrealtype t) (CVodeSetStopTime, CVodeSetInitStep) by address."""
    sig = types.int32(function, memory, t)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(_I32, [_I8P, _DOUBLE])
        callee = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(callee, [builder.inttoptr(args[1], _I8P), args[2]])

    return sig, codegen


@intrinsic
def call_reinit(typingctx, function, memory, t, vector):
    """int CVodeReInit(void *mem, sunrealtype t0, N_Vector y0) by address."""
    sig = types.int32(function, memory, t, vector)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(_I32, [_I8P, _DOUBLE, _I8P])
        callee = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(callee, [builder.inttoptr(args[1], _I8P), args[2],
                                     builder.inttoptr(args[3], _I8P)])

    return sig, codegen


def _address_arguments(builder, values, kinds):
    """LLVM values for a C call: 'p' double* (from an address or a pointer), 'v' void*,
    'i' int64, 'd' double."""
    converted = []
    for value, kind in zip(values, kinds, strict=True):
        if kind == "p":
            converted.append(_cast(builder, value, _DOUBLE.as_pointer()))
        elif kind == "v":
            converted.append(_cast(builder, value, _I8P))
        elif kind == "i":
            converted.append(value if value.type == ir.IntType(64)
                             else builder.sext(value, ir.IntType(64)))
        else:
            converted.append(value)
    return converted


_LLVM_KINDS = {"p": _DOUBLE.as_pointer(), "v": _I8P, "i": ir.IntType(64), "d": _DOUBLE}


def _call_by_address(builder, address, values, kinds, result):
    fnty = ir.FunctionType(result, [_LLVM_KINDS[k] for k in kinds])
    callee = builder.inttoptr(address, fnty.as_pointer())
    return builder.call(callee, _address_arguments(builder, values, kinds))


@intrinsic
def call_deformations(typingctx, address, x, ref, order, e, De, D2e, m, k, width):
    """An element's `deformations_entry` (jit.DEFORMATIONS_ENTRY) through its address; the
    arrays are given by their addresses."""
    sig = types.void(address, x, ref, order, e, De, D2e, m, k, width)

    def codegen(context, builder, signature, args):
        _call_by_address(builder, args[0], args[1:], "ppippiiii", ir.VoidType())
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def call_inertia(typingctx, address, x, v, ref, order, p, Dp, acc, m, P, width):
    """An element's `inertia_entry` (jit.INERTIA_ENTRY) through its address."""
    sig = types.void(address, x, v, ref, order, p, Dp, acc, m, P, width)

    def codegen(context, builder, signature, args):
        _call_by_address(builder, args[0], args[1:], "pppipppiii", ir.VoidType())
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def call_engine(typingctx, operations, op, user_data, t, a, b, c, s):
    """Operation `op` of the engine: its entry point (engine.ENGINE_ENTRY) through the table
    of the operations' addresses at `operations` (int64 each, by operation code); int32
    status."""
    sig = types.int32(operations, op, user_data, t, a, b, c, s)

    def codegen(context, builder, signature, args):
        table = _cast(builder, args[0], ir.IntType(64).as_pointer())
        address = builder.load(builder.gep(table, [args[1]]))
        return _call_by_address(builder, address, args[1:], "ivdvvvd", _I32)

    return sig, codegen


@intrinsic
def call_stepper(typingctx, function, arguments, t):
    """int32 f(void *arguments, double t) through its address (an integrator's advance
    entry, `simulation.esdirk_entry`); arguments an address (int64)."""
    sig = types.int32(function, arguments, t)

    def codegen(context, builder, signature, args):
        return _call_by_address(builder, args[0], args[1:], "vd", _I32)

    return sig, codegen


@intrinsic
def call_get_real(typingctx, function, memory, out):
    """int f(void *mem, sunrealtype *out) (CVodeGetActualInitStep, ...) by address; out is
    an address."""
    sig = types.int32(function, memory, out)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(_I32, [_I8P, _DOUBLE.as_pointer()])
        callee = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(callee, [builder.inttoptr(args[1], _I8P),
                                     _cast(builder, args[2], _DOUBLE.as_pointer())])

    return sig, codegen


@intrinsic
def call_get_long(typingctx, function, memory, out):
    """int f(void *mem, long *out) (CVodeGetNumSteps, ...) by address; out an address."""
    sig = types.int32(function, memory, out)

    def codegen(context, builder, signature, args):
        long_pointer = ir.IntType(64).as_pointer()
        fnty = ir.FunctionType(_I32, [_I8P, long_pointer])
        callee = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(callee, [builder.inttoptr(args[1], _I8P),
                                     _cast(builder, args[2], long_pointer)])

    return sig, codegen


@intrinsic
def address_of(typingctx, pointer):
    """The address (int64) of a pointer (e.g. a C callback's void* user data)."""
    sig = types.int64(pointer)

    def codegen(context, builder, signature, args):
        return builder.ptrtoint(args[0], ir.IntType(64))

    return sig, codegen
