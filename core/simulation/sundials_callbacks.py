"""The compiled callbacks SUNDIALS calls through C function pointers (`sundials`): CVODE's
right-hand side and Jacobian, IDA's residual and Jacobian, each one engine operation on the
packed model whose address is the callbacks' user data, counted, with the engine's status
turned into SUNDIALS' 0 (OK), 1 (recoverable: a kinematics that does not converge at a trial
state) or -1 (unrecoverable: a non-finite state, a singular configuration). The code of the
last failure is kept in the counters, so an error names its cause."""


from ..engine import access, engine
from ..engine import data as ed
from ..numerics.dense import copy
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, call_engine, carray, dense_matrix_data, nvector_data


@kernel(inline="always")
def _callback(op, user_data, t, a, b, c, s, counter):
    """Count, call the engine through its address, and turn its status into SUNDIALS' 0 (OK),
    1 (recoverable) or -1 (unrecoverable), keeping the failure's code."""
    table = address_of(user_data)
    dims = access.dims(table)
    counters = access.counters(table)
    counters[counter] += 1
    status = call_engine(dims[ed.ENGINE], op, user_data, t, a, b, c, s)
    if status == ed.OK:
        return 0
    counters[ed.FAILED_STATUS] = status
    return -1 if status in (ed.NONFINITE_STATE, ed.SINGULAR_CONSTRAINTS, ed.NOT_CONNECTED) else 1


# SUNDIALS' callback types (CVRhsFn, CVLsJacFn, IDAResFn, IDALsJacFn) as numba signatures
_P = "voidptr"
CV_RHS_ENTRY = f"intc(float64, {_P}, {_P}, {_P})"
CV_JAC_ENTRY = f"intc(float64, {', '.join([_P] * 7)})"
IDA_RES_ENTRY = f"intc(float64, {', '.join([_P] * 4)})"
IDA_JAC_ENTRY = f"intc(float64, float64, {', '.join([_P] * 8)})"


@entry(CV_RHS_ENTRY)
def cvode_rhs(t, y, ydot, user_data):
    """CVRhsFn: ydot = f(t, y) by the engine."""
    return _callback(engine.OP_RHS, user_data, t, nvector_data(y), nvector_data(ydot),
                     nvector_data(y), 0.0, ed.RHS_COUNT)


@entry(CV_JAC_ENTRY)
def cvode_jacobian(t, y, fy, matrix, user_data, tmp1, tmp2, tmp3):
    """CVLsJacFn: the dense d f / d y (column-major) from the model's tangent, kept in slot
    jacobian_cache. After a restart in a sampled loop (dims[JACOBIAN_REUSE] = 1) the kept
    Jacobian is handed back once instead."""
    table = address_of(user_data)
    dims = access.dims(table)
    n = 2 * dims[ed.NDOF] + dims[ed.NEL]
    J = carray(dense_matrix_data(matrix), (n * n,))
    kept = access.jacobian_cache(table)
    if dims[ed.JACOBIAN_REUSE] == 1:
        dims[ed.JACOBIAN_REUSE] = 0
        copy(J, kept)
        return 0
    status = _callback(engine.OP_JACOBIAN, user_data, t, nvector_data(y),
                       dense_matrix_data(matrix), nvector_data(y), 1.0, ed.JACOBIAN_COUNT)
    if status == 0:
        copy(kept, J)
    return status


@entry(IDA_RES_ENTRY)
def ida_residual(t, y, yp, res, user_data):
    """IDAResFn: the implicit form's residual by the engine."""
    return _callback(engine.OP_RESIDUAL, user_data, t, nvector_data(y), nvector_data(yp),
                     nvector_data(res), 0.0, ed.RHS_COUNT)


@entry(IDA_JAC_ENTRY)
def ida_jacobian(t, cj, y, yp, res, matrix, user_data, tmp1, tmp2, tmp3):
    """IDALsJacFn: d res / d y + cj d res / d yp from the model's tangent."""
    return _callback(engine.OP_RESIDUAL_JACOBIAN, user_data, t, nvector_data(y),
                     nvector_data(yp), dense_matrix_data(matrix), cj, ed.JACOBIAN_COUNT)


