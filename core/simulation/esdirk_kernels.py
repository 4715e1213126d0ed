"""The compiled ESDIRK's step (`esdirk` describes the method and its `Esdirk` stepper drives it):
`advance` takes steps, each with its stages (`esdirk_newton`), its error test and step-size
control, and `restart` starts again after an input change or a new state; the first step's
size (`_initial_step`), the cut after repeated error-test failures (`observed_shrink`) and the
predictor's history (`keep_history`) are here too. The workspace's layout is `esdirk_layout`'s.
`esdirk_entry` makes `advance` and `restart` C entries; the sampled loop
(`sampled_loop_kernels`) calls them too.
"""

import numpy as np

from ..engine import access, engine
from ..engine import data as ed
from ..numerics.jit import kernel
from ..numerics.native import call_engine
from .esdirk_layout import (
    CONVERGENCE_FAILURES,
    ERROR_TEST_FAILURES,
    FSAL_CURRENT,
    FSAL_INPUTS,
    FSAL_NONE,
    I_AFTER_INPUT,
    I_BOUNDED_RESPONSE,
    I_ETA_AGE,
    I_ETA_HOLD,
    I_EVALUATION,
    I_EXTRA,
    I_FRESH,
    I_FSAL,
    I_HISTORY,
    I_JACOBIAN,
    I_LANDED,
    I_LU,
    I_MAX_STEPS,
    I_NEWTON_FAILURES,
    I_ONE_STEP,
    I_QUIET,
    I_REFRESH,
    I_REJECTED,
    I_RESPONSES,
    I_STEPS,
    M_ETA,
    M_EXPONENT,
    M_H,
    M_H_INPUT,
    M_H_LU,
    M_H_MAX,
    M_RTOL,
    M_T,
    OK,
    RHS_FAILURE,
    SINGULAR_MATRIX,
    STEP_TOO_SMALL,
    TOO_MUCH_WORK,
    V_CURVATURE,
    V_DELTA,
    V_ERR,
    V_F,
    V_SLOPE,
    V_WEIGHT,
    V_Y,
    V_Z,
)
from .esdirk_newton import (
    LU_SLACK,
    NEWTON_TOLERANCE,
    SPARSE_LU_SLACK,
    evaluate,
    factor_model,
    jacobian_cost,
    solve,
    solve_stage,
    weighted_norm,
)

MAX_FAILURES = 12         # consecutive failed attempts of one step
SAFETY, GROW, SHRINK = 0.9, 5.0, 0.2
# After two error-test failures at the same t the error's observed order in h replaces the
# assumed one (`observed_shrink`): at least ORDER_FLOOR, the step cut by at most SHRINK_FLOOR.
ORDER_FLOOR, SHRINK_FLOOR = 0.5, 0.01
# The share of the stage Newton's tolerance that the input response's error may take of a
# step (`response_weights`): a tenth, so that the response's error stays a tenth of the
# Newton's own leftover and far below the error test's 1 (NEWTON_TOLERANCE = 0.05 of it)
RESPONSE_SHARE = 0.1


@kernel
def _initial_step(table, memory, flags, vectors, atol, t_stop):
    """A first step (s) from the size of y, f and an estimate of f' (Hairer, Norsett & Wanner,
    Solving ODEs I, II.4), for the embedded order; the stage derivative F_1 must be current."""
    y, F1 = vectors[V_Y], vectors[V_F]
    weight, probe, slope = vectors[V_WEIGHT], vectors[V_Z], vectors[V_DELTA]
    rtol = memory[M_RTOL]
    for i in range(y.size):
        weight[i] = 1.0 / (rtol * abs(y[i]) + atol[i])
    d0, d1 = weighted_norm(y, weight), weighted_norm(F1, weight)
    h0 = 0.01 * d0 / d1 if d0 > 1e-5 and d1 > 1e-5 else 1e-6
    h0 = min(h0, t_stop - memory[M_T])
    for i in range(y.size):
        probe[i] = y[i] + h0 * F1[i]
    if evaluate(table, probe, slope, flags, engine.OP_RHS, memory[M_T] + h0) != ed.OK:
        return h0
    for i in range(y.size):
        slope[i] = (slope[i] - F1[i]) / h0
    d2 = weighted_norm(slope, weight)
    big = max(d1, d2)
    h1 = (0.01 / big) ** memory[M_EXPONENT] if big > 1e-15 else max(1e-6, 1e-3 * h0)
    return min(100.0 * h0, h1)


@kernel(inline="always")
def observed_shrink(h, error, h_before, error_before, exponent):
    """The factor of h after a second error-test failure at the same t: where the error
    (weighted, 1 = the tolerance) fell from error_before at h_before (s) to `error` at h
    more slowly than the controller's assumed h^(1/exponent), SAFETY error^(-1/p) with p the
    observed order log(error_before / error) / log(h_before / h), at least ORDER_FLOOR, the
    factor at least SHRINK_FLOOR; 1 (no further cut) otherwise. Why: the sudden tip load on
    the 384-DOF spatial cantilever makes the first step's error fall as h^0.4 (bending waves
    at the tip, each mode resolved in turn), where the step size control assumes h^4: nine
    rejections at t = 0 at rtol 1e-6, more than MAX_FAILURES at rtol 1e-7."""
    if h_before <= h:
        return 1.0
    order = np.log(error_before / error) / np.log(h_before / h)
    if order * exponent >= 1.0:
        return 1.0
    return max(SHRINK_FLOOR, SAFETY * error ** (-1.0 / max(order, ORDER_FLOOR)))


@kernel(inline="always")
def keep_history(vectors, A, h):
    """The accepted step's stage derivatives F at c = 0, c2 and 1 (the last stage) as a
    quadratic in t: its mean slope (F_s - F_1) / h and its curvature (1/s^2), for the next
    step's predictor."""
    F, c2 = vectors[V_F:], A[1, 0] + A[1, 1]
    last = A.shape[0] - 1
    slope, curvature = vectors[V_SLOPE], vectors[V_CURVATURE]
    for k in range(slope.size):
        slope[k] = (F[last, k] - F[0, k]) / h
        bend = (F[last, k] - F[1, k]) / (1.0 - c2) - (F[1, k] - F[0, k]) / c2
        curvature[k] = bend / (h * h)


@kernel(inline="always")
def first_stage_unread(A, EW):
    """Whether no stage and no estimate reads F_1 (A's first column, b_1 and b_hat_1 zero: an
    SDIRK written as an ESDIRK): then F_1 = f(y_n) is needed only as the predictor's start,
    where the last step's F_s serves, also after an input change (no input response)."""
    for i in range(A.shape[0]):
        if A[i, 0] != 0.0:
            return False
    return EW[0] == 0.0


@kernel(inline="always")
def response_weights(memory, y, atol, t_stop, m, out):
    """out[:m] = the error weights (s^2/m, s^2/rad) to which the engine may refine the input
    response d (m/s^2, rad/s^2) of the m DOFs, when the next step's size is known (True;
    False: none, the engine's fixed relative tolerance). Why: d is added to F_1's velocity
    half, so its error e moves each stage's state by h a_i1 e and the error estimate by
    h (b_1 - b_hat_1) e, each below h |e| in every tableau (TR-BDF2: a_21 0.29, b_1 0.35,
    b_1 - b_hat_1 0.14; the order-3 table: 0.44 at most). The weights are h_next w_v /
    (RESPONSE_SHARE NEWTON_TOLERANCE), w_v = 1 / (rtol |v| + atol_v) the velocity weights at
    y, which bound the ones the step's Newton and error test take (those use max(|y|, |z|)):
    an accepted e then moves the step, in the weighted RMS norm over its 2m states, by at
    most RESPONSE_SHARE / sqrt(2) of what the stage Newton may leave. h_next is an upper
    bound of the next step (memory[M_H], after `restart` already cut to memory[M_H_INPUT];
    capped by memory[M_H_MAX] and t_stop); a retried step is smaller, and the error it
    carries shrinks with its h, as the bound would."""
    h = memory[M_H]
    if memory[M_H_MAX] > 0.0:
        h = min(h, memory[M_H_MAX])
    h = min(h, t_stop - memory[M_T])
    if not h > 0.0:
        return False
    rtol, scale = memory[M_RTOL], h / (RESPONSE_SHARE * NEWTON_TOLERANCE)
    for j in range(m):
        out[j] = scale / (rtol * abs(y[m + j]) + atol[m + j])
    return True


@kernel(inline="always")  # into its C entry (esdirk_entry), its one caller: one unit
def advance(table, memory, flags, vectors, J, LU, piv, atol, A, EW, P, t_stop):
    """Integrate from memory[M_T] towards t_stop (s): to t_stop exactly, or one accepted step
    with flags[I_ONE_STEP] = 1; at most flags[I_MAX_STEPS] steps (0: no limit); flags, not
    arguments, so that the compiled loop's constant 0s do not compile the integrator a second
    time for their literal types. The state y is vectors[V_Y]; returns
    OK or a negative status, with y and memory[M_T] the last accepted state. The tableau:
    A (s, s), EW = b - b_hat (s,), P the predictor weights (s, s) (`esdirk_method`)."""
    n = piv.size
    stages = A.shape[0]
    y, z, err, weight, F = vectors[V_Y], vectors[V_Z], vectors[V_ERR], vectors[V_WEIGHT], \
        vectors[V_F:]
    rtol = memory[M_RTOL]
    counters, dims = access.counters(table), access.dims(table)
    one_step, max_steps = flags[I_ONE_STEP] != 0, flags[I_MAX_STEPS]
    steps = 0
    failures = 0
    if flags[I_LANDED] == 1:
        flags[I_QUIET] = 1
    h_rejected, error_rejected = 0.0, 0.0  # the last error-test failure at this t
    while memory[M_T] < t_stop:
        t = memory[M_T]
        if flags[I_FSAL] == FSAL_INPUTS and first_stage_unread(A, EW):
            flags[I_FSAL] = FSAL_CURRENT  # F_s of the old inputs: a predictor's start only
        if flags[I_FSAL] == FSAL_INPUTS:  # valid while the engine evaluated nothing since
            flags[I_RESPONSES] += 1
            delta = vectors[V_DELTA]  # d qddot (NDOF,) of the inputs' change
            # the weights' address, or null (an address's type: an int 0 would unify to float)
            bounds = weight.ctypes.data if flags[I_BOUNDED_RESPONSE] == 1 and \
                response_weights(memory, y, atol, t_stop, dims[ed.NDOF], weight) else \
                np.uint64(0)
            ok = counters[ed.EVALUATIONS] == flags[I_EVALUATION] and call_engine(
                dims[ed.ENGINE], engine.OP_INPUT_RESPONSE, table, 0.0, delta.ctypes.data,
                bounds, 0, 0.0) == ed.OK
            for j in range(dims[ed.NDOF] if ok else 0):
                F[0, dims[ed.NDOF] + j] += delta[j]
            flags[I_FSAL] = FSAL_CURRENT if ok else FSAL_NONE
        if flags[I_FSAL] == FSAL_NONE:  # a restart: no history either
            if evaluate(table, y, F[0], flags, engine.OP_RHS, t) != ed.OK:
                return RHS_FAILURE
            flags[I_FSAL] = FSAL_CURRENT
            vectors[V_SLOPE:] = 0.0
        if memory[M_H] <= 0.0:
            memory[M_H] = _initial_step(table, memory, flags, vectors, atol, t_stop)
        h = memory[M_H]
        if memory[M_H_MAX] > 0.0:
            h = min(h, memory[M_H_MAX])
        remaining = t_stop - t
        if h >= remaining * (1.0 - 1e-10):
            h = remaining
        elif 2.0 * h > remaining:
            h = 0.5 * remaining
        if h <= 16.0 * 2.2e-16 * max(abs(t), abs(t_stop)):
            return STEP_TOO_SMALL
        if flags[I_EXTRA] >= jacobian_cost(n, dims[ed.NEWTON_SPARSE] == 1):
            flags[I_REFRESH] = 1
        if flags[I_REFRESH] == 1 or flags[I_JACOBIAN] == 0:
            if evaluate(table, y, J, flags, engine.OP_JACOBIAN, t) != ed.OK:
                return RHS_FAILURE
            flags[I_JACOBIAN], flags[I_FRESH], flags[I_REFRESH], flags[I_LU] = 1, 1, 0, 0
            flags[I_EXTRA] = 0
        hg = h * A[1, 1]
        slack = SPARSE_LU_SLACK if dims[ed.NEWTON_SPARSE] == 1 else LU_SLACK
        if flags[I_LU] == 0 or abs(hg / memory[M_H_LU] - 1.0) > slack:
            if not factor_model(table, J, LU, piv, hg, flags):
                return SINGULAR_MATRIX
            flags[I_LU] = 1
            memory[M_H_LU] = hg
        for k in range(n):
            weight[k] = 1.0 / (rtol * abs(y[k]) + atol[k])
        converged = True
        for i in range(1, stages):
            if not solve_stage(table, i, h, memory, flags, vectors, J, LU, piv, A, P):
                converged = False
                break
        failures += 1
        if not converged:
            flags[I_NEWTON_FAILURES] += 1
            flags[I_ETA_AGE] = flags[I_ETA_HOLD]
            if failures > MAX_FAILURES:
                return CONVERGENCE_FAILURES
            if flags[I_FRESH] == 0:
                flags[I_REFRESH] = 1
            else:  # not the Jacobian's age: a smaller step, with the count started over
                memory[M_H] = 0.25 * h
                flags[I_EXTRA] = 0
            memory[M_ETA] = 1.0
            continue
        # the error estimate, filtered by the Newton matrix
        for k in range(n):
            s = 0.0
            for j in range(stages):
                s += EW[j] * F[j, k]
            err[k] = h * s
            weight[k] = 1.0 / (rtol * max(abs(y[k]), abs(z[k])) + atol[k])
        solve(table, J, LU, piv, memory, flags, err)
        error = weighted_norm(err, weight)
        if not np.isfinite(error):
            error = 1e10
        if error > 1.0:
            flags[I_REJECTED] += 1
            if failures > MAX_FAILURES:
                return ERROR_TEST_FAILURES
            shrink = max(SHRINK, SAFETY * error ** -memory[M_EXPONENT])
            if h_rejected > 0.0:
                shrink = min(shrink, observed_shrink(h, error, h_rejected, error_rejected,
                                                     memory[M_EXPONENT]))
            h_rejected, error_rejected = h, error
            memory[M_H] = h * shrink
            continue
        # accept: y_new = z_s, and its derivative F_s is the next step's F_1; the history
        if flags[I_HISTORY] == 1:
            keep_history(vectors, A, h)
        for k in range(n):
            y[k] = z[k]
            F[0, k] = F[stages - 1, k]
        flags[I_EVALUATION] = counters[ed.EVALUATIONS]  # its last stage's
        memory[M_T] = t_stop if h == remaining else t + h
        flags[I_LANDED] = 1 if h == remaining else 0
        memory[M_H] = (h * min(GROW, SAFETY * error ** -memory[M_EXPONENT]) if error > 0.0
                       else h * GROW)
        if flags[I_AFTER_INPUT] == 1:  # the first step after an input change: its own sequence
            memory[M_H_INPUT] = memory[M_H]
            flags[I_AFTER_INPUT] = 0
        flags[I_STEPS] += 1
        flags[I_ETA_AGE] = min(flags[I_ETA_AGE] + 1, flags[I_ETA_HOLD])
        flags[I_FRESH] = 0
        failures = 0
        h_rejected = 0.0
        steps += 1
        if one_step or (max_steps > 0 and steps >= max_steps and memory[M_T] < t_stop):
            return OK if one_step else TOO_MUCH_WORK
    return OK


@kernel
def restart(table, memory, flags, t, inputs_only):
    """Restart at time t (s) from the state in the vectors' V_Y row, with the inputs in the
    packed model at address `table`: the first stage's derivative is recomputed, or with
    inputs_only (nothing but the inputs changed since the step that ended at t) it is the last
    stage's plus the engine's input response; the step size, Jacobian and Newton matrix are
    kept, except that after an input change the first step is at most the one the controller
    proposed after the last input change's first step (memory[M_H_INPUT]). Why: a held
    input's jump excites the model's faster modes at every sample, so the first step of a
    sample wants about the size the last sample's first step had, not the size the last
    sample's smooth end grew to (on manipulator_reduced's 4 kHz loop that size was rejected
    three times a sample: docs/benchmarks.md, session 35). Not after a stretch of integration
    with no input change (flags[I_QUIET]): the last change's first step says nothing then.
    `Esdirk.reset` and the compiled sampled loop both restart through it."""
    # not with kinematic inputs: the input response is that of the unconstrained
    # accelerations (the engine declines it too), and a host's move_to changes the path,
    # which changes f where no input response can tell
    keep = inputs_only and memory[M_T] == t and flags[I_FSAL] != FSAL_NONE and \
        access.dims(table)[ed.NKI] == 0
    memory[M_T] = t
    flags[I_FSAL] = FSAL_INPUTS if keep else FSAL_NONE
    flags[I_AFTER_INPUT] = 1 if keep else 0
    if keep and memory[M_H_INPUT] > 0.0 and flags[I_QUIET] == 0:
        memory[M_H] = min(memory[M_H], memory[M_H_INPUT])
    flags[I_LANDED], flags[I_QUIET] = 0, 0
    access.counters(table)[ed.FAILED_STATUS] = 0
