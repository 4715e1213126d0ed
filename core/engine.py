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
from numba import carray, njit

from . import engine_data as ed
from .elements import beam, euler, plbeam, pltruss
from .native import as_float_pointer, as_int_pointer

# slot indices as compile-time constants
(_DIMS, _FREE, _ROWS, _DOF_COORDS, _DOF_DEFS, _DOF_POS, _STRESSED, _INPUT_COORDS, _GROUPS,
 _COORD_INDEX, _DEF_INDEX, _ROW_OF_DEF, _COL_OF_COORD, _PIVOTS, _MASS_PIVOTS,
 _COUNTERS) = range(len(ed.INT_SLOTS))
(_SETTINGS, _S, _D, _LUMPED, _CONST_FORCE, _GROUP_DATA, _INPUTS, _Q_REF, _X, _Q, _DF, _LU,
 _E, _DE, _D2E, _X_TRIAL, _G, _DX, _XDOT, _EDOT, _SIGMA, _FORCE, _MASS, _MASS_LU,
 _REDUCED_FORCE, _QDDOT, _CONV, _LOCAL, _DEF, _STIFFNESS, _DAMPING, _JAC_CACHE,
 _X_START) = range(len(ed.FLOAT_SLOTS))
_N_INT, _N_FLOAT = len(ed.INT_SLOTS), len(ed.FLOAT_SLOTS)
_NODE_INERTIA = ed.NODE_INERTIA


# -- from a C callback's user data to the arrays -----------------------------------------------
@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy", inline="always")
def _ints(table, slot):
    return carray(as_int_pointer(table[2 * slot]), (table[2 * slot + 1],))


@njit(cache=True, error_model="numpy", inline="always")
def _floats(table, slot):
    return carray(as_float_pointer(table[2 * slot]), (table[2 * slot + 1],))


# -- dense linear algebra on small matrices (row-major, in place) --------------------------------
@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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


# -- element kernels by code --------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def _element_deformations(code, x, ref, order, e, De, D2e):
    if code == 0:
        pltruss.deformations_kernel(x, ref, order, e, De, D2e)
    elif code == 1:
        plbeam.deformations_kernel(x, ref, order, e, De, D2e)
    elif code == 2:
        beam.deformations_kernel(x, ref, order, e, De, D2e)
    elif code == 3:
        euler.deformations_kernel(x, ref, order, e, De, D2e)


@njit(cache=True, error_model="numpy")
def _element_inertia(code, x, v, ref, order, p, Dp, acc):
    if code == 0:
        pltruss.inertia_kernel(x, v, ref, order, p, Dp, acc)
    elif code == 1:
        plbeam.inertia_kernel(x, v, ref, order, p, Dp, acc)
    elif code == 2:
        beam.inertia_kernel(x, v, ref, order, p, Dp, acc)
    elif code == _NODE_INERTIA:
        _node_inertia_kernel(x, v, ref, order, p, Dp, acc)


def _bind_node_inertia():
    from . import rotary_inertia

    return rotary_inertia.inertia_kernel


_node_inertia_kernel = _bind_node_inertia()


@njit(cache=True, error_model="numpy", inline="always")
def _view2(a, offset, n0, n1):
    """a[offset:].reshape(n0, n1) as a view without the reshape machinery (a hot path)."""
    return carray(as_float_pointer(a.ctypes.data + 8 * offset), (n0, n1))


@njit(cache=True, error_model="numpy", inline="always")
def _view3(a, offset, n0, n1, n2):
    return carray(as_float_pointer(a.ctypes.data + 8 * offset), (n0, n1, n2))


@njit(cache=True, error_model="numpy", inline="always")
def _view4(a, offset, n0, n1, n2, n3):
    return carray(as_float_pointer(a.ctypes.data + 8 * offset), (n0, n1, n2, n3))


@njit(cache=True, error_model="numpy", inline="always")
def _group(I, g):
    groups = I[_GROUPS]
    return groups[g * ed.G_WIDTH: (g + 1) * ed.G_WIDTH]


# -- deformations of every element ---------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def deformations(I, F, x, order):
    """e (NE,) into F[_E] and, by order, each element's De, D2e into F[_DE], F[_D2E]."""
    dims = I[_DIMS]
    e = F[_E]
    local = F[_LOCAL]
    max_m, max_k = dims[ed.MAX_M], dims[ed.MAX_K]
    for g in range(dims[ed.NGROUPS]):
        row = _group(I, g)
        code, n, m, k = row[ed.G_KERNEL], row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        if k == 0:
            continue
        width = row[ed.G_REF_WIDTH]
        coords = I[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = I[_DEF_INDEX][row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        refs = _view2(F[_GROUP_DATA], row[ed.G_DATA_OFFSET], n, width)
        De = _view3(F[_DE], row[ed.G_DE_OFFSET], n, k, m)
        D2e = _view4(F[_D2E], row[ed.G_D2E_OFFSET], n, k, m, m)
        xl = local[:m]
        el = local[max_m: max_m + k]
        for i in range(n):
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
            _element_deformations(code, xl, refs[i], order, el, De[i], D2e[i])
            for b in range(k):
                e[defs[i * k + b]] = el[b]


# -- kinematics -----------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def _residual(I, F, x, q, g):
    """g (n_free,) = [e_rigid; e_dof - q_e; x_dof - q_x] at x with the deformations in F[_E]."""
    dims = I[_DIMS]
    e = F[_E]
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    rows = I[_ROWS]
    worst = 0.0
    for j in range(n_rigid):
        g[j] = e[rows[j]]
    for j in range(n_edof):
        g[n_rigid + j] = e[rows[n_rigid + j]] - q[n_xdof + j]
    for j in range(n_xdof):
        g[n_rigid + n_edof + j] = x[I[_DOF_COORDS][j]] - q[j]
    for j in range(g.size):
        worst = max(worst, abs(g[j]))
    return worst


@njit(cache=True, error_model="numpy")
def _constraint_jacobian(I, F, J):
    """J (n_free, n_free) row-major into J from the elements' De in F[_DE]."""
    dims = I[_DIMS]
    nf = dims[ed.NFREE]
    J[:] = 0.0
    row_of_def, col_of_coord = I[_ROW_OF_DEF], I[_COL_OF_COORD]
    for g in range(dims[ed.NGROUPS]):
        row = _group(I, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        coords = I[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = I[_DEF_INDEX][row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        De = F[_DE][row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
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
    positions = I[_DOF_POS]
    for j in range(dims[ed.NXDOF]):
        J[(n_def + j) * nf + positions[j]] = 1.0


@njit(cache=True, error_model="numpy")
def _store(I, F, q, x):
    """Factor J at the solved x (deformations of order 2 in F), DF, and keep both as the next
    warm start; status SINGULAR_CONSTRAINTS if J's pivots say the configuration is singular."""
    dims = I[_DIMS]
    nx, ndof, nf = dims[ed.NX], dims[ed.NDOF], dims[ed.NFREE]
    lu, piv = F[_LU], I[_PIVOTS]
    _constraint_jacobian(I, F, lu)
    ratio = lu_factor(lu, nf, piv)
    if not ratio > F[_SETTINGS][ed.SINGULAR_RATIO]:
        return ed.SINGULAR_CONSTRAINTS
    DF, column = F[_DF], F[_DX]
    free = I[_FREE]
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
    F[_X][:nx] = x[:nx]
    F[_Q][:] = q
    dims[ed.WARM] = 1
    return ed.OK


@njit(cache=True, error_model="numpy")
def solve_kinematics(I, F, q):
    """x = F(q) into F[_X], with e, De, D2e, the LU of J and DF there; a status code."""
    dims = I[_DIMS]
    nx, nf = dims[ed.NX], dims[ed.NFREE]
    tolerance = F[_SETTINGS][ed.TOLERANCE]
    x, g, dx, free = F[_X_TRIAL], F[_G], F[_DX], I[_FREE]
    lu, piv = F[_LU], I[_PIVOTS]
    if dims[ed.WARM] == 1:
        DF, x_prev, q_prev = F[_DF], F[_X], F[_Q]
        ndof = dims[ed.NDOF]
        for a in range(nx):
            s = x_prev[a]
            for j in range(ndof):
                s += DF[a * ndof + j] * (q[j] - q_prev[j])
            x[a] = s
        deformations(I, F, x, 0)
        if _residual(I, F, x, q, g) <= tolerance:
            deformations(I, F, x, 2)
            return _store(I, F, q, x)
        for _ in range(dims[ed.CHORD_ITERATIONS]):
            dx[:] = g
            lu_solve(lu, nf, piv, dx)
            step = 0.0
            for a in range(nf):
                x[free[a]] -= dx[a]
                step = max(step, abs(dx[a]))
            if not np.isfinite(step):
                break
            deformations(I, F, x, 2)
            if _residual(I, F, x, q, g) <= tolerance or step <= tolerance:
                return _store(I, F, q, x)
    else:
        x[:] = F[_X_START]
    if not np.all(np.isfinite(x)):
        x[:] = F[_X]
    for _ in range(dims[ed.MAX_NEWTON]):  # full Newton
        deformations(I, F, x, 1)
        _residual(I, F, x, q, g)
        _constraint_jacobian(I, F, lu)
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
            deformations(I, F, x, 2)
            return _store(I, F, q, x)
    return ed.NOT_CONVERGED


@njit(cache=True, error_model="numpy")
def positions(I, F, q, out):
    """Coordinates x (NX,) for q into out (the kinematics of `solve_kinematics`); status."""
    status = solve_kinematics(I, F, q)
    out[:] = F[_X]
    return status


# -- equations of motion ------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def evaluate(I, F, q, qdot):
    """qddot (NDOF,) into F[_QDDOT] for DOFs q, velocities qdot and the inputs in F[_INPUTS].

    Leaves in F what the tangent needs: the kinematics, the constitutive stress resultants
    (F[_SIGMA]), the coordinate force balance r (F[_FORCE]) and M_bar (F[_MASS]); a status."""
    status = solve_kinematics(I, F, q)
    if status != ed.OK:
        return status
    dims = I[_DIMS]
    nx, ne, ndof, nf = dims[ed.NX], dims[ed.NE], dims[ed.NDOF], dims[ed.NFREE]
    DF, x, xdot = F[_DF], F[_X], F[_XDOT]
    moving = False
    for j in range(ndof):
        if qdot[j] != 0.0:
            moving = True
    for a in range(nx):
        s = 0.0
        for j in range(ndof):
            s += DF[a * ndof + j] * qdot[j]
        xdot[a] = s
    _element_rates(I, F, xdot, moving)  # edot (stressed rows) and, if moving, the quad forms
    # sigma_c = S e_s + D edot_s
    sigma, e, edot = F[_SIGMA], F[_E], F[_EDOT]
    stressed, S, D = I[_STRESSED], F[_S], F[_D]
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
    r = F[_FORCE]
    r[:] = F[_CONST_FORCE]
    inputs, input_coords = F[_INPUTS], I[_INPUT_COORDS]
    for j in range(inputs.size):
        r[input_coords[j]] += inputs[j]
    _scatter_stress(I, F, sigma, r)
    conv = F[_CONV]
    if moving:  # (D2F qdot) qdot = -J^-1 [xdot^T H_i xdot on the constraint rows]
        dx = F[_DX]
        for a in range(nf):
            dx[a] = F[_G][a]  # the quadratic forms, left in g by _element_rates
        lu_solve(F[_LU], nf, I[_PIVOTS], dx)
        conv[:] = 0.0
        free = I[_FREE]
        for a in range(nf):
            conv[free[a]] = -dx[a]
    _inertia(I, F, x, xdot, conv, moving, r)
    # M_bar qddot = DF^T r
    rq, qddot = F[_REDUCED_FORCE], F[_QDDOT]
    for j in range(ndof):
        s = 0.0
        for a in range(nx):
            s += DF[a * ndof + j] * r[a]
        rq[j] = s
    mass_lu = F[_MASS_LU]
    mass_lu[:] = F[_MASS]
    if not lu_factor(mass_lu, ndof, I[_MASS_PIVOTS]) > 0.0:
        return ed.SINGULAR_MASS
    qddot[:] = rq
    lu_solve(mass_lu, ndof, I[_MASS_PIVOTS], qddot)
    return ed.OK


@njit(cache=True, error_model="numpy")
def _element_rates(I, F, xdot, moving):
    """edot = De xdot (F[_EDOT]) and, if moving, xdot^T D2e_i xdot of the constraint rows
    into F[_G] (n_free,: zero on the unit rows of the DOF coordinates)."""
    dims = I[_DIMS]
    edot, quad = F[_EDOT], F[_G]
    row_of_def = I[_ROW_OF_DEF]
    quad[:] = 0.0
    for g in range(dims[ed.NGROUPS]):
        row = _group(I, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        coords = I[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = I[_DEF_INDEX][row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        De = F[_DE][row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
        D2e = F[_D2E][row[ed.G_D2E_OFFSET]: row[ed.G_D2E_OFFSET] + n * k * m * m]
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


@njit(cache=True, error_model="numpy")
def _scatter_stress(I, F, sigma, r):
    """r -= De^T sigma, element by element."""
    dims = I[_DIMS]
    for g in range(dims[ed.NGROUPS]):
        row = _group(I, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        coords = I[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = I[_DEF_INDEX][row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        De = F[_DE][row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
        for i in range(n):
            for b in range(k):
                s = sigma[defs[i * k + b]]
                if s == 0.0:
                    continue
                base = (i * k + b) * m
                for a in range(m):
                    r[coords[i * m + a]] -= De[base + a] * s


@njit(cache=True, error_model="numpy")
def _inertia(I, F, x, xdot, conv, moving, r):
    """M_bar = DF^T M DF into F[_MASS]; gravity on the element masses into r; and, if moving,
    r -= M conv + g_conv. Element by element through the inertia points."""
    dims = I[_DIMS]
    nx, ndof = dims[ed.NX], dims[ed.NDOF]
    DF, mass, lumped = F[_DF], F[_MASS], F[_LUMPED]
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
    local = F[_LOCAL]
    max_m, max_p = dims[ed.MAX_M], dims[ed.MAX_P]
    for g in range(dims[ed.NGROUPS]):
        row = _group(I, g)
        P = row[ed.G_P]
        if P == 0:
            continue
        code, n, m, width = row[ed.G_KERNEL], row[ed.G_COUNT], row[ed.G_M], row[ed.G_REF_WIDTH]
        coords = I[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        data = F[_GROUP_DATA]
        refs = data[row[ed.G_DATA_OFFSET]: row[ed.G_DATA_OFFSET] + n * width]
        # scratch: x, v (m), p, acc, w (P), Dp (P m), B = Dp DF_e (P ndof)
        xl, vl = local[:max_m], local[max_m: 2 * max_m]
        o = 2 * max_m
        pl, acc, w = local[o: o + max_p], local[o + max_p: o + 2 * max_p], \
            local[o + 2 * max_p: o + 3 * max_p]
        o += 3 * max_p
        Dp = local[o: o + max_p * max_m].reshape((max_p, max_m))
        o += max_p * max_m
        B = local[o: o + max_p * ndof]
        gravity = data[row[ed.G_GRAVITY_OFFSET]: row[ed.G_GRAVITY_OFFSET] + P]
        for i in range(n):
            Mp = data[row[ed.G_MASS_OFFSET] + i * P * P: row[ed.G_MASS_OFFSET] + (i + 1) * P * P]
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
                vl[a] = xdot[coords[i * m + a]]
            _element_inertia(code, xl[:m], vl[:m], refs[i * width: (i + 1) * width],
                             2 if moving else 1, pl[:P], Dp[:P, :m], acc[:P])
            # B = Dp DF_e (P, ndof)
            for pp in range(P):
                for j in range(ndof):
                    s = 0.0
                    for a in range(m):
                        d = Dp[pp, a]
                        if d != 0.0:
                            s += d * DF[coords[i * m + a] * ndof + j]
                    B[pp * ndof + j] = s
            # w = Mp (gravity - Dp conv_e - acc): the point force whose Dp^T adds to r
            for pp in range(P):
                s = 0.0
                for qq in range(P):
                    point = gravity[qq]
                    if moving:
                        dpc = 0.0
                        for a in range(m):
                            dpc += Dp[qq, a] * conv[coords[i * m + a]]
                        point -= dpc + acc[qq]
                    s += Mp[pp * P + qq] * point
                w[pp] = s
            for a in range(m):
                s = 0.0
                for pp in range(P):
                    s += Dp[pp, a] * w[pp]
                r[coords[i * m + a]] += s
            # M_bar += B^T Mp B
            for pp in range(P):
                for qq in range(P):
                    mpq = Mp[pp * P + qq]
                    if mpq == 0.0:
                        continue
                    for a in range(ndof):
                        ba = mpq * B[pp * ndof + a]
                        for b in range(ndof):
                            mass[a * ndof + b] += ba * B[qq * ndof + b]


# -- tangent ----------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def tangent(I, F, qddot):
    """Stiffness K0 + G0 and damping C0 (NDOF, NDOF) into F[_STIFFNESS], F[_DAMPING] at the
    state of the last `evaluate`, with the dynamic balance taken at accelerations qddot."""
    dims = I[_DIMS]
    nx, ne, ndof, nf = dims[ed.NX], dims[ed.NE], dims[ed.NDOF], dims[ed.NFREE]
    DF, x = F[_DF], F[_X]
    # r_full = r - M DF qddot, then the multipliers J^-T r_full on the free coordinates
    acc = F[_CONV]
    for a in range(nx):
        s = 0.0
        for j in range(ndof):
            s += DF[a * ndof + j] * qddot[j]
        acc[a] = s
    r_full = F[_X_TRIAL]
    r_full[:] = F[_FORCE]
    _mass_times(I, F, x, acc, r_full)
    free, lam = I[_FREE], F[_DX]
    for a in range(nf):
        lam[a] = r_full[free[a]]
    lu_solve_transposed(F[_LU], nf, I[_PIVOTS], lam)
    sigma = F[_EDOT]  # reused: the full stress resultants
    sigma[:] = F[_SIGMA]
    rows = I[_ROWS]
    for j in range(rows.size):
        sigma[rows[j]] += lam[j]
    # DeF = De DF (NE, NDOF) and G0 = sum DF_e^T (sum_i sigma_i D2e_i) DF_e
    DeF, K, C = F[_DEF], F[_STIFFNESS], F[_DAMPING]
    K[:] = 0.0
    C[:] = 0.0
    DeF[:] = 0.0
    local = F[_LOCAL]
    for g in range(dims[ed.NGROUPS]):
        row = _group(I, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        coords = I[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = I[_DEF_INDEX][row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        De = F[_DE][row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
        D2e = F[_D2E][row[ed.G_D2E_OFFSET]: row[ed.G_D2E_OFFSET] + n * k * m * m]
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
    stressed, S, D = I[_STRESSED], F[_S], F[_D]
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


@njit(cache=True, error_model="numpy")
def _mass_times(I, F, x, v, out):
    """out -= M(x) v for a coordinate vector v (NX,): lumped plus element masses."""
    dims = I[_DIMS]
    nx = dims[ed.NX]
    lumped = F[_LUMPED]
    for a in range(nx):
        out[a] -= lumped[a] * v[a]
    local = F[_LOCAL]
    max_m, max_p = dims[ed.MAX_M], dims[ed.MAX_P]
    data = F[_GROUP_DATA]
    ndof = dims[ed.NDOF]
    for g in range(dims[ed.NGROUPS]):
        row = _group(I, g)
        P = row[ed.G_P]
        if P == 0:
            continue
        code, n, m, width = row[ed.G_KERNEL], row[ed.G_COUNT], row[ed.G_M], row[ed.G_REF_WIDTH]
        coords = I[_COORD_INDEX][row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        refs = data[row[ed.G_DATA_OFFSET]: row[ed.G_DATA_OFFSET] + n * width]
        # scratch after the first 2 ndof entries, which `tangent` keeps for itself
        o = 2 * ndof + max_m * max_m + max_m * ndof
        xl, vl = local[o: o + max_m], local[o + max_m: o + 2 * max_m]
        o += 2 * max_m
        pl, acc, w = local[o: o + max_p], local[o + max_p: o + 2 * max_p], \
            local[o + 2 * max_p: o + 3 * max_p]
        o += 3 * max_p
        Dp = local[o: o + max_p * max_m].reshape((max_p, max_m))
        for i in range(n):
            Mp = data[row[ed.G_MASS_OFFSET] + i * P * P: row[ed.G_MASS_OFFSET] + (i + 1) * P * P]
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
            _element_inertia(code, xl[:m], vl[:m], refs[i * width: (i + 1) * width], 1,
                             pl[:P], Dp[:P, :m], acc[:P])
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
@njit(cache=True, error_model="numpy")
def first_order_rhs(I, F, y, ydot):
    """ydot = [qdot, qddot] for the state y = [q - q_ref, qdot]; a status code.

    The absolute DOFs are formed in the last NDOF entries of the scratch array, which no
    other part of an evaluation uses."""
    n = I[_DIMS][ed.NDOF]
    for j in range(2 * n):
        if not np.isfinite(y[j]):
            return ed.NONFINITE_STATE
    q_abs = F[_LOCAL][F[_LOCAL].size - n:]
    q_ref = F[_Q_REF]
    for j in range(n):
        q_abs[j] = q_ref[j] + y[j]
    status = evaluate(I, F, q_abs, y[n: 2 * n])
    if status != ed.OK:
        return status
    qddot = F[_QDDOT]
    for j in range(n):
        if not np.isfinite(qddot[j]):
            return ed.NONFINITE_RESULT
    if ydot.size:  # empty when only the evaluation left in F is wanted
        for j in range(n):
            ydot[j] = y[n + j]
            ydot[n + j] = qddot[j]
    return ed.OK


@njit(cache=True, error_model="numpy")
def first_order_jacobian(I, F, y, J, column_major):
    """d ydot / d y (2n, 2n) into J (flat; column-major for SUNDIALS' dense matrix):
    [[0, I], [-M_bar^-1 K, -M_bar^-1 C]] with the model's tangent at y; a status code."""
    status = first_order_rhs(I, F, y, F[_DX][: 0])
    if status != ed.OK:
        return status
    n = I[_DIMS][ed.NDOF]
    tangent(I, F, F[_QDDOT])
    K, C, mass_lu, piv = F[_STIFFNESS], F[_DAMPING], F[_MASS_LU], I[_MASS_PIVOTS]
    column = F[_REDUCED_FORCE]
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


@njit(cache=True, error_model="numpy", inline="always")
def _put(J, N, i, j, value, column_major):
    if column_major:
        J[j * N + i] = value
    else:
        J[i * N + j] = value


@njit(cache=True, error_model="numpy")
def implicit_residual(I, F, y, yp, res):
    """IDA's residual [qp - qdot; M_bar (qddot_p - qddot(q, qdot))]; a status code."""
    status = first_order_rhs(I, F, y, F[_DX][: 0])
    if status != ed.OK:
        return status
    n = I[_DIMS][ed.NDOF]
    mass, qddot = F[_MASS], F[_QDDOT]
    for i in range(n):
        res[i] = yp[i] - y[n + i]
        s = 0.0
        for j in range(n):
            s += mass[i * n + j] * (yp[n + j] - qddot[j])
        res[n + i] = s
    return ed.OK


@njit(cache=True, error_model="numpy")
def implicit_jacobian(I, F, y, yp, cj, J):
    """IDA's d res / d y + cj d res / d yp, column-major (2n, 2n): [[cj I, -I], [K, C + cj
    M_bar]] with the tangent's dynamic balance at qddot = yp[n:]; a status code."""
    status = first_order_rhs(I, F, y, F[_DX][: 0])
    if status != ed.OK:
        return status
    n = I[_DIMS][ed.NDOF]
    tangent(I, F, yp[n: 2 * n])
    K, C, mass = F[_STIFFNESS], F[_DAMPING], F[_MASS]
    N = 2 * n
    J[:] = 0.0
    for i in range(n):
        J[i * N + i] = cj
        J[(n + i) * N + i] = -1.0
        for j in range(n):
            J[j * N + n + i] = K[i * n + j]
            J[(n + j) * N + n + i] = C[i * n + j] + cj * mass[i * n + j]
    return ed.OK
