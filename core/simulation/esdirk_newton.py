"""The compiled ESDIRK's stages: each stage equation z = base + h g f(z) solved by
simplified Newton with the Newton matrix's factors (dense, its Schur complement, or the
engine's sparse ones: `newton_matrix`), the residual's velocity half in mass form on the
sparse path, and the Newton tolerance and Jacobian-age rules. `esdirk_kernels.advance` calls
`solve_stage` for each implicit stage of a step.
"""

import numpy as np

from ..engine import access, engine
from ..engine import data as ed
from ..engine.operations import FORCE, OP_NEWTON_JACOBIAN, OP_STAGE_FORCE
from ..numerics.jit import kernel
from ..numerics.native import call_engine
from . import newton_matrix
from .esdirk_layout import (
    I_ETA_AGE,
    I_ETA_HOLD,
    I_EXTRA,
    I_FACTORIZATIONS,
    I_HISTORY,
    I_JACOBIANS,
    I_MASS_FORM,
    I_REDUCED,
    I_RHS,
    M_ETA,
    M_H_LU,
    M_T,
    SPARSE_FACTORS,
    V_BASE,
    V_CURVATURE,
    V_DELTA,
    V_F,
    V_SLOPE,
    V_WEIGHT,
    V_Y,
    V_Z,
)
from .newton_matrix import newton_solve

NEWTON_TOLERANCE = 0.05   # eta |dz| in the weighted norm (1 = the error the step may make)
MAX_NEWTON = 7
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
# On the sparse Newton matrix (`newton_matrix`) a J costs a number of iterations that does not
# grow with n: a J and the Newton matrix's factors over one stage iteration (a stage force and
# its force solve; CPU at states a sample apart) 8.2 on manipulator_control (150 states), 7.8
# on manipulator_reduced (1014), 4.6 on the 384-DOF cantilever (768), where n / 4 says 37.5,
# 253 and 192. Not 8: the iterations counted are not all the age's (a fresh J leaves 1.2 a
# stage on manipulator_control, 1.9 on manipulator_reduced), and a J at 8 cost
# manipulator_control's loop 1.09 to 1.24 of its CPU. 40, about five J's worth, keeps its n / 4
# (37.5, the same bits) and renews manipulator_reduced's J every 8 to 9 samples, not 12: its
# closed loop at rtol 1e-4 in 0.86 to 0.90 of the CPU at 0.93 of the positions' error, its
# replay at 5e-5 in 0.83 to 0.90 of 1e-4's CPU at 0.90 of its q error (docs/benchmarks.md,
# session 40)
SPARSE_JACOBIAN_COST = 40.0  # evaluations
THETA_STALE = 0.01
# Accepted steps the Newton contraction estimate eta is trusted unmeasured before it grows
# at a step's first implicit stage (flags[I_ETA_HOLD], set by `Esdirk`: on the sparse Newton
# matrix, whose J stays current for long; 0, growth at every step, on the dense path, where
# it cost accuracy on stage_planar_3dof). On the cantilevers 0.90 to 0.99 of the evaluations
# at their errors; an eta unmeasured for 10 steps grows again, so a stale J is still found
# (docs/benchmarks.md, session 35)
ETA_HOLD = 10


@kernel(inline="always")
def jacobian_cost(n, sparse):
    """The Newton iterations a Jacobian's age may cost (flags[I_EXTRA]) before the next step
    takes a new one, for n states: the cost of a new J in evaluations of f, JACOBIAN_COST n on
    the dense path, SPARSE_JACOBIAN_COST (at most the dense path's) on the sparse Newton
    matrix (`sparse`); at least 1."""
    cost = JACOBIAN_COST * n
    if sparse:
        cost = min(cost, SPARSE_JACOBIAN_COST)
    return max(1.0, cost)


@kernel
def evaluate(table, y, out, flags, op, t):
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
def weighted_norm(v, weight):
    """Weighted RMS norm sqrt(mean((v_i weight_i)^2))."""
    s = 0.0
    for i in range(v.size):
        s += (v[i] * weight[i]) ** 2
    return np.sqrt(s / v.size)


@kernel
def mass_form_residual(table, z, base, hg, delta, flags, t):
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
    to the bit (`mass_form_residual` forms it by the same expression) and the sparse Newton
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
def solve_stage(table, i, h, memory, flags, vectors, J, LU, piv, A, P):
    """Solve stage i: z = base + h g f(z) by simplified Newton; F_i from the stage equation.
    True when it converged. On the sparse Newton matrix (flags[I_REDUCED] = SPARSE_FACTORS,
    flags[I_MASS_FORM] = 1) the residual's velocity half is taken in mass form
    (`mass_form_residual`), which needs no factorisation of the augmented system per
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
            if mass_form_residual(table, z, base, hg, delta, flags, t_stage) != ed.OK:
                return False
            newton_matrix.sparse_force_solve(table, memory[M_H_LU], delta)
        else:
            if evaluate(table, z, F[i], flags, engine.OP_RHS, t_stage) != ed.OK:
                return False
            for k in range(n):
                delta[k] = base[k] + hg * F[i, k] - z[k]
            solve(table, J, LU, piv, memory, flags, delta)
        for k in range(n):
            z[k] += delta[k]
        if sparse:
            consistent_positions(z, base, hg)
        norm = weighted_norm(delta, weight)
        if not np.isfinite(norm):
            return False
        if iteration > 0:
            theta = norm / previous
            if theta >= THETA_STALE:  # an iteration the Jacobian's age cost
                flags[I_EXTRA] += 1
            if theta >= 0.99:
                return False
            # a slow contraction that converges asks for no new J of its own: its iterations
            # count in flags[I_EXTRA] against the cost of one (`jacobian_cost`)
            eta = theta / (1.0 - theta)
            flags[I_ETA_AGE] = 0
        if eta * norm <= NEWTON_TOLERANCE or norm == 0.0:
            memory[M_ETA] = eta
            for k in range(n):
                F[i, k] = (z[k] - base[k]) / hg
            return True
        previous = norm
    return False
