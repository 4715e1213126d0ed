"""The compiled ESDIRK (`esdirk` describes the method and its `Esdirk` stepper drives it):
the layout of its memory, flags and vector workspace, its status codes and step control
constants, and its kernels: the stage equations, the step with its error test and step-size
control (`advance`), and the restart (`restart`). `esdirk_entry` makes `advance` and `restart`
C entries; the sampled loop (`sampled_loop_kernels`) calls them too.
"""

import numpy as np

from ..engine import access, engine
from ..engine import data as ed
from ..engine.operations import FORCE, OP_NEWTON_JACOBIAN, OP_STAGE_FORCE
from ..numerics.jit import kernel
from ..numerics.native import call_engine
from . import newton_matrix
from .esdirk_method import MAX_STAGES
from .newton_matrix import newton_solve

# float64 memory slots
(M_T, M_H, M_RTOL, M_H_MAX, M_H_LU, M_ETA, M_EXPONENT, M_H_INPUT, M_SIZE) = range(9)
# memory[M_H_INPUT]: the step (s) the controller proposed after the last accepted first step
# after an input change (0: none yet); the next input change starts no larger (`restart`)
# int64 flags and counters; flags[I_FSAL]: F_1 to evaluate, F_1 current, F_1 = F_s of the inputs
# of the engine's last evaluation (counters[EVALUATIONS] = flags[I_EVALUATION]): add the response
FSAL_NONE, FSAL_CURRENT, FSAL_INPUTS = range(3)
(I_FSAL, I_JACOBIAN, I_FRESH, I_REFRESH, I_LU, I_STEPS, I_REJECTED, I_NEWTON_FAILURES,
 I_RHS, I_JACOBIANS, I_FACTORIZATIONS, I_REDUCED, I_ONE_STEP, I_MAX_STEPS, I_EVALUATION,
 I_HISTORY, I_EXTRA, I_MASS_FORM, I_RESPONSES, I_AFTER_INPUT, I_ETA_AGE, I_ETA_HOLD,
 I_LANDED, I_QUIET, I_SIZE) = range(25)
# flags[I_AFTER_INPUT] = 1 from an input change (`restart`) to the next accepted step;
# I_LANDED = 1 once a step lands on t_stop, and no restart since; I_QUIET = 1 once an advance
# started from a landing (a stretch with no input change: memory[M_H_INPUT] is stale)
# flags[I_ETA_AGE]: accepted steps since a stage last measured its contraction; the estimate
# grows at a step's first implicit stage once the age reaches flags[I_ETA_HOLD] (`_stage`)
# flags[I_RESPONSES]: the engine's input responses the first stage asked for (`advance`)
# flags[I_MASS_FORM] = 1 (`Esdirk`'s default): on the sparse Newton matrix the stages take
# their residual in mass form (`_mass_form_residual`); 0 the accelerations' (for comparison)
# flags[I_REDUCED]: the Newton matrix's factors are the full matrix's (0), its Schur
# complement's (1) or the engine's sparse ones (SPARSE_FACTORS, `newton_matrix`)
SPARSE_FACTORS = 2
# rows of the vector workspace: the stage derivatives from V_F, then the last step's history
(V_Y, V_Z, V_BASE, V_DELTA, V_ERR, V_WEIGHT, V_F) = range(7)
V_SLOPE, V_CURVATURE = V_F + MAX_STAGES, V_F + MAX_STAGES + 1
V_ROWS = V_CURVATURE + 1

OK = 0
TOO_MUCH_WORK, STEP_TOO_SMALL, ERROR_TEST_FAILURES, CONVERGENCE_FAILURES, SINGULAR_MATRIX, \
    RHS_FAILURE = -1, -2, -3, -4, -5, -8
FLAG_NAMES = {TOO_MUCH_WORK: "TOO_MUCH_WORK", STEP_TOO_SMALL: "STEP_TOO_SMALL",
              ERROR_TEST_FAILURES: "ERROR_TEST_FAILURES",
              CONVERGENCE_FAILURES: "CONVERGENCE_FAILURES", SINGULAR_MATRIX: "SINGULAR_MATRIX",
              RHS_FAILURE: "RHS_FAILURE"}

NEWTON_TOLERANCE = 0.05   # eta |dz| in the weighted norm (1 = the error the step may make)
MAX_NEWTON = 7
MAX_FAILURES = 12         # consecutive failed attempts of one step
LU_SLACK = 0.2            # |h / h_LU - 1| that keeps the Newton matrix's factors
# On the sparse Newton matrix (`newton_matrix`) none: factored again at every new h. Why: a
# Newton matrix made at hg_LU contracts the stiff modes (|hg lambda| >> 1) of a stage at hg
# only by |1 - hg / hg_LU|, up to the slack; on the 384-DOF spatial cantilever the stages'
# contractions of 0.01 to 0.1 were that, an iteration more, where a sparse factorisation
# costs a fifth of an evaluation (0.086 ms against 0.47): 0.83 of the evaluations on 15
# runs at rtol 1e-5 to 1e-7, 0.81 at 96 DOFs, at the same error (docs/benchmarks.md). Not 0:
# an h equal to the factors' but for round-off (a CPU's fused multiply-adds) keeps them
SPARSE_LU_SLACK = 1e-9
# A new Jacobian J = df/dy at the next step once the Newton iterations its age cost since the
# last one (beyond each stage's first, contracting by theta >= THETA_STALE: with a current J
# Newton contracts quadratically, theta < 1e-3 on the stages measured) have cost as much as a
# new J, about n / 4 evaluations of f for n states or less (1.5 for stage_planar_3dof's 6, 4.0
# for stage_spatial_19dof's 38, 22 for manipulator_control's 150: docs/decisions.md)
JACOBIAN_COST = 0.25      # evaluations per state
THETA_STALE = 0.01
SAFETY, GROW, SHRINK = 0.9, 5.0, 0.2
# Accepted steps the Newton contraction estimate eta is trusted unmeasured before it grows
# at a step's first implicit stage (flags[I_ETA_HOLD], set by `Esdirk`: on the sparse Newton
# matrix, whose J stays current for long; 0, growth at every step, on the dense path, where
# it cost accuracy on stage_planar_3dof). On the cantilevers 0.90 to 0.99 of the evaluations
# at their errors; an eta unmeasured for 10 steps grows again, so a stale J is still found
# (docs/benchmarks.md, session 35)
ETA_HOLD = 10
# After two error-test failures at the same t the error's observed order in h replaces the
# assumed one (`observed_shrink`): at least ORDER_FLOOR, the step cut by at most SHRINK_FLOOR.
ORDER_FLOOR, SHRINK_FLOOR = 0.5, 0.01


@kernel
def _f(table, y, out, flags, op, t):
    """out = f(t, y) by the engine at time t (s; read by a model with kinematic inputs only)
    (op OP_JACOBIAN: J = d f / d y, row-major, flat, from the model's tangent); its
    status."""
    jacobian = op == engine.OP_JACOBIAN
    flags[I_JACOBIANS if jacobian else I_RHS] += 1
    counters = access.counters(table)
    counters[ed.JACOBIAN_COUNT if jacobian else ed.RHS_COUNT] += 1
    dims = access.dims(table)
    if jacobian and dims[ed.NEWTON_SPARSE] == 1:  # M, C_x, K_x in the engine (`newton_matrix`)
        op = OP_NEWTON_JACOBIAN
    status = call_engine(dims[ed.ENGINE], op, table, t, y.ctypes.data, out.ctypes.data, 0, 0.0)
    if status != ed.OK:
        counters[ed.FAILED_STATUS] = status
    return status


@kernel(inline="always")
def factor(J, LU, piv, hg, flags):
    """LU = factors of I - hg J (`newton_matrix`), counted; flags[I_REDUCED] = 1 when they are
    its Schur complement's; False when singular."""
    form = newton_matrix.factor(J, LU, piv, hg)
    flags[I_FACTORIZATIONS] += 1
    flags[I_REDUCED] = 1 if form == newton_matrix.SCHUR else 0
    return form != newton_matrix.SINGULAR


@kernel(inline="always")
def factor_model(table, J, LU, piv, hg, flags):
    """`factor`, or on a model with the sparse Newton matrix (dims[NEWTON_SPARSE]) the
    engine's factors from its last sparse Jacobian (`newton_matrix.sparse_factor`), counted,
    with flags[I_REDUCED] = SPARSE_FACTORS; False when singular."""
    if access.dims(table)[ed.NEWTON_SPARSE] != 1:
        return factor(J, LU, piv, hg, flags)
    form = newton_matrix.sparse_factor(table, hg)
    flags[I_FACTORIZATIONS] += 1
    flags[I_REDUCED] = SPARSE_FACTORS
    return form != newton_matrix.SINGULAR


@kernel(inline="always")
def solve(table, J, LU, piv, memory, flags, v):
    """v <- (I - hg J)^-1 v with the factors of the last `factor_model` (hg =
    memory[M_H_LU])."""
    if flags[I_REDUCED] == SPARSE_FACTORS:
        newton_matrix.sparse_solve(table, memory[M_H_LU], v)
    else:
        newton_solve(J, LU, piv, memory[M_H_LU], flags[I_REDUCED] == 1, v)


@kernel
def _norm(v, weight):
    """Weighted RMS norm sqrt(mean((v_i weight_i)^2))."""
    s = 0.0
    for i in range(v.size):
        s += (v[i] * weight[i]) ** 2
    return np.sqrt(s / v.size)


@kernel
def _initial_step(table, memory, flags, vectors, atol, t_stop):
    """A first step (s) from the size of y, f and an estimate of f' (Hairer, Norsett & Wanner,
    Solving ODEs I, II.4), for the embedded order; the stage derivative F_1 must be current."""
    y, F1 = vectors[V_Y], vectors[V_F]
    weight, probe, slope = vectors[V_WEIGHT], vectors[V_Z], vectors[V_DELTA]
    rtol = memory[M_RTOL]
    for i in range(y.size):
        weight[i] = 1.0 / (rtol * abs(y[i]) + atol[i])
    d0, d1 = _norm(y, weight), _norm(F1, weight)
    h0 = 0.01 * d0 / d1 if d0 > 1e-5 and d1 > 1e-5 else 1e-6
    h0 = min(h0, t_stop - memory[M_T])
    for i in range(y.size):
        probe[i] = y[i] + h0 * F1[i]
    if _f(table, probe, slope, flags, engine.OP_RHS, memory[M_T] + h0) != ed.OK:
        return h0
    for i in range(y.size):
        slope[i] = (slope[i] - F1[i]) / h0
    d2 = _norm(slope, weight)
    big = max(d1, d2)
    h1 = (0.01 / big) ** memory[M_EXPONENT] if big > 1e-15 else max(1e-6, 1e-3 * h0)
    return min(100.0 * h0, h1)


@kernel
def _mass_form_residual(table, z, base, hg, delta, flags, t):
    """delta (2 NDOF,) = [base_q + hg v - q; hg g], the stage residual with its velocity half
    in mass form, for z = [q, v]: g = M_bar (qddot(z) - a_c) (N, N m; `engine.stage_force`)
    for the candidate accelerations a_c = (v - base_v) / hg, so that hg g = M_bar r2 where
    r2 = base_v + hg qddot(z) - v is the velocity half of the accelerations' residual. Counted
    as an evaluation of f (flags[I_RHS], counters[RHS_COUNT]; the engine counts it in
    counters[EVALUATIONS]); its status."""
    m = z.size // 2
    acc = delta[m:]
    for k in range(m):
        acc[k] = (z[m + k] - base[m + k]) / hg
    flags[I_RHS] += 1
    counters = access.counters(table)
    counters[ed.RHS_COUNT] += 1
    status = call_engine(access.dims(table)[ed.ENGINE], OP_STAGE_FORCE, table, t, z.ctypes.data,
                         acc.ctypes.data, acc.ctypes.data, FORCE)
    if status != ed.OK:
        counters[ed.FAILED_STATUS] = status
        return status
    for k in range(m):
        delta[k] = base[k] + hg * z[m + k] - z[k]
        delta[m + k] = hg * acc[k]
    return ed.OK


@kernel(inline="always")
def consistent_positions(z, base, hg):
    """z's position half = base_q + hg v for z = [q, v] (2 NDOF,; hg in s): the stage
    equation's linear half q = base_q + hg v solved exactly, so that its residual r1 is zero
    to the bit (`_mass_form_residual` forms it by the same expression) and the sparse Newton
    force solve skips J's solve and K_x's product of r1 (`engine.newton.solve`). Why it
    changes nothing but the iterates: a Newton correction satisfies the linear half exactly
    (dq = r1 + hg dv), so every iterate after a stage's first is on it anyway, to round-off;
    the first moves from base_q + hg (extrapolated velocity) to base_q + hg (predicted v),
    of the same first-order accuracy, and the root is the same. On the sparse path in either
    residual form (the accelerations' is for comparison: the same iterates but for the
    residual's form); the dense path keeps its iterates."""
    m = z.size // 2
    for k in range(m):
        z[k] = base[k] + hg * z[m + k]


@kernel
def _stage(table, i, h, memory, flags, vectors, J, LU, piv, A, P):
    """Solve stage i: z = base + h g f(z) by simplified Newton; F_i from the stage equation.
    True when it converged. On the sparse Newton matrix (flags[I_REDUCED] = SPARSE_FACTORS,
    flags[I_MASS_FORM] = 1) the residual's velocity half is taken in mass form
    (`_mass_form_residual`), which needs no factorisation of the augmented system per
    iteration: the same root, iterates that differ by (M_bar(z) - M_bar at the Jacobian's
    state) r2, second order in the residual; and on that matrix the iterates keep their
    positions on the stage equation's linear half (`consistent_positions`)."""
    n = piv.size
    base, z, delta, weight = vectors[V_BASE], vectors[V_Z], vectors[V_DELTA], vectors[V_WEIGHT]
    y, F = vectors[V_Y], vectors[V_F:]
    hg = h * A[1, 1]
    # the last step's history (`keep_history`, where the tableau takes it): its mean slope
    # for stage 2, its curvature for stage 3
    history, weight_of_history = vectors[V_SLOPE], 0.0
    if flags[I_HISTORY] == 1 and i <= 2:
        c2, ci = A[1, 0] + A[1, 1], 0.0
        for j in range(i + 1):
            ci += A[i, j]
        if i == 1:
            weight_of_history = c2 * h
        else:
            history, weight_of_history = vectors[V_CURVATURE], ci * (ci - c2) * h * h
    for k in range(n):
        s = y[k]
        for j in range(i):
            s += h * A[i, j] * F[j, k]
        base[k] = s
        p = weight_of_history * history[k]
        for j in range(i):
            p += P[i, j] * F[j, k]
        z[k] = s + hg * p  # f(z_i) predicted by extrapolating the stages before
    sparse = flags[I_REDUCED] == SPARSE_FACTORS
    mass_form = sparse and flags[I_MASS_FORM] == 1
    if sparse:
        consistent_positions(z, base, hg)
    c_i = 0.0  # the stage's time is t + c_i h
    for j in range(i + 1):
        c_i += A[i, j]
    t_stage = memory[M_T] + c_i * h
    # the last contraction estimate, let grow once per step (its first implicit stage), as
    # RADAU5 does once per step for its one Newton over all stages, once it has gone
    # unmeasured for flags[I_ETA_HOLD] accepted steps (`ETA_HOLD`)
    eta = max(memory[M_ETA], 1e-16)
    if i == 1 and flags[I_ETA_AGE] >= flags[I_ETA_HOLD]:
        eta = eta ** 0.8
    previous = 0.0
    for iteration in range(MAX_NEWTON):
        if mass_form:
            if _mass_form_residual(table, z, base, hg, delta, flags, t_stage) != ed.OK:
                return False
            newton_matrix.sparse_force_solve(table, memory[M_H_LU], delta)
        else:
            if _f(table, z, F[i], flags, engine.OP_RHS, t_stage) != ed.OK:
                return False
            for k in range(n):
                delta[k] = base[k] + hg * F[i, k] - z[k]
            solve(table, J, LU, piv, memory, flags, delta)
        for k in range(n):
            z[k] += delta[k]
        if sparse:
            consistent_positions(z, base, hg)
        norm = _norm(delta, weight)
        if not np.isfinite(norm):
            return False
        if iteration > 0:
            theta = norm / previous
            if theta >= THETA_STALE:  # an iteration the Jacobian's age cost
                flags[I_EXTRA] += 1
            if theta >= 0.99:
                return False
            # a slow contraction that converges asks for no new J of its own: its iterations
            # count in flags[I_EXTRA] against the cost of one (JACOBIAN_COST); on
            # manipulator_reduced a J costs about 110 evaluations (docs/benchmarks.md)
            eta = theta / (1.0 - theta)
            flags[I_ETA_AGE] = 0
        if eta * norm <= NEWTON_TOLERANCE or norm == 0.0:
            memory[M_ETA] = eta
            for k in range(n):
                F[i, k] = (z[k] - base[k]) / hg
            return True
        previous = norm
    return False


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
            ok = counters[ed.EVALUATIONS] == flags[I_EVALUATION] and call_engine(
                dims[ed.ENGINE], engine.OP_INPUT_RESPONSE, table, 0.0, delta.ctypes.data, 0, 0,
                0.0) == ed.OK
            for j in range(dims[ed.NDOF] if ok else 0):
                F[0, dims[ed.NDOF] + j] += delta[j]
            flags[I_FSAL] = FSAL_CURRENT if ok else FSAL_NONE
        if flags[I_FSAL] == FSAL_NONE:  # a restart: no history either
            if _f(table, y, F[0], flags, engine.OP_RHS, t) != ed.OK:
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
        if flags[I_EXTRA] >= max(1.0, JACOBIAN_COST * n):
            flags[I_REFRESH] = 1
        if flags[I_REFRESH] == 1 or flags[I_JACOBIAN] == 0:
            if _f(table, y, J, flags, engine.OP_JACOBIAN, t) != ed.OK:
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
            if not _stage(table, i, h, memory, flags, vectors, J, LU, piv, A, P):
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
        error = _norm(err, weight)
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
