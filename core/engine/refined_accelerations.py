"""The evaluation's accelerations by iterative refinement with kept factors, on rigid clusters.

`motion.evaluate` solves the augmented system on the reduced free coordinates z,

    A d = b,   A = [M_ff J_o^T; J_o 0],   b = [T^T (r - M c) (+ the folded clusters'); -h_o],

by assembling A element by element and factoring it. On manipulator_control that is 140 of
the 195 us of one right-hand side: the assembly 106 us (each touching element's
T_e^T Dp^T Mp Dp T_e, the folded clusters' rigid bodies), the sparse LU 32 us
(examples/benchmarks/manipulator_rhs_profile.py). A depends on the coordinates alone, so the
factors of A at an earlier state (dims[A_KEPT], `factors`) solve it by iterative refinement
as `refinement` does for the input response:

    d_1 = A_kept^-1 b,    d_{k+1} = d_k + A_kept^-1 (b - A d_k)

with b - A d_k formed element by element without assembling A: the first rows are
T^T (r - M (T d_f + c)) less J_o^T d_lambda with the folded clusters' forces, whose element
pass is `inertia_product.element_products` over the points' Dp alone; the rigid rows
-h_o - J_o d_f (`refinement.constraint_products`). b itself is the residual at d = 0. The
element masses' gravity and -g_conv are added into r once, as `motion.inertia_forces` leaves
them in slot force for the tangent, in the same element pass as the first residual
(`inertia_product.forces_and_products`: each element's points evaluated once for both, 4 to
7 % off an rhs on manipulator_control). One product costs an element pass, the rigid rows
and a solve with the kept factors (about 22 us on manipulator_control).

Warm start. When slot augmented_rhs still holds the last evaluation's solution (its first
n_free entries equal the free coordinates' accelerations that evaluation left in slot xddot,
bit for bit: a stage force or an input response in between leaves other vectors there), the
refinement starts from it, d_0 = that solution, instead of from d_1 = A_kept^-1 b: b is not
formed (one element pass and a solve fewer) and an rhs asked again at a state, or at one a
Newton correction away, is done in one product. The first correction from a warm start says
how far d_0 was, not how fast A_kept contracts, so it neither gives up on its rate nor is
accepted on its size; only the round-off floor below accepts it. It leaves the error
rho |d_0 - d| where A_kept^-1 b leaves rho |d|, and a warm start may take one product more
than MAX_PRODUCTS (the one that b and d_1 would have cost): along a CVODE run of
manipulator_control under 1 N on every input (steps of 80 us) the solution moves by about
0.1 of itself a step (0.03 to 0.2), rho is 1e-4 to 4e-4, and three products from d_0 fell short of
1e-12 every second to fourth state, each time paying the products and the factorisation.

Convergence as `refinement`'s: the corrections c_k shrink by about rho, the spectral radius
of I - A_kept^-1 A, so the error left after c_k is about rho / (1 - rho) |c_k| (max norms
over d_f, the accelerations on z, m/s^2 and 1/s^2 on the Euler parameters, which the
evaluation returns; the multipliers feed only the next residual). Accepted when that
estimate, rho from two corrections, or a correction itself, is at most TOLERANCE = 1e-12 of
max |d_f|: ten times the round-off of the direct sparse solve (1e-13 of d_f against a dense
solve on the manipulator, the condition of A 8e4). Where the accelerations are small beside
the forces that A balances, that solve's own round-off exceeds 1e-12 of d_f (2e-12 m/s^2
against max |d_f| = 0.12 at the 6 mm move's state of fastest motion, whose b_f is 10 N):
the residual b - A d_k is then at its round-off before the corrections shrink to the
tolerance, and d_k + c_k is accepted when both blocks of that residual are at most
RESIDUAL_FLOOR = 1e-14 (45 ulps) of the scales of b, max |T^T r| on z and max |h| on the
rigid rows (measured 4e-16 and 5e-16 of them there), the error left being that of a solve
whose backward error is that residual. At rest (h = 0) the floor does not apply.

Given up, the evaluation then assembles and factors A at its state (whose factors are kept
for the next), when a rate exceeds RATE_LIMIT = 0.1, when a correction is not finite, or
after MAX_PRODUCTS = 3 products (three products and the residual at 0 cost about as much as
the assembly they replace).

Only for models with rigid clusters and the sparse Newton matrix (dims NSLAVES > 0 and
NEWTON_SPARSE = 1: the augmented form, no coil currents, no kinematic inputs), where the
assembly dominates; reached through OP_STAGE_FORCE (s = REFINED_ACCELERATIONS), which
`engine.connect` gives every such model, so that a model without them compiles none of it.
Units: b and A d in N, N m (first rows) and m/s^2 (rigid rows), d in m/s^2, 1/s^2 and N, N m
(multipliers).
"""

import numpy as np

from ..numerics.dense import copy
from ..numerics.jit import kernel
from ..numerics.native import call_engine
from . import data as ed
from . import slots as slot
from .factors import KEPT_NONE, KEPT_SPARSE, kept_resolve
from .inertia_product import element_products, forces_and_products, spread_accelerations
from .operations import ALONE, OP_RIGID_BODIES, OP_RIGID_CONDENSE, WITH_FORCE, run
from .refinement import constraint_products, largest
from .rigid_inertia_kernels import PRODUCT_AT_REST, PRODUCT_MOVING
from .slots import float_array as _f
from .slots import int_array as _i

TOLERANCE = 1e-12  # the estimated error of d_f accepted, relative to max |d_f|
RATE_LIMIT = 0.1  # a larger estimated contraction rate: factor A at the current state
MAX_PRODUCTS = 3  # products A d_k after the first solve, before that
RESIDUAL_FLOOR = 1e-14  # |b - A d| at most this of b's scale (each block): d + c is final


@kernel
def refined_accelerations(table, moving, rhs):
    """rhs (na,) = A^-1 b at the state the evaluation's front half left in the slots (x,
    xdot, the slaves' c, slot force r before the element masses, h in slots g and rigid_h),
    by refinement with the kept factors (the module's docstring); slot force then holds r
    with the element masses' gravity and -g_conv, as `motion.inertia_forces` leaves it.
    Returns ed.OK when converged; ed.NOT_AVAILABLE, with b in rhs, when the caller has to
    assemble and factor A at this state (no factors kept, too slow a contraction, a
    correction not finite). rhs holds on entry the last evaluation's solution when it still
    does (`warm_start`), the first iterate then. Works in slot refinement."""
    dims = _i(table, slot.DIMS)
    nf, nx = dims[ed.NFREE], dims[ed.NX]
    na = nf + dims[ed.NRIGID]
    work = _f(table, slot.REFINEMENT)
    b, d, c = work[:na], work[na: 2 * na], work[2 * na: 3 * na]
    a, total = work[3 * na: 3 * na + nx], work[3 * na + nx: 3 * na + 2 * nx]
    kept = dims[ed.A_KEPT]
    warm = kept != KEPT_NONE and warm_start(table, rhs)
    if warm:
        copy(d, rhs[:na])
    else:
        d[:] = 0.0
    # r += the element masses' gravity and -g_conv, and the first residual, at d_0 (into c:
    # the first correction's) or at 0 (b), in one element pass
    residual(table, moving, d, a, total, c if warm else b, True)
    if not warm:
        copy(rhs[:na], b)
        if kept == KEPT_NONE:
            return ed.NOT_AVAILABLE
    sparse = kept == KEPT_SPARSE
    # the scales of the residual's round-off: T^T r on z (slot dx, from the first
    # residual's pass over T), h on the rigid rows
    force_scale, h_scale = largest(_f(table, slot.DX), nf), 0.0
    if moving:
        quad, rigid_h = _f(table, slot.G), _f(table, slot.RIGID_H)
        for o in range(na - nf):
            h_scale = max(h_scale, abs(quad[o] + rigid_h[o]))
    if not warm:
        copy(d, b)
        kept_resolve(table, sparse, na, d)  # d_1
    previous = largest(d, nf)
    if not np.isfinite(previous):
        return give_up(table, moving, warm, rhs)
    if previous == 0.0 and not warm:  # b is zero on z: so is d_f, exactly
        copy(rhs[:na], d)
        return ed.OK
    for k in range(MAX_PRODUCTS + 1 if warm else MAX_PRODUCTS):  # warm: b's pass saved
        if k > 0 or not warm:  # c = b - A d (from a warm start formed above)
            residual(table, moving, d, a, total, c, False)
        # the residual at the round-off of b: d + c is as close as the direct solve gets
        floor = (largest(c, nf) <= RESIDUAL_FLOOR * force_scale
                 and largest(c[nf:], na - nf) <= RESIDUAL_FLOOR * h_scale)
        kept_resolve(table, sparse, na, c)
        size = largest(c, nf)
        if not np.isfinite(size):
            return give_up(table, moving, warm, rhs)
        for i in range(na):
            d[i] += c[i]
        scale = TOLERANCE * largest(d, nf)
        rate = size / previous
        previous = size
        if floor:
            copy(rhs[:na], d)
            return ed.OK
        if warm and k == 0:  # rate: how far the warm start was, not the contraction
            continue
        # as `refinement.refined_solve`: a correction within the tolerance, or from the
        # second on the rate of two corrections
        if size <= scale or (k > 0 and rate <= RATE_LIMIT
                             and rate * size <= (1.0 - rate) * scale):
            copy(rhs[:na], d)
            return ed.OK
        if rate > RATE_LIMIT:
            return give_up(table, moving, warm, rhs)
    return give_up(table, moving, warm, rhs)


@kernel
def warm_start(table, rhs):
    """Whether rhs (slot augmented_rhs) still holds the last evaluation's solution, which
    `motion.qddot_of_solution` copied onto the free coordinates of slot xddot: equal there
    bit for bit and finite (a stage force and an input response leave other vectors in it,
    a stage force other accelerations in slot xddot)."""
    dims = _i(table, slot.DIMS)
    free, xddot = _i(table, slot.FREE), _f(table, slot.XDDOT)
    for k in range(dims[ed.NFREE]):
        if rhs[k] != xddot[free[k]]:
            return False
    for k in range(dims[ed.NFREE] + dims[ed.NRIGID]):
        if not np.isfinite(rhs[k]):
            return False
    return True


@kernel
def give_up(table, moving, warm, rhs):
    """ed.NOT_AVAILABLE with b in rhs (formed now after a warm start, which did not)."""
    dims = _i(table, slot.DIMS)
    nf, nx = dims[ed.NFREE], dims[ed.NX]
    na = nf + dims[ed.NRIGID]
    work = _f(table, slot.REFINEMENT)
    if warm:
        d = work[na: 2 * na]
        d[:] = 0.0
        residual(table, moving, d, work[3 * na: 3 * na + nx], work[3 * na + nx: 3 * na + 2 * nx],
                 work[:na], False)
    copy(rhs[:na], work[:na])
    return ed.NOT_AVAILABLE


@kernel
def residual(table, moving, d, a, total, out, with_forces):
    """out (na,) = b - A d for the augmented system at the state in the slots, slot force r
    holding the element masses' gravity and -g_conv (with_forces: not yet; they are added to
    it here, in the same element pass as the product: `inertia_product.forces_and_products`):
    first rows T^T (r - M (T d_f + c)) with the folded clusters' forces, less J_o^T
    d_lambda; rigid rows -h_o - J_o d_f; with_forces also T^T r (r completed) into slot dx.
    a, total (NX,) scratch (`inertia_product.force_minus_mass`'s)."""
    dims = _i(table, slot.DIMS)
    nf, n_rigid = dims[ed.NFREE], dims[ed.NRIGID]
    x, xdot, r = _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.FORCE)
    copy(total, r)
    spread_accelerations(table, d[:nf], moving, a, total)  # a = T d_f + c
    if with_forces:  # r += Dp^T Mp (g_p - (D2p v) v), total += that - Dp^T Mp Dp a_e
        forces_and_products(table, x, xdot, moving, a, r, total)
    else:  # - Dp^T Mp Dp a_e
        element_products(table, x, xdot, False, False, a, total)
    if _i(table, slot.RIGID_BODIES).size:  # the folded clusters' gravity, -g_conv, -M a
        call_engine(dims[ed.ENGINE], OP_RIGID_BODIES, table, 0.0, a.ctypes.data,
                    total.ctypes.data, 0, PRODUCT_MOVING if moving else PRODUCT_AT_REST)
    # T^T; with_forces also of the completed r into slot dx (`refined_accelerations`' scale)
    run(table, OP_RIGID_CONDENSE, total.ctypes.data, out.ctypes.data,
        WITH_FORCE if with_forces else ALONE)
    quad, rigid_h = _f(table, slot.G), _f(table, slot.RIGID_H)
    for o in range(n_rigid):
        out[nf + o] = -(quad[o] + rigid_h[o]) if moving else 0.0
    constraint_products(table, d, out)
