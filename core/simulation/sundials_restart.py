"""CVODE's restart, compiled: the one `sundials.Cvode.reset` and the compiled sampled loop
(`sampled_loop`) both run. Apart from `sundials` so that the sampled loop on a one-step method
does not load SUNDIALS' callbacks (they load only where CVODE or IDA runs)."""

from ..engine import access
from ..engine import data as ed
from ..numerics.jit import entry, kernel
from ..numerics.native import (
    as_float_pointer,
    as_int_pointer,
    call_get_long,
    call_reinit,
    call_with_time,
    carray,
    float_address,
    int_address,
)

# Cvode.address_table: the addresses its compiled restart (`cvode_restart`) and the compiled
# sampled loop call, in this order
(A_SOLVE, A_REINIT, A_STOP, A_MEMORY, A_Y, A_TRET, A_INIT_STEP, A_ACTUAL_INIT_STEP,
 A_NUM_STEPS, A_NUM_RHS, A_NUM_JACOBIANS, A_DATA, A_ANALYTIC, A_SIZE) = range(14)
# Cvode.learnt: what a restart keeps: [initial step (s; 0: SUNDIALS' estimate), 1.0 when a
# Jacobian is kept for the next setup]
L_INITIAL_STEP, L_JACOBIAN = range(2)
# _Solver.totals: the counts before the last (re)start (ReInit zeroes SUNDIALS'), and a scratch
T_STEPS, T_RHS, T_JACOBIANS, T_SCRATCH = range(4)


@kernel
def _add_count(function, memory, totals, slot):
    call_get_long(function, memory, totals[T_SCRATCH:].ctypes.data)
    totals[slot] += totals[T_SCRATCH]


@kernel
def cvode_restart(addresses, learnt, totals, t):
    """Restart CVODE at time t (s) at order 1 from the state in its y vector, with the inputs
    in the packed model: its counts since the last restart added to `totals`, ReInit, the
    learnt initial step set, and the kept Jacobian handed back once at the next setup (see
    `Cvode.reset`). `Cvode.reset` and the compiled sampled loop both restart through it.
    Returns 0 or ReInit's negative flag."""
    memory = addresses[A_MEMORY]
    _add_count(addresses[A_NUM_STEPS], memory, totals, T_STEPS)
    _add_count(addresses[A_NUM_RHS], memory, totals, T_RHS)
    _add_count(addresses[A_NUM_JACOBIANS], memory, totals, T_JACOBIANS)
    access.counters(addresses[A_DATA])[ed.FAILED_STATUS] = 0
    flag = call_reinit(addresses[A_REINIT], memory, t, addresses[A_Y])
    if flag < 0:
        return flag
    if learnt[L_INITIAL_STEP] > 0.0:
        call_with_time(addresses[A_INIT_STEP], memory, learnt[L_INITIAL_STEP])
    if learnt[L_JACOBIAN] != 0.0 and addresses[A_ANALYTIC] != 0:
        access.dims(addresses[A_DATA])[ed.JACOBIAN_REUSE] = 1
    return 0


@entry("int32(voidptr, voidptr, voidptr, float64)")
def _cvode_restart_entry(addresses, learnt, totals, t):
    """`cvode_restart` as a C entry, the arrays by address."""
    return cvode_restart(carray(as_int_pointer(addresses), (A_SIZE,)),
                         carray(as_float_pointer(learnt), (L_JACOBIAN + 1,)),
                         carray(as_int_pointer(totals), (T_SCRATCH + 1,)), t)


def cvode_restart_now(addresses, learnt, totals, t):
    """`cvode_restart` from Python (through its C entry: a process that loads compiled code
    from the cache calls it without numba). Returns 0 or ReInit's negative flag."""
    for array, size in ((addresses, A_SIZE), (learnt, L_JACOBIAN + 1), (totals, T_SCRATCH + 1)):
        if array.size != size:
            raise ValueError(f"cvode_restart: an array of {array.size} entries, not {size}")
    return _cvode_restart_entry.ctypes(int_address(addresses), float_address(learnt),
                                       int_address(totals), float(t))


__all__ = ["cvode_restart", "cvode_restart_now"]
