"""The compiled evaluation engine: kinematics, inertia, equations of motion and their tangent.

One place computes, for DOFs q and velocities qdot (m, rad, m/s, rad/s) and the held inputs u
(N, N m), everything the integrators need, compiled with numba and cached on disk:

Kinematics. x = F(q) solves, on the free coordinates, e_o(x) = 0 (deformations prescribed
zero), e_m(x) = q_e (DOF deformations) and x_m = q_x (DOF coordinates). Warm start: the
first-order prediction x_prev + DF_prev (q - q_prev); if its residual exceeds the tolerance,
chord iterations with the previous LU of the constraint Jacobian J (converging at a rate of
order |dq| / L), and full Newton from there if they stall. Then J DF = [0; I] gives DF.

Equations of motion (the reduced form of the course notes):

    M_bar qddot = DF^T (f - M (D2F qdot) qdot - g_conv - De^T sigma_c),  M_bar = DF^T M DF

with f the constant loads, gravity and the inputs, sigma_c = S e + D edot on the stressed
deformations, M = diag(lumped) + sum Dp^T Mp Dp over the inertia points p of the element
masses, g_conv = sum Dp^T Mp (D2p xdot) xdot, and (D2F qdot) qdot = -J^-1 [xdot^T H_i xdot]
on the constraint rows. Gravity acts on the position points of the inertia, which are linear
in x for every element, so it has no tangent stiffness.

Tangent (the integrators' Newton matrix): mass M_bar, damping C0 = DeF_s^T D DeF_s and
stiffness K0 + G0, K0 = DeF_s^T S DeF_s, G0 = sum DF_e^T (sum_i sigma_i D2e_i) DF_e, with
sigma the stress resultants of the full dynamic balance (sigma_c plus the multipliers
J^-T (r - M DF qddot) on the constraint rows), DeF = De DF.

Everything works element by element on the packed arrays of `engine_data.EngineData` (no
dense (NX, NX) matrix is formed; M_bar is accumulated from (Dp DF_e)^T Mp (Dp DF_e)), and no
evaluation allocates. The plain-numpy twin of every quantity is in `kinematics`, `assembly`
and `mechanics` (used by the static analyses); tests compare the two to round-off.

Status codes (`engine_data`): each function returns OK or the reason it could not finish;
nothing raises inside compiled code.
"""

import numpy as np
from numba import carray, types

from . import engine_data as ed
from .jit import entry, kernel
from .native import as_float_pointer, as_int_pointer, call_deformations, call_inertia

# slot indices as compile-time constants
(_DIMS, _FREE, _ROWS, _DOF_COORDS, _DOF_DEFS, _DOF_POS, _STRESSED, _INPUT_COORDS, _GROUPS,
 _COORD_INDEX, _DEF_INDEX, _ROW_OF_DEF, _COL_OF_COORD, _PIVOTS, _MASS_PIVOTS,
 _COUNTERS) = range(len(ed.INT_SLOTS))
(_SETTINGS, _S, _D, _LUMPED, _CONST_FORCE, _GROUP_DATA, _INPUTS, _Q_REF, _X, _Q, _DF, _LU,
 _E, _DE, _D2E, _X_TRIAL, _G, _DX, _XDOT, _EDOT, _SIGMA, _FORCE, _MASS, _MASS_LU,
 _REDUCED_FORCE, _QDDOT, _CONV, _LOCAL, _DEF, _STIFFNESS, _DAMPING, _JAC_CACHE,
 _X_START) = range(len(ed.FLOAT_SLOTS))
_N_INT, _N_FLOAT = len(ed.INT_SLOTS), len(ed.FLOAT_SLOTS)


# -- from a C callback's user data to the arrays -----------------------------------------------
@kernel
def unpack(user_data):
    """(ints, floats) tuples of the arrays whose (address, length) table is at user_data."""
    table = carray(as_int_pointer(user_data), (2 * (_N_INT + _N_FLOAT),))
    ints = (
        _ints(table, 0), _ints(table, 1), _ints(table, 2), _ints(table, 3), _ints(table, 4),
        _ints(table, 5), _ints(table, 6), _ints(table, 7), _ints(table, 8), _ints(table, 9),
        _ints(table, 10), _ints(table, 11), _ints(table, 12), _ints(table, 13),
        _ints(table, 14), _ints(table, 15))
    o = _N_INT
    floats = (
        _floats(table, o), _floats(table, o + 1), _floats(table, o + 2), _floats(table, o + 3),
        _floats(table, o + 4), _floats(table, o + 5), _floats(table, o + 6),
        _floats(table, o + 7), _floats(table, o + 8), _floats(table, o + 9),
        _floats(table, o + 10), _floats(table, o + 11), _floats(table, o + 12),
        _floats(table, o + 13), _floats(table, o + 14), _floats(table, o + 15),
        _floats(table, o + 16), _floats(table, o + 17), _floats(table, o + 18),
        _floats(table, o + 19), _floats(table, o + 20), _floats(table, o + 21),
        _floats(table, o + 22), _floats(table, o + 23), _floats(table, o + 24),
        _floats(table, o + 25), _floats(table, o + 26), _floats(table, o + 27),
        _floats(table, o + 28), _floats(table, o + 29), _floats(table, o + 30),
        _floats(table, o + 31), _floats(table, o + 32))
    return ints, floats


@kernel(inline="always")
def _ints(table, slot):
    return carray(as_int_pointer(table[2 * slot]), (table[2 * slot + 1],))


@kernel(inline="always")
def _floats(table, slot):
    return carray(as_float_pointer(table[2 * slot]), (table[2 * slot + 1],))


# -- dense linear algebra on small matrices (row-major, in place) --------------------------------
@kernel
def lu_factor(a, n, piv):
    """LU with partial pivoting of the (n, n) row-major a, in place; returns the ratio of the
    smallest to the largest pivot magnitude (0 for an exactly singular matrix)."""
    smallest, largest = np.inf, 0.0
    for k in range(n):
        p, big = k, abs(a[k * n + k])
        for i in range(k + 1, n):
            value = abs(a[i * n + k])
            if value > big:
                p, big = i, value
        piv[k] = p
        if p != k:
            for j in range(n):
                a[k * n + j], a[p * n + j] = a[p * n + j], a[k * n + j]
        smallest, largest = min(smallest, big), max(largest, big)
        if big == 0.0:
            continue
        inverse = 1.0 / a[k * n + k]
        for i in range(k + 1, n):
            factor = a[i * n + k] * inverse
            a[i * n + k] = factor
            if factor != 0.0:
                for j in range(k + 1, n):
                    a[i * n + j] -= factor * a[k * n + j]
    return smallest / largest if largest > 0.0 else 0.0


@kernel
def lu_solve(a, n, piv, b):
    """Solve A z = b in place (b (n,)) with the factors of `lu_factor`."""
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= a[i * n + j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i * n + j] * b[j]
        b[i] = s / a[i * n + i]


@kernel
def lu_solve_transposed(a, n, piv, b):
    """Solve A^T z = b in place with the factors of `lu_factor` (A = P^T L U)."""
    for i in range(n):  # U^T w = b
        s = b[i]
        for j in range(i):
            s -= a[j * n + i] * b[j]
        b[i] = s / a[i * n + i]
    for i in range(n - 1, -1, -1):  # L^T v = w
        s = b[i]
        for j in range(i + 1, n):
            s -= a[j * n + i] * b[j]
        b[i] = s
    for k in range(n - 1, -1, -1):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]


@kernel(inline="always")
def _group(ints, g):
    groups = ints[_GROUPS]
    return groups[g * ed.G_WIDTH: (g + 1) * ed.G_WIDTH]


# -- deformations of every element ---------------------------------------------------------------
@kernel
def deformations(ints, floats, x, order):
    """e (NE,) into F[_E] and, by order, each element's De, D2e into F[_DE], F[_D2E]."""
    dims = ints[_DIMS]
    e = floats[_E]
    local = floats[_LOCAL]
    max_m = dims[ed.MAX_M]
    for g in range(dims[ed.NGROUPS]):
        row = _group(ints, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        if k == 0:
            continue
        width, function = row[ed.G_REF_WIDTH], row[ed.G_DEFORMATIONS_ENTRY]
        coords = ints[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = ints[_DEF_INDEX][row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        refs = floats[_GROUP_DATA].ctypes.data + 8 * row[ed.G_DATA_OFFSET]
        De = floats[_DE].ctypes.data + 8 * row[ed.G_DE_OFFSET]
        D2e = floats[_D2E].ctypes.data + 8 * row[ed.G_D2E_OFFSET]
        xl = local[:m]
        el = local[max_m: max_m + k]
        for i in range(n):
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
            call_deformations(function, xl.ctypes.data, refs + 8 * i * width, order,
                              el.ctypes.data, De + 8 * i * k * m, D2e + 8 * i * k * m * m,
                              m, k, width)
            for b in range(k):
                e[defs[i * k + b]] = el[b]


# -- kinematics -----------------------------------------------------------------------------------
@kernel
def _residual(ints, floats, x, q, g):
    """g (n_free,) = [e_rigid; e_dof - q_e; x_dof - q_x] at x with the deformations in F[_E]."""
    dims = ints[_DIMS]
    e = floats[_E]
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    rows = ints[_ROWS]
    worst = 0.0
    for j in range(n_rigid):
        g[j] = e[rows[j]]
    for j in range(n_edof):
        g[n_rigid + j] = e[rows[n_rigid + j]] - q[n_xdof + j]
    for j in range(n_xdof):
        g[n_rigid + n_edof + j] = x[ints[_DOF_COORDS][j]] - q[j]
    for j in range(g.size):
        worst = max(worst, abs(g[j]))
    return worst


@kernel
def _constraint_jacobian(ints, floats, J):
    """J (n_free, n_free) row-major into J from the elements' De in F[_DE]."""
    dims = ints[_DIMS]
    nf = dims[ed.NFREE]
    J[:] = 0.0
    row_of_def, col_of_coord = ints[_ROW_OF_DEF], ints[_COL_OF_COORD]
    for g in range(dims[ed.NGROUPS]):
        row = _group(ints, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        coords = ints[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = ints[_DEF_INDEX][row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        De = floats[_DE][row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
        for i in range(n):
            for b in range(k):
                r = row_of_def[defs[i * k + b]]
                if r < 0:
                    continue
                for a in range(m):
                    c = col_of_coord[coords[i * m + a]]
                    if c >= 0:
                        J[r * nf + c] = De[(i * k + b) * m + a]
    n_def = dims[ed.NRIGID] + dims[ed.NEDOF]
    positions = ints[_DOF_POS]
    for j in range(dims[ed.NXDOF]):
        J[(n_def + j) * nf + positions[j]] = 1.0


@kernel
def _store(ints, floats, q, x):
    """Factor J at the solved x (deformations of order 2 in F), DF, and keep both as the next
    warm start; status SINGULAR_CONSTRAINTS if J's pivots say the configuration is singular."""
    dims = ints[_DIMS]
    nx, ndof, nf = dims[ed.NX], dims[ed.NDOF], dims[ed.NFREE]
    lu, piv = floats[_LU], ints[_PIVOTS]
    _constraint_jacobian(ints, floats, lu)
    ratio = lu_factor(lu, nf, piv)
    if not ratio > floats[_SETTINGS][ed.SINGULAR_RATIO]:
        return ed.SINGULAR_CONSTRAINTS
    DF, column = floats[_DF], floats[_DX]
    free = ints[_FREE]
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    DF[:] = 0.0
    for j in range(ndof):  # J DF = [0; I]: DOF coordinates first in q, last in the rows of J
        column[:] = 0.0
        if j < n_xdof:
            column[n_rigid + n_edof + j] = 1.0
        else:
            column[n_rigid + j - n_xdof] = 1.0
        lu_solve(lu, nf, piv, column)
        for a in range(nf):
            DF[free[a] * ndof + j] = column[a]
    floats[_X][:nx] = x[:nx]
    floats[_Q][:] = q
    dims[ed.WARM] = 1
    return ed.OK


@kernel
def solve_kinematics(ints, floats, q):
    """x = F(q) into F[_X], with e, De, D2e, the LU of J and DF there; a status code."""
    dims = ints[_DIMS]
    nx, nf = dims[ed.NX], dims[ed.NFREE]
    tolerance = floats[_SETTINGS][ed.TOLERANCE]
    x, g, dx, free = floats[_X_TRIAL], floats[_G], floats[_DX], ints[_FREE]
    lu, piv = floats[_LU], ints[_PIVOTS]
    if dims[ed.WARM] == 1:
        DF, x_prev, q_prev = floats[_DF], floats[_X], floats[_Q]
        ndof = dims[ed.NDOF]
        for a in range(nx):
            s = x_prev[a]
            for j in range(ndof):
                s += DF[a * ndof + j] * (q[j] - q_prev[j])
            x[a] = s
        deformations(ints, floats, x, 2)  # with the derivatives: usually x needs no correction
        if _residual(ints, floats, x, q, g) <= tolerance:
            return _store(ints, floats, q, x)
        for _ in range(dims[ed.CHORD_ITERATIONS]):
            dx[:] = g
            lu_solve(lu, nf, piv, dx)
            step = 0.0
            for a in range(nf):
                x[free[a]] -= dx[a]
                step = max(step, abs(dx[a]))
            if not np.isfinite(step):
                break
            deformations(ints, floats, x, 2)
            if _residual(ints, floats, x, q, g) <= tolerance or step <= tolerance:
                return _store(ints, floats, q, x)
    else:
        x[:] = floats[_X_START]
    if not np.all(np.isfinite(x)):
        x[:] = floats[_X]
    for _ in range(dims[ed.MAX_NEWTON]):  # full Newton
        deformations(ints, floats, x, 1)
        _residual(ints, floats, x, q, g)
        _constraint_jacobian(ints, floats, lu)
        if not lu_factor(lu, nf, piv) > 0.0:
            return ed.SINGULAR_CONSTRAINTS
        dx[:] = g
        lu_solve(lu, nf, piv, dx)
        step = 0.0
        for a in range(nf):
            x[free[a]] -= dx[a]
            step = max(step, abs(dx[a]))
        if not np.isfinite(step):
            return ed.NOT_CONVERGED
        if step <= tolerance:
            deformations(ints, floats, x, 2)
            return _store(ints, floats, q, x)
    return ed.NOT_CONVERGED


@kernel
def positions(ints, floats, q, out):
    """Coordinates x (NX,) for q into out (the kinematics of `solve_kinematics`); status."""
    status = solve_kinematics(ints, floats, q)
    out[:] = floats[_X]
    return status


# -- equations of motion ------------------------------------------------------------------------
@kernel
def evaluate(ints, floats, q, qdot):
    """qddot (NDOF,) into F[_QDDOT] for DOFs q, velocities qdot and the inputs in F[_INPUTS].

    Leaves in F what the tangent needs: the kinematics, the constitutive stress resultants
    (F[_SIGMA]), the coordinate force balance r (F[_FORCE]) and M_bar (F[_MASS]); a status."""
    status = solve_kinematics(ints, floats, q)
    if status != ed.OK:
        return status
    dims = ints[_DIMS]
    nx, ndof, nf = dims[ed.NX], dims[ed.NDOF], dims[ed.NFREE]
    DF, x, xdot = floats[_DF], floats[_X], floats[_XDOT]
    moving = False
    for j in range(ndof):
        if qdot[j] != 0.0:
            moving = True
    for a in range(nx):
        s = 0.0
        for j in range(ndof):
            s += DF[a * ndof + j] * qdot[j]
        xdot[a] = s
    # edot and, if moving, the quadratic forms of the constraint rows
    _element_rates(ints, floats, xdot, moving)
    # sigma_c = S e_s + D edot_s
    sigma, e, edot = floats[_SIGMA], floats[_E], floats[_EDOT]
    stressed, S, D = ints[_STRESSED], floats[_S], floats[_D]
    ns = stressed.size
    sigma[:] = 0.0
    damped = dims[ed.HAS_DAMPING] == 1
    for a in range(ns):
        s = 0.0
        for b in range(ns):
            s += S[a * ns + b] * e[stressed[b]]
            if damped:
                s += D[a * ns + b] * edot[stressed[b]]
        sigma[stressed[a]] = s
    # coordinate force r = f - De^T sigma_c (- inertia terms below)
    r = floats[_FORCE]
    r[:] = floats[_CONST_FORCE]
    inputs, input_coords = floats[_INPUTS], ints[_INPUT_COORDS]
    for j in range(inputs.size):
        r[input_coords[j]] += inputs[j]
    _scatter_stress(ints, floats, sigma, r)
    conv = floats[_CONV]
    if moving:  # (D2F qdot) qdot = -J^-1 [xdot^T H_i xdot on the constraint rows]
        dx = floats[_DX]
        for a in range(nf):
            dx[a] = floats[_G][a]  # the quadratic forms, left in g by _element_rates
        lu_solve(floats[_LU], nf, ints[_PIVOTS], dx)
        conv[:] = 0.0
        free = ints[_FREE]
        for a in range(nf):
            conv[free[a]] = -dx[a]
    _inertia(ints, floats, x, xdot, conv, moving, r)
    # M_bar qddot = DF^T r
    rq, qddot = floats[_REDUCED_FORCE], floats[_QDDOT]
    for j in range(ndof):
        s = 0.0
        for a in range(nx):
            s += DF[a * ndof + j] * r[a]
        rq[j] = s
    mass_lu = floats[_MASS_LU]
    mass_lu[:] = floats[_MASS]
    if not lu_factor(mass_lu, ndof, ints[_MASS_PIVOTS]) > 0.0:
        return ed.SINGULAR_MASS
    qddot[:] = rq
    lu_solve(mass_lu, ndof, ints[_MASS_PIVOTS], qddot)
    return ed.OK


@kernel
def _element_rates(ints, floats, xdot, moving):
    """edot = De xdot (F[_EDOT]) and, if moving, xdot^T D2e_i xdot of the constraint rows
    into F[_G] (n_free,: zero on the unit rows of the DOF coordinates)."""
    dims = ints[_DIMS]
    edot, quad = floats[_EDOT], floats[_G]
    row_of_def = ints[_ROW_OF_DEF]
    quad[:] = 0.0
    for g in range(dims[ed.NGROUPS]):
        row = _group(ints, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        coords = ints[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = ints[_DEF_INDEX][row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        De = floats[_DE][row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
        D2e = floats[_D2E][row[ed.G_D2E_OFFSET]: row[ed.G_D2E_OFFSET] + n * k * m * m]
        for i in range(n):
            for b in range(k):
                s = 0.0
                base = (i * k + b) * m
                for a in range(m):
                    s += De[base + a] * xdot[coords[i * m + a]]
                edot[defs[i * k + b]] = s
                r = row_of_def[defs[i * k + b]]
                if moving and r >= 0:
                    h = 0.0
                    base2 = (i * k + b) * m * m
                    for a in range(m):
                        va = xdot[coords[i * m + a]]
                        if va == 0.0:
                            continue
                        t = 0.0
                        for c in range(m):
                            t += D2e[base2 + a * m + c] * xdot[coords[i * m + c]]
                        h += va * t
                    quad[r] = h


@kernel
def _scatter_stress(ints, floats, sigma, r):
    """r -= De^T sigma, element by element."""
    dims = ints[_DIMS]
    for g in range(dims[ed.NGROUPS]):
        row = _group(ints, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        coords = ints[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = ints[_DEF_INDEX][row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        De = floats[_DE][row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
        for i in range(n):
            for b in range(k):
                s = sigma[defs[i * k + b]]
                if s == 0.0:
                    continue
                base = (i * k + b) * m
                for a in range(m):
                    r[coords[i * m + a]] -= De[base + a] * s


@kernel
def _inertia(ints, floats, x, xdot, conv, moving, r):
    """M_bar = DF^T M DF into F[_MASS]; gravity on the element masses into r; and, if moving,
    r -= M conv + g_conv. Element by element through the inertia points."""
    dims = ints[_DIMS]
    nx, ndof = dims[ed.NX], dims[ed.NDOF]
    DF, mass, lumped = floats[_DF], floats[_MASS], floats[_LUMPED]
    mass[:] = 0.0
    for a in range(nx):  # the lumped masses
        la = lumped[a]
        if la == 0.0:
            continue
        if moving:
            r[a] -= la * conv[a]
        for i in range(ndof):
            di = la * DF[a * ndof + i]
            if di == 0.0:
                continue
            for j in range(ndof):
                mass[i * ndof + j] += di * DF[a * ndof + j]
    local = floats[_LOCAL]
    max_m, max_p = dims[ed.MAX_M], dims[ed.MAX_P]
    for g in range(dims[ed.NGROUPS]):
        row = _group(ints, g)
        P = row[ed.G_P]
        if P == 0:
            continue
        n, m, width = row[ed.G_COUNT], row[ed.G_M], row[ed.G_REF_WIDTH]
        function = row[ed.G_INERTIA_ENTRY]
        coords = ints[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        data = floats[_GROUP_DATA]
        refs = data.ctypes.data + 8 * row[ed.G_DATA_OFFSET]
        # scratch: x, v (m), p then the point forces, acc, w (P), Dp (P, m), B = Dp DF_e and
        # Mp B (P, ndof)
        xl, vl = local[:max_m], local[max_m: 2 * max_m]
        o = 2 * max_m
        point, acc, w = local[o: o + max_p], local[o + max_p: o + 2 * max_p], \
            local[o + 2 * max_p: o + 3 * max_p]
        o += 3 * max_p
        Dp = local[o: o + P * m].reshape((P, m))
        o += max_p * max_m
        B = local[o: o + max_p * ndof]
        o += max_p * ndof
        MpB = local[o: o + max_p * ndof]
        gravity = data[row[ed.G_GRAVITY_OFFSET]: row[ed.G_GRAVITY_OFFSET] + P]
        for i in range(n):
            Mp = data[row[ed.G_MASS_OFFSET] + i * P * P: row[ed.G_MASS_OFFSET] + (i + 1) * P * P]
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
                vl[a] = xdot[coords[i * m + a]]
            call_inertia(function, xl.ctypes.data, vl.ctypes.data, refs + 8 * i * width,
                         2 if moving else 1, point.ctypes.data, Dp.ctypes.data,
                         acc.ctypes.data, m, P, width)
            # B = Dp DF_e (P, ndof), and the force on the points gravity - Dp conv_e - acc
            B[: P * ndof] = 0.0
            for pp in range(P):
                f = gravity[pp]
                for a in range(m):
                    d = Dp[pp, a]
                    if d != 0.0:
                        row_df = coords[i * m + a] * ndof
                        for j in range(ndof):
                            B[pp * ndof + j] += d * DF[row_df + j]
                        if moving:
                            f -= d * conv[coords[i * m + a]]
                point[pp] = f - acc[pp] if moving else f
            # w = Mp (point forces), MpB = Mp B
            for pp in range(P):
                s = 0.0
                for j in range(ndof):
                    MpB[pp * ndof + j] = 0.0
                for qq in range(P):
                    mpq = Mp[pp * P + qq]
                    if mpq == 0.0:
                        continue
                    s += mpq * point[qq]
                    for j in range(ndof):
                        MpB[pp * ndof + j] += mpq * B[qq * ndof + j]
                w[pp] = s
            for a in range(m):  # r += Dp^T w
                s = 0.0
                for pp in range(P):
                    s += Dp[pp, a] * w[pp]
                r[coords[i * m + a]] += s
            for pp in range(P):  # M_bar += B^T (Mp B)
                for a in range(ndof):
                    ba = B[pp * ndof + a]
                    if ba == 0.0:
                        continue
                    for b in range(ndof):
                        mass[a * ndof + b] += ba * MpB[pp * ndof + b]


# -- tangent ----------------------------------------------------------------------------------
@kernel
def tangent(ints, floats, qddot):
    """Stiffness K0 + G0 and damping C0 (NDOF, NDOF) into F[_STIFFNESS], F[_DAMPING] at the
    state of the last `evaluate`, with the dynamic balance taken at accelerations qddot."""
    dims = ints[_DIMS]
    nx, ndof, nf = dims[ed.NX], dims[ed.NDOF], dims[ed.NFREE]
    DF, x = floats[_DF], floats[_X]
    # r_full = r - M DF qddot, then the multipliers J^-T r_full on the free coordinates
    acc = floats[_CONV]
    for a in range(nx):
        s = 0.0
        for j in range(ndof):
            s += DF[a * ndof + j] * qddot[j]
        acc[a] = s
    r_full = floats[_X_TRIAL]
    r_full[:] = floats[_FORCE]
    _mass_times(ints, floats, x, acc, r_full)
    free, lam = ints[_FREE], floats[_DX]
    for a in range(nf):
        lam[a] = r_full[free[a]]
    lu_solve_transposed(floats[_LU], nf, ints[_PIVOTS], lam)
    sigma = floats[_EDOT]  # reused: the full stress resultants
    sigma[:] = floats[_SIGMA]
    rows = ints[_ROWS]
    for j in range(rows.size):
        sigma[rows[j]] += lam[j]
    # DeF = De DF (NE, NDOF) and G0 = sum DF_e^T (sum_i sigma_i D2e_i) DF_e
    DeF, K, C = floats[_DEF], floats[_STIFFNESS], floats[_DAMPING]
    K[:] = 0.0
    C[:] = 0.0
    DeF[:] = 0.0
    local = floats[_LOCAL]
    for g in range(dims[ed.NGROUPS]):
        row = _group(ints, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        coords = ints[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = ints[_DEF_INDEX][row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        De = floats[_DE][row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
        D2e = floats[_D2E][row[ed.G_D2E_OFFSET]: row[ed.G_D2E_OFFSET] + n * k * m * m]
        H = local[: m * m]
        HD = local[m * m: m * m + m * ndof]
        for i in range(n):
            for b in range(k):
                base = (i * k + b) * m
                d = defs[i * k + b]
                for j in range(ndof):
                    s = 0.0
                    for a in range(m):
                        s += De[base + a] * DF[coords[i * m + a] * ndof + j]
                    DeF[d * ndof + j] = s
            H[:] = 0.0
            for b in range(k):
                s = sigma[defs[i * k + b]]
                if s == 0.0:
                    continue
                base2 = (i * k + b) * m * m
                for a in range(m * m):
                    H[a] += s * D2e[base2 + a]
            for a in range(m):  # HD = H DF_e
                for j in range(ndof):
                    s = 0.0
                    for c in range(m):
                        s += H[a * m + c] * DF[coords[i * m + c] * ndof + j]
                    HD[a * ndof + j] = s
            for a in range(m):
                for j1 in range(ndof):
                    dfa = DF[coords[i * m + a] * ndof + j1]
                    if dfa == 0.0:
                        continue
                    for j2 in range(ndof):
                        K[j1 * ndof + j2] += dfa * HD[a * ndof + j2]
    # K0 = DeF_s^T S DeF_s, C0 = DeF_s^T D DeF_s
    stressed, S, D = ints[_STRESSED], floats[_S], floats[_D]
    ns = stressed.size
    damped = dims[ed.HAS_DAMPING] == 1
    SD = local[: ndof]
    DD = local[ndof: 2 * ndof]
    for a in range(ns):
        for j in range(ndof):
            s = 0.0
            t = 0.0
            for b in range(ns):
                v = DeF[stressed[b] * ndof + j]
                s += S[a * ns + b] * v
                if damped:
                    t += D[a * ns + b] * v
            SD[j] = s
            DD[j] = t
        for i in range(ndof):
            v = DeF[stressed[a] * ndof + i]
            if v == 0.0:
                continue
            for j in range(ndof):
                K[i * ndof + j] += v * SD[j]
                if damped:
                    C[i * ndof + j] += v * DD[j]


@kernel
def _mass_times(ints, floats, x, v, out):
    """out -= M(x) v for a coordinate vector v (NX,): lumped plus element masses."""
    dims = ints[_DIMS]
    nx = dims[ed.NX]
    lumped = floats[_LUMPED]
    for a in range(nx):
        out[a] -= lumped[a] * v[a]
    local = floats[_LOCAL]
    max_m, max_p = dims[ed.MAX_M], dims[ed.MAX_P]
    data = floats[_GROUP_DATA]
    ndof = dims[ed.NDOF]
    for g in range(dims[ed.NGROUPS]):
        row = _group(ints, g)
        P = row[ed.G_P]
        if P == 0:
            continue
        n, m, width = row[ed.G_COUNT], row[ed.G_M], row[ed.G_REF_WIDTH]
        function = row[ed.G_INERTIA_ENTRY]
        coords = ints[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        refs = data.ctypes.data + 8 * row[ed.G_DATA_OFFSET]
        # scratch after the first 2 ndof entries, which `tangent` keeps for itself
        o = 2 * ndof + max_m * max_m + max_m * ndof
        xl, vl = local[o: o + max_m], local[o + max_m: o + 2 * max_m]
        o += 2 * max_m
        pl, acc, w = local[o: o + max_p], local[o + max_p: o + 2 * max_p], \
            local[o + 2 * max_p: o + 3 * max_p]
        o += 3 * max_p
        Dp = local[o: o + P * m].reshape((P, m))
        for i in range(n):
            Mp = data[row[ed.G_MASS_OFFSET] + i * P * P: row[ed.G_MASS_OFFSET] + (i + 1) * P * P]
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
            call_inertia(function, xl.ctypes.data, vl.ctypes.data, refs + 8 * i * width, 1,
                         pl.ctypes.data, Dp.ctypes.data, acc.ctypes.data, m, P, width)
            for pp in range(P):
                s = 0.0
                for a in range(m):
                    s += Dp[pp, a] * v[coords[i * m + a]]
                acc[pp] = s
            for pp in range(P):
                s = 0.0
                for qq in range(P):
                    s += Mp[pp * P + qq] * acc[qq]
                w[pp] = s
            for a in range(m):
                s = 0.0
                for pp in range(P):
                    s += Dp[pp, a] * w[pp]
                out[coords[i * m + a]] -= s


# -- first-order form for the integrators ---------------------------------------------------------
@kernel
def first_order_rhs(ints, floats, y, ydot):
    """ydot = [qdot, qddot] for the state y = [q - q_ref, qdot]; a status code.

    The absolute DOFs are formed in the last NDOF entries of the scratch array, which no
    other part of an evaluation uses."""
    n = ints[_DIMS][ed.NDOF]
    for j in range(2 * n):
        if not np.isfinite(y[j]):
            return ed.NONFINITE_STATE
    q_abs = floats[_LOCAL][floats[_LOCAL].size - n:]
    q_ref = floats[_Q_REF]
    for j in range(n):
        q_abs[j] = q_ref[j] + y[j]
    status = evaluate(ints, floats, q_abs, y[n: 2 * n])
    if status != ed.OK:
        return status
    qddot = floats[_QDDOT]
    for j in range(n):
        if not np.isfinite(qddot[j]):
            return ed.NONFINITE_RESULT
    if ydot.size:  # empty when only the evaluation left in F is wanted
        for j in range(n):
            ydot[j] = y[n + j]
            ydot[n + j] = qddot[j]
    return ed.OK


@kernel
def first_order_jacobian(ints, floats, y, J, column_major):
    """d ydot / d y (2n, 2n) into J (flat; column-major for SUNDIALS' dense matrix):
    [[0, I], [-M_bar^-1 K, -M_bar^-1 C]] with the model's tangent at y; a status code."""
    status = first_order_rhs(ints, floats, y, floats[_DX][: 0])
    if status != ed.OK:
        return status
    n = ints[_DIMS][ed.NDOF]
    tangent(ints, floats, floats[_QDDOT])
    K, C, mass_lu, piv = floats[_STIFFNESS], floats[_DAMPING], floats[_MASS_LU], ints[_MASS_PIVOTS]
    column = floats[_REDUCED_FORCE]
    N = 2 * n
    J[:] = 0.0
    for j in range(n):
        _put(J, N, j, n + j, 1.0, column_major)
    for j in range(n):  # column j of -M^-1 K and of -M^-1 C
        for i in range(n):
            column[i] = K[i * n + j]
        lu_solve(mass_lu, n, piv, column)
        for i in range(n):
            _put(J, N, n + i, j, -column[i], column_major)
        for i in range(n):
            column[i] = C[i * n + j]
        lu_solve(mass_lu, n, piv, column)
        for i in range(n):
            _put(J, N, n + i, n + j, -column[i], column_major)
    return ed.OK


@kernel(inline="always")
def _put(J, N, i, j, value, column_major):
    if column_major:
        J[j * N + i] = value
    else:
        J[i * N + j] = value


@kernel
def implicit_residual(ints, floats, y, yp, res):
    """IDA's residual [qp - qdot; M_bar (qddot_p - qddot(q, qdot))]; a status code."""
    status = first_order_rhs(ints, floats, y, floats[_DX][: 0])
    if status != ed.OK:
        return status
    n = ints[_DIMS][ed.NDOF]
    mass, qddot = floats[_MASS], floats[_QDDOT]
    for i in range(n):
        res[i] = yp[i] - y[n + i]
        s = 0.0
        for j in range(n):
            s += mass[i * n + j] * (yp[n + j] - qddot[j])
        res[n + i] = s
    return ed.OK


@kernel
def implicit_jacobian(ints, floats, y, yp, cj, J):
    """IDA's d res / d y + cj d res / d yp, column-major (2n, 2n): [[cj I, -I], [K, C + cj
    M_bar]] with the tangent's dynamic balance at qddot = yp[n:]; a status code."""
    status = first_order_rhs(ints, floats, y, floats[_DX][: 0])
    if status != ed.OK:
        return status
    n = ints[_DIMS][ed.NDOF]
    tangent(ints, floats, yp[n: 2 * n])
    K, C, mass = floats[_STIFFNESS], floats[_DAMPING], floats[_MASS]
    N = 2 * n
    J[:] = 0.0
    for i in range(n):
        J[i * N + i] = cj
        J[(n + i) * N + i] = -1.0
        for j in range(n):
            J[j * N + n + i] = K[i * n + j]
            J[(n + j) * N + n + i] = C[i * n + j] + cj * mass[i * n + j]
    return ed.OK


# -- the one entry point: every operation through one compiled C function ---------------------
(OP_RHS, OP_JACOBIAN, OP_RESIDUAL, OP_RESIDUAL_JACOBIAN, OP_KINEMATICS, OP_DEFORMATIONS,
 OP_EVALUATE, OP_TANGENT) = range(8)
# (op, user data, t, a, b, c, s) -> status: a, b, c the operation's arrays, s its number
ENGINE_ENTRY = types.int32(types.int64, types.voidptr, types.float64, types.voidptr,
                           types.voidptr, types.voidptr, types.float64)


@entry(ENGINE_ENTRY)
def engine_entry(op, user_data, t, a, b, c, s):
    """Every operation of the engine on the packed model at user_data (an address table):

    OP_RHS (y, ydot), OP_JACOBIAN (y, J; s = 1 column-major), OP_RESIDUAL (y, yp, res),
    OP_RESIDUAL_JACOBIAN (y, yp, J; s = cj), OP_KINEMATICS (q), OP_DEFORMATIONS (x; s =
    order), OP_EVALUATE (q, qdot), OP_TANGENT (qddot). Returns the status code."""
    ints, floats = unpack(user_data)
    dims = ints[_DIMS]
    nx, ndof = dims[ed.NX], dims[ed.NDOF]
    n = 2 * ndof
    f8 = np.float64
    if op == OP_RHS:
        return first_order_rhs(ints, floats, carray(a, (n,), f8), carray(b, (n,), f8))
    if op == OP_JACOBIAN:
        return first_order_jacobian(ints, floats, carray(a, (n,), f8), carray(b, (n * n,), f8),
                                    s != 0.0)
    if op == OP_RESIDUAL:
        return implicit_residual(ints, floats, carray(a, (n,), f8), carray(b, (n,), f8),
                                 carray(c, (n,), f8))
    if op == OP_RESIDUAL_JACOBIAN:
        return implicit_jacobian(ints, floats, carray(a, (n,), f8), carray(b, (n,), f8), s,
                                 carray(c, (n * n,), f8))
    if op == OP_KINEMATICS:
        return solve_kinematics(ints, floats, carray(a, (ndof,), f8))
    if op == OP_DEFORMATIONS:
        deformations(ints, floats, carray(a, (nx,), f8), int(s))
        return ed.OK
    if op == OP_EVALUATE:
        return evaluate(ints, floats, carray(a, (ndof,), f8), carray(b, (ndof,), f8))
    if op == OP_TANGENT:
        tangent(ints, floats, carray(a, (ndof,), f8))
        return ed.OK
    return -1


def call(data, op, a=None, b=None, c=None, s=0.0, t=0.0):
    """Run one engine operation from Python (a ctypes call, about 1 us): data an
    `EngineData`, a, b, c contiguous float64 arrays of the operation. Returns the status."""
    return engine_entry.ctypes(op, data.address, t, _address(a), _address(b), _address(c),
                               float(s))


def _address(array):
    if array is None:
        return None
    if not (array.dtype == np.float64 and array.flags.c_contiguous):
        raise TypeError("engine arrays must be C-contiguous float64")
    return array.ctypes.data
