"""The compiled variable-step BDF2 (`bdf2` describes the method and its `Bdf2` stepper drives
it): its step with the error test and step-size control (`advance`), and `advance_entry`, the C
entry that Python and the sampled loop call. It shares the ESDIRK's memory, flags, vector
workspace, status codes, restart (`esdirk_kernels.restart`) and argument layout
(`esdirk_entry.arguments`), so that the compiled sampled loop drives both through one driver.

One step from t_n with size h = omega h_b (h_b the last accepted step), y = [q - q_ref, qdot]
(m, rad, m/s, rad/s) and F_n its derivative:

    z = a1 y_n + a2 y_b + beta h f(t_n + h, z),        y_b = y_(n-1), the last step's start
    a1 = (1 + w)^2 / (1 + 2 w),  a2 = -w^2 / (1 + 2 w),  beta = (1 + w) / (1 + 2 w)

exact for quadratics in t (order 2; at w = 1 the textbook 4/3, -1/3, 2/3). Without a history
(a restart) the step is backward Euler (a1 = 1, a2 = 0, beta = 1, order 1).

Error estimate: z minus the quadratic p through y_b, y_n with slope F_n at t_n (p = y_n +
h F_n + w^2 (y_b - y_n + h_b F_n)): with c = y'''/6, y(t_n+1) - p = c h^3 (1 + w) / w and
y(t_n+1) - z = -c h^3 (1 + w)^2 / (w (1 + 2 w)), so the local error is (1 + w) / (2 + 3 w)
(z - p) (2/5 at w = 1; backward Euler's, against p = y_n + h F_n, is (z - p) / 2), filtered
by the Newton matrix (I - beta h J)^-1 as the ESDIRK's (Hairer & Wanner IV.8). The step
grows at most GROW times, inside variable-step BDF2's zero stability (w < 1 + sqrt(2)).

Newton: simplified, on I - beta h J with the ESDIRK's rules for the Jacobian's renewal, the
factors' slack and the contraction estimate (`esdirk_kernels`), started from f(z) predicted
as F_n + w (F_n - F_b).

A held input's change at t_n (the engine's input response dqddot, one solve: `esdirk`)
enters F_n, and the history as the new inputs would have made it to second order: q_b +=
h_b^2 / 2 dqddot, qdot_b -= h_b dqddot, and F_b alike. Why: the force held from a sample
makes qddot jump there; a history from before the jump, used as it is, costs BDF2 an error
of order h^2 times the jump per step (an input shifted in time), where with the history
moved the step stays of order 3. So in a loop at a fixed sample rate a step spans a sample
with one evaluation of f where TR-BDF2 takes two (docs/benchmarks.md).
"""

import numpy as np

from ..engine import access, engine
from ..engine import data as ed
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, as_float_pointer, as_int_pointer, call_engine, carray
from . import esdirk_entry as ee
from . import esdirk_kernels as ek
from .esdirk_kernels import _f, _initial_step, _norm, factor_model, observed_shrink, solve

# rows of the vector workspace (esdirk_kernels.V_...) beyond the ones both methods use
B_F = ek.V_F              # F_n, the derivative at y_n (its first stage's, for the ESDIRK)
B_F_NEW = ek.V_F + 1      # F at the step's solution z
B_Y_BEFORE = ek.V_F + 2   # y_b = y_(n-1)
B_F_BEFORE = ek.V_F + 3   # F_b = F_(n-1)
GROW = 2.0                # the largest h / h_b
EXPONENT_START = 0.5      # the step control's exponent on backward Euler's (order 1) estimate


@kernel(inline="always")
def coefficients(omega, history):
    """(a1, a2, beta, e) of a step of omega (h / h_b) times the last one: z = a1 y_n + a2 y_b
    + beta h f(z), and e the factor of z - p in its local error; backward Euler's without a
    history."""
    if not history:
        return 1.0, 0.0, 1.0, 0.5
    d = 1.0 + 2.0 * omega
    return ((1.0 + omega) ** 2 / d, -omega * omega / d, (1.0 + omega) / d,
            (1.0 + omega) / (2.0 + 3.0 * omega))


@kernel(inline="always")
def _move_history(vectors, ndof, h_before, dqddot):
    """F_n, F_b and y_b as the inputs whose response is dqddot (NDOF,) would have made them
    (second order in h_b, s)."""
    F, F_before, y_before = vectors[B_F], vectors[B_F_BEFORE], vectors[B_Y_BEFORE]
    for j in range(ndof):
        d = dqddot[j]
        F[ndof + j] += d
        if h_before > 0.0:
            F_before[ndof + j] += d
            F_before[j] -= h_before * d
            y_before[j] += 0.5 * h_before * h_before * d
            y_before[ndof + j] -= h_before * d


@kernel
def _solve_step(table, hg, memory, flags, vectors, J, LU, piv, t_new):
    """z = base + hg f(t_new, z) by simplified Newton from the z in the workspace; F at z from
    the equation. True when it converged."""
    n = piv.size
    base, z, delta = vectors[ek.V_BASE], vectors[ek.V_Z], vectors[ek.V_DELTA]
    weight, F_new = vectors[ek.V_WEIGHT], vectors[B_F_NEW]
    eta = max(memory[ek.M_ETA], 1e-16) ** 0.8  # let grow once per step, as the ESDIRK's
    previous = 0.0
    for iteration in range(ek.MAX_NEWTON):
        if _f(table, z, F_new, flags, engine.OP_RHS, t_new) != ed.OK:
            return False
        for k in range(n):
            delta[k] = base[k] + hg * F_new[k] - z[k]
        solve(table, J, LU, piv, memory, flags, delta)
        for k in range(n):
            z[k] += delta[k]
        norm = _norm(delta, weight)
        if not np.isfinite(norm):
            return False
        if iteration > 0:
            theta = norm / previous
            if theta >= ek.THETA_STALE:  # an iteration the Jacobian's age cost
                flags[ek.I_EXTRA] += 1
            if theta >= 0.99:
                return False
            eta = theta / (1.0 - theta)
        if eta * norm <= ek.NEWTON_TOLERANCE or norm == 0.0:
            memory[ek.M_ETA] = eta
            for k in range(n):
                F_new[k] = (z[k] - base[k]) / hg
            return True
        previous = norm
    return False


@kernel(inline="always")  # into its C entry, its one caller: one unit
def advance(table, memory, flags, vectors, J, LU, piv, atol, t_stop):
    """Integrate from memory[M_T] towards t_stop (s), as `esdirk_kernels.advance` (the same
    flags, landing on t_stop, step budget and status codes) with BDF2's step."""
    n = piv.size
    y, z, base, err = vectors[ek.V_Y], vectors[ek.V_Z], vectors[ek.V_BASE], vectors[ek.V_ERR]
    weight, F, F_new = vectors[ek.V_WEIGHT], vectors[B_F], vectors[B_F_NEW]
    y_before, F_before = vectors[B_Y_BEFORE], vectors[B_F_BEFORE]
    rtol = memory[ek.M_RTOL]
    counters, dims = access.counters(table), access.dims(table)
    one_step, max_steps = flags[ek.I_ONE_STEP] != 0, flags[ek.I_MAX_STEPS]
    steps = 0
    failures = 0
    h_rejected, error_rejected = 0.0, 0.0
    while memory[ek.M_T] < t_stop:
        t = memory[ek.M_T]
        if flags[ek.I_FSAL] == ek.FSAL_INPUTS:  # valid while the engine evaluated nothing since
            delta = vectors[ek.V_DELTA]
            ok = counters[ed.EVALUATIONS] == flags[ek.I_EVALUATION] and call_engine(
                dims[ed.ENGINE], engine.OP_INPUT_RESPONSE, table, 0.0, delta.ctypes.data, 0, 0,
                0.0) == ed.OK
            if ok:
                _move_history(vectors, dims[ed.NDOF], memory[ek.M_H_BEFORE], delta)
            flags[ek.I_FSAL] = ek.FSAL_CURRENT if ok else ek.FSAL_NONE
        if flags[ek.I_FSAL] == ek.FSAL_NONE:  # a restart: no history either
            if _f(table, y, F, flags, engine.OP_RHS, t) != ed.OK:
                return ek.RHS_FAILURE
            flags[ek.I_FSAL] = ek.FSAL_CURRENT
            memory[ek.M_H_BEFORE] = 0.0
        if memory[ek.M_H] <= 0.0:
            memory[ek.M_H] = _initial_step(table, memory, flags, vectors, atol, t_stop)
        h_before = memory[ek.M_H_BEFORE]
        history = h_before > 0.0
        h = memory[ek.M_H]
        if history:
            h = min(h, GROW * h_before)
        if memory[ek.M_H_MAX] > 0.0:
            h = min(h, memory[ek.M_H_MAX])
        remaining = t_stop - t
        if h >= remaining * (1.0 - 1e-10):
            h = remaining
        elif 2.0 * h > remaining:
            h = 0.5 * remaining
        if h <= 16.0 * 2.2e-16 * max(abs(t), abs(t_stop)):
            return ek.STEP_TOO_SMALL
        if flags[ek.I_EXTRA] >= max(1.0, ek.JACOBIAN_COST * n):
            flags[ek.I_REFRESH] = 1
        if flags[ek.I_REFRESH] == 1 or flags[ek.I_JACOBIAN] == 0:
            if _f(table, y, J, flags, engine.OP_JACOBIAN, t) != ed.OK:
                return ek.RHS_FAILURE
            flags[ek.I_JACOBIAN], flags[ek.I_FRESH], flags[ek.I_REFRESH], flags[ek.I_LU] = \
                1, 1, 0, 0
            flags[ek.I_EXTRA] = 0
        omega = h / h_before if history else 0.0
        a1, a2, beta, e = coefficients(omega, history)
        hg = beta * h
        slack = ek.SPARSE_LU_SLACK if dims[ed.NEWTON_SPARSE] == 1 else ek.LU_SLACK
        if flags[ek.I_LU] == 0 or abs(hg / memory[ek.M_H_LU] - 1.0) > slack:
            if not factor_model(table, J, LU, piv, hg, flags):
                return ek.SINGULAR_MATRIX
            flags[ek.I_LU] = 1
            memory[ek.M_H_LU] = hg
        for k in range(n):
            weight[k] = 1.0 / (rtol * abs(y[k]) + atol[k])
            base[k] = a1 * y[k] + a2 * y_before[k] if history else y[k]
            slope = F[k] + omega * (F[k] - F_before[k]) if history else F[k]
            z[k] = base[k] + hg * slope
        t_new = t_stop if h == remaining else t + h
        converged = _solve_step(table, hg, memory, flags, vectors, J, LU, piv, t_new)
        failures += 1
        if not converged:
            flags[ek.I_NEWTON_FAILURES] += 1
            if failures > ek.MAX_FAILURES:
                return ek.CONVERGENCE_FAILURES
            if flags[ek.I_FRESH] == 0:
                flags[ek.I_REFRESH] = 1
            else:  # not the Jacobian's age: a smaller step, with the count started over
                memory[ek.M_H] = 0.25 * h
                flags[ek.I_EXTRA] = 0
            memory[ek.M_ETA] = 1.0
            continue
        for k in range(n):  # the local error from z - p, filtered by the Newton matrix
            p = y[k] + h * F[k]
            if history:
                p += omega * omega * (y_before[k] - y[k] + h_before * F[k])
            err[k] = e * (z[k] - p)
            weight[k] = 1.0 / (rtol * max(abs(y[k]), abs(z[k])) + atol[k])
        solve(table, J, LU, piv, memory, flags, err)
        error = _norm(err, weight)
        if not np.isfinite(error):
            error = 1e10
        exponent = memory[ek.M_EXPONENT] if history else EXPONENT_START
        if error > 1.0:
            flags[ek.I_REJECTED] += 1
            if failures > ek.MAX_FAILURES:
                return ek.ERROR_TEST_FAILURES
            shrink = max(ek.SHRINK, ek.SAFETY * error ** -exponent)
            if h_rejected > 0.0:
                shrink = min(shrink, observed_shrink(h, error, h_rejected, error_rejected,
                                                     exponent))
            h_rejected, error_rejected = h, error
            memory[ek.M_H] = h * shrink
            continue
        for k in range(n):  # accept: the step's start becomes the history
            y_before[k], F_before[k] = y[k], F[k]
            y[k], F[k] = z[k], F_new[k]
        memory[ek.M_H_BEFORE] = h
        flags[ek.I_EVALUATION] = counters[ed.EVALUATIONS]  # the step's last
        memory[ek.M_T] = t_new
        memory[ek.M_H] = (h * min(GROW, ek.SAFETY * error ** -exponent) if error > 0.0
                          else h * GROW)
        flags[ek.I_STEPS] += 1
        flags[ek.I_FRESH] = 0
        failures = 0
        h_rejected = 0.0
        steps += 1
        if one_step or (max_steps > 0 and steps >= max_steps and memory[ek.M_T] < t_stop):
            return ek.OK if one_step else ek.TOO_MUCH_WORK
    return ek.OK


# A module-level function, not a closure (as `esdirk_entry.advance_entry`: numba keys a
# closure's cache entry on its cells' pickled contents)
@entry(ee.ADVANCE_ENTRY)
def advance_entry(arguments, t_stop):
    """`advance` on the arrays whose addresses and sizes `arguments` holds
    (`esdirk_entry.arguments`; the tableau's entries are not read)."""
    a = carray(as_int_pointer(address_of(arguments)), (ee.A_SIZE,))
    n = a[ee.A_N]
    return advance(
        a[ee.A_TABLE], carray(as_float_pointer(a[ee.A_MEMORY]), (ek.M_SIZE,)),
        carray(as_int_pointer(a[ee.A_FLAGS]), (ek.I_SIZE,)),
        carray(as_float_pointer(a[ee.A_VECTORS]), (ek.V_ROWS, n)),
        carray(as_float_pointer(a[ee.A_J]), (n * n,)),
        carray(as_float_pointer(a[ee.A_LU]), (n * n,)),
        carray(as_int_pointer(a[ee.A_PIVOTS]), (n,)),
        carray(as_float_pointer(a[ee.A_ATOL]), (n,)), t_stop)
