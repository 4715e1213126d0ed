"""The augmented system at the current state solved with the factors of an earlier one.

After a stage force in mass form (`stage_force`) the slots hold a state whose augmented
system A = [M_ff J_o^T; J_o 0] (`motion.evaluate`) is neither assembled nor factored, while
the storage still holds the factors of A_kept, the same system at an earlier state
(dims[A_KEPT], `factors`). The input response (`input_response`) needs A^-1 b at the
current state. Iterative refinement with the kept factors gives it without assembling or
factoring A:

    d_1 = A_kept^-1 b,    d_{k+1} = d_k + A_kept^-1 (b - A d_k)

where A d comes element by element: M_ff d_f by `inertia_product.minus_mass_product` (the
element masses' points, T and T^T with rigid clusters), J_o d_f and J_o^T d_lambda from the
rigid rows' De (`constraint_products`). The error contracts by rho, the spectral radius of
I - A_kept^-1 A, which grows with the distance between the two states: on the 6 mm move of
manipulator_control about 1.1e-4 per sample of the kept factors' age (and d_1 is off by
about 7e-6 of d per sample). A product costs about 40 us there (the element pass without
the kinematics, the rigid rows, a solve with the kept factors) against 220 us for FACTOR_A's
assembly and factorisation (docs/benchmarks.md, session 35).

Convergence. The corrections c_k = d_{k+1} - d_k shrink by about rho each, so the error left
in d_{k+1} is about rho / (1 - rho) |c_k|, rho estimated as |c_k| / |c_{k-1}| (max norms over
the free coordinates' accelerations d_f, which the response returns; the multipliers only
feed the next residual). The solve is accepted when that estimate is at most TOLERANCE =
1e-12 of max |d_f|, from the second product on: the first ratio, |c_1| / |d_1|, measures how
far d_1 is, not the contraction (which it underestimates 15-fold on the manipulator); or at
once when a correction is itself within the tolerance (the error left is then at most rho /
(1 - rho) of it, and near round-off the ratio of two corrections is noise). Why 1e-12: it
is ten times the round-off of the direct sparse solve it replaces (1e-13 of d_f against
numpy's dense solve on the manipulator, whose A has the condition 8e4). The response enters
the ESDIRK's first stage as F_1 = F(y_n) + [0; d qddot], so its error moves the step's
velocities by at most h b_1 1e-12 |d qddot| (b_1 <= 1/2): 1e-12 of the change the input
step itself makes in one step. The stage Newton stops at 0.05 of rtol |v| + atol, and the
error estimate is formed from the converged stages, so neither can tell the refined response
from the exact one while one step's input change moves the velocities by less than 1e11
rtol of themselves (at the loop's rtol 1e-5: a million times; at rtol 1e-11, the tightest
the tests run, by their own size).

A caller that knows what error it can carry gives a bound instead (`refined_solve_within`):
error weights w (NDOF,) on the response's accelerations d qddot, the solve accepted also when
the same two estimates, taken on the correction's d qddot in sqrt(mean((w_j e_j)^2)), are at
most 1 (`weighted_size`). The ESDIRK gives w from its next step and its velocity weights
(`esdirk_kernels.response_weights`), so that the response's error moves a step by at most a
small share of the stage Newton's own tolerance whatever the response's size: at the loop's
rtol 1e-5 1.75 products a response instead of 2.9, and no factorisation of A in the 6 mm
move instead of 338 (docs/benchmarks.md, session 36). The fixed TOLERANCE still
accepts too: the bound never costs a product more. The rule "1e-3 of rtol" relative to
max |d_f| was measured and not kept (session 35): where the forces jump far beyond the
velocities' scale every sample (manipulator_reduced's 5 ms move) the response's error, which
a retried step shrinks only as h, failed the error test; a bound in the step's own norm
scales with h and the velocities, not with |d|.

The solve gives up, and the caller factors A at the current state (then the kept factors),
when no factors are kept, when an estimated rate exceeds RATE_LIMIT = 0.1 (the states are
too far apart: a product would buy less than a digit), when a correction is not finite, or
after MAX_PRODUCTS = 3 products: two suffice while the kept factors are a sample or two old,
three up to about 18 samples; a fourth would make the refinement cost more than a
factorisation shared by the samples after it. Units: b and A d in N, N m (first rows) and
m/s^2 (rigid rows), d in m/s^2, 1/s^2 (Euler parameters) and N, N m (multipliers).
"""

import numpy as np

from ..numerics.dense import copy
from ..numerics.jit import kernel
from ..numerics.sparse_lu import unsigned_index as _u
from . import data as ed
from . import slots as slot
from .factors import KEPT_NONE, KEPT_SPARSE, kept_resolve
from .inertia_product import minus_mass_product
from .motion import qddot_of_solution
from .rigid_kernels import touching_row
from .slots import float_array as _f
from .slots import group, group_deformations, rigid_element
from .slots import int_array as _i

TOLERANCE = 1e-12  # the estimated error of d_f accepted, relative to max |d_f|
RATE_LIMIT = 0.1  # a larger estimated contraction rate: factor A at the current state
MAX_PRODUCTS = 3  # products A d_k before that


@kernel
def refined_solve(table, na, rhs):
    """rhs (na,) <- A^-1 rhs at the current state by refinement with the kept factors, to
    TOLERANCE of max |d_f| (the module's docstring); True when converged, False (rhs as
    given) when the caller has to factor A at the current state. Works in slot refinement."""
    return refined_solve_within(table, na, rhs, rhs[:0], rhs[:0], rhs[:0])


@kernel
def refined_solve_within(table, na, rhs, weights, xddot, qddot):
    """`refined_solve`, accepting also an error of the response qddot (NDOF,) whose weighted
    RMS sqrt(mean((weights_j e_j)^2)) is estimated at most 1 (weights in s^2/m, s^2/rad:
    the caller's bound, `weighted_size`); with empty weights TOLERANCE alone. xddot (NX,)
    and qddot (NDOF,) are scratch for the correction's qddot when weights are given.
    Never more products than TOLERANCE alone takes: its test still accepts."""
    dims = _i(table, slot.DIMS)
    kept = dims[ed.A_KEPT]
    if kept == KEPT_NONE:
        return False
    sparse = kept == KEPT_SPARSE
    nf, nx = dims[ed.NFREE], dims[ed.NX]
    work = _f(table, slot.REFINEMENT)
    b, d, c = work[:na], work[na: 2 * na], work[2 * na: 3 * na]
    a, total = work[3 * na: 3 * na + nx], work[3 * na + nx: 3 * na + 2 * nx]
    copy(b, rhs[:na])
    copy(d, b)
    kept_resolve(table, sparse, na, d)  # d_1
    previous = largest(d, nf)
    if not np.isfinite(previous):
        return False
    counters = _i(table, slot.COUNTERS)
    if previous == 0.0:  # b is zero on what the response reads: so is d_f, exactly
        copy(rhs[:na], d)
        counters[ed.REFINED_RESPONSES] += 1
        return True
    bounded = weights.size > 0
    for k in range(MAX_PRODUCTS):
        counters[ed.REFINEMENT_PRODUCTS] += 1
        minus_mass_product(table, d[:nf], a, total, c[:nf])  # c = b - A d
        for i in range(nf):
            c[i] += b[i]
        for i in range(nf, na):
            c[i] = b[i]
        constraint_products(table, d, c)
        kept_resolve(table, sparse, na, c)
        size = largest(c, nf)
        if not np.isfinite(size):
            return False
        for i in range(na):
            d[i] += c[i]
        scale = TOLERANCE * largest(d, nf)
        rate = size / previous
        # a correction within the tolerance leaves at most rate / (1 - rate) of it, however
        # rate is estimated (near round-off the ratio of two corrections is noise); else
        # the rate of two refinement corrections, from the second product on, says what is
        # left. The caller's weighted bound by the same two rules, on the correction's qddot
        accepted = size <= scale or (k > 0 and rate <= RATE_LIMIT
                                     and rate * size <= (1.0 - rate) * scale)
        if bounded and not accepted:
            weighted = weighted_size(table, c, weights, xddot, qddot)
            accepted = weighted <= 1.0 or (k > 0 and rate <= RATE_LIMIT
                                           and rate * weighted <= 1.0 - rate)
        if accepted:
            copy(rhs[:na], d)
            counters[ed.REFINED_RESPONSES] += 1
            return True
        if rate > RATE_LIMIT:
            return False
        previous = size
    return False


@kernel
def weighted_size(table, c, weights, xddot, qddot):
    """sqrt(mean((weights_j qddot_j)^2)) over the NDOF accelerations qddot (m/s^2, rad/s^2)
    that the augmented system's solution c (its free coordinates' part) makes
    (`motion.qddot_of_solution` without the slaves' c or h: a change of the solution, as the
    response is); xddot (NX,) and qddot (NDOF,) scratch."""
    qddot_of_solution(table, c, xddot, False, c, False, qddot)
    s = 0.0
    for j in range(qddot.size):
        s += (weights[j] * qddot[j]) ** 2
    return np.sqrt(s / qddot.size)


@kernel
def largest(v, n):
    """max |v_k| over the first n entries (inf when one is not finite)."""
    out = 0.0
    for k in range(n):
        if not np.isfinite(v[k]):
            return np.inf
        out = max(out, abs(v[k]))
    return out


@kernel
def constraint_products(table, d, out):
    """out[:n_free] -= J_o^T d[n_free:] and out[n_free:] -= J_o d[:n_free] (d, out (na,)): A's
    rigid rows and columns times d, from the rigid rows' De at the current state (slot de;
    a touching element's De_z in slot rigid_de), as `factors.add_rigid_rows` places them."""
    dims = _i(table, slot.DIMS)
    nf, n_rigid = dims[ed.NFREE], dims[ed.NRIGID]
    rigid = dims[ed.NSLAVES] > 0
    row_of_def, col_of_coord = _i(table, slot.ROW_OF_DEF), _i(table, slot.COL_OF_COORD)
    rde = _f(table, slot.RIGID_DE)
    for j in range(_i(table, slot.TOUCHING_ROWS).size // 3):  # empty without clusters
        o, coords, de, z, at = touching_row(table, j)
        if o >= n_rigid:
            continue
        # the rigid row's sum in a register (c < n_free: out[c] is never it), the same
        # subtractions in the same order; unsigned indices: no test for one from the end
        s, dl = out[nf + o], d[nf + o]
        for a in range(z.size):
            c = col_of_coord[_u(z[a])]
            if c >= 0:
                v = rde[_u(at + a)]
                s -= v * d[_u(c)]
                out[_u(c)] -= v * dl
        out[nf + o] = s
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = group_deformations(table, g)
        row = group(table, g)
        for i in range(n):
            if rigid and rigid_element(table, row, i) >= 0:
                continue  # from its De_z above
            for b in range(k):
                o = row_of_def[defs[i * k + b]]
                if o < 0 or o >= n_rigid:
                    continue
                s, dl = out[nf + o], d[nf + o]  # as above
                for a in range(m):
                    c = col_of_coord[_u(coords[i * m + a])]
                    if c >= 0:
                        v = De[_u((i * k + b) * m + a)]
                        s -= v * d[_u(c)]
                        out[_u(c)] -= v * dl
                out[nf + o] = s
