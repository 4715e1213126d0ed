"""The compiled evaluation engine: kinematics, inertia, equations of motion and their tangent.

One place computes, for DOFs q and velocities qdot (m, rad, m/s, rad/s) and the held inputs u
(N, N m), everything the integrators need, compiled with numba and cached on disk:

Kinematics. x = F(q) solves, on the free coordinates, e_o(x) = 0 (deformations prescribed
zero), e_m(x) = q_e (DOF deformations) and x_m = q_x (DOF coordinates). Warm start: the
first-order prediction x_prev + DF_prev (q - q_prev); if its residual exceeds the tolerance,
chord iterations with the previous LU of the constraint Jacobian J (converging at a rate of
order |dq| / L), and full Newton from there if they stall. J DF = [0; I] gives DF where it is
needed (the reduced form, the tangent, the kinematics operation).

Equations of motion, in the reduced form of the course notes (or, for models with many DOFs,
in the augmented form on the free coordinates that `evaluate` describes, which gives the same
qddot without forming DF and M_bar; `engine_data.evaluation_cost` picks one per model):

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
evaluation allocates. J and the augmented system are factored as banded matrices
(`core/banded.py`) in the bandwidth-reducing orders computed at packing, so an evaluation in
the augmented form costs in proportion to the element count. The plain-numpy twin of every
quantity is in `kinematics`, `assembly` and `mechanics` (used by the static analyses); tests
compare the two to round-off.

Status codes (`engine_data`): each function returns OK or the reason it could not finish;
nothing raises inside compiled code.
"""

import numpy as np
from numba import carray, types

from . import banded
from . import engine_data as ed
from .jit import entry, kernel
from .native import address_of, as_float_pointer, as_int_pointer, call_deformations, call_inertia

# slot indices as compile-time constants
(_DIMS, _FREE, _ROWS, _DOF_COORDS, _DOF_DEFS, _DOF_POS, _STRESSED, _INPUT_COORDS, _GROUPS,
 _COORD_INDEX, _DEF_INDEX, _ROW_OF_DEF, _COL_OF_COORD, _PIVOTS, _MASS_PIVOTS,
 _COUNTERS, _AUG_PIVOTS, _J_ROW_POS, _J_COL_POS, _AUG_POS) = range(len(ed.INT_SLOTS))
(_SETTINGS, _S, _D, _LUMPED, _CONST_FORCE, _GROUP_DATA, _INPUTS, _Q_REF, _X, _Q, _DF, _LU,
 _E, _DE, _D2E, _X_TRIAL, _G, _DX, _XDOT, _EDOT, _SIGMA, _FORCE, _MASS, _MASS_LU,
 _REDUCED_FORCE, _QDDOT, _CONV, _LOCAL, _DEF, _STIFFNESS, _DAMPING, _JAC_CACHE,
 _X_START, _XDDOT, _AUG, _AUG_RHS, _BAND_SCRATCH) = range(len(ed.FLOAT_SLOTS))
_N_INT, _N_FLOAT = len(ed.INT_SLOTS), len(ed.FLOAT_SLOTS)


# -- the packed model's arrays, from the address of its table ------------------------------------
# Every function takes the table's address (`table`, int64) and takes from it the arrays it
# uses: passing the 49 arrays themselves from call to call made each call copy hundreds of
# values, and the compiled code ten times larger.
_TABLE_SIZE = 2 * (_N_INT + _N_FLOAT)


@kernel
def int_array(table, slot):
    """The int64 array of `slot` (an index of engine_data.INT_SLOTS) of the packed model whose
    table is at the address `table` (int64); for any compiled code that holds that address."""
    entries = carray(as_int_pointer(table), (_TABLE_SIZE,))
    return carray(as_int_pointer(entries[2 * slot]), (entries[2 * slot + 1],))


@kernel
def float_array(table, slot):
    """The float64 array of `slot` (an index of engine_data.FLOAT_SLOTS), as `int_array`."""
    entries = carray(as_int_pointer(table), (_TABLE_SIZE,))
    k = 2 * (_N_INT + slot)
    return carray(as_float_pointer(entries[k]), (entries[k + 1],))


_i, _f = int_array, float_array  # the short names of the many uses below


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


@kernel
def _group(table, g):
    groups = _i(table, _GROUPS)
    return groups[g * ed.G_WIDTH: (g + 1) * ed.G_WIDTH]


@kernel
def _group_deformations(table, g):
    """(n, m, k, coords, defs, De, D2e) of element group g: its element count, coordinates and
    deformations per element, their model indices (flat, element by element) and the elements'
    De and D2e of the last evaluation (flat)."""
    row = _group(table, g)
    n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
    coords = _i(table, _COORD_INDEX)[row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
    defs = _i(table, _DEF_INDEX)[row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
    De = _f(table, _DE)[row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
    D2e = _f(table, _D2E)[row[ed.G_D2E_OFFSET]: row[ed.G_D2E_OFFSET] + n * k * m * m]
    return n, m, k, coords, defs, De, D2e


# -- deformations of every element ---------------------------------------------------------------
@kernel
def deformations(table, x, order):
    """e (NE,) into slot e and, by order, each element's De, D2e into slot de, slot d2e."""
    dims = _i(table, _DIMS)
    e = _f(table, _E)
    local = _f(table, _LOCAL)
    max_m = dims[ed.MAX_M]
    for g in range(dims[ed.NGROUPS]):
        row = _group(table, g)
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        if k == 0:
            continue
        width, function = row[ed.G_REF_WIDTH], row[ed.G_DEFORMATIONS_ENTRY]
        coords = _i(table, _COORD_INDEX)[row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        defs = _i(table, _DEF_INDEX)[row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
        refs = _f(table, _GROUP_DATA).ctypes.data + 8 * row[ed.G_DATA_OFFSET]
        De = _f(table, _DE).ctypes.data + 8 * row[ed.G_DE_OFFSET]
        D2e = _f(table, _D2E).ctypes.data + 8 * row[ed.G_D2E_OFFSET]
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
def _residual(table, x, q, g):
    """g (n_free,) = [e_rigid; e_dof - q_e; x_dof - q_x] at x with the deformations in slot e."""
    dims = _i(table, _DIMS)
    e = _f(table, _E)
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    rows = _i(table, _ROWS)
    worst = 0.0
    for j in range(n_rigid):
        g[j] = e[rows[j]]
    for j in range(n_edof):
        g[n_rigid + j] = e[rows[n_rigid + j]] - q[n_xdof + j]
    for j in range(n_xdof):
        g[n_rigid + n_edof + j] = x[_i(table, _DOF_COORDS)[j]] - q[j]
    for j in range(g.size):
        worst = max(worst, abs(g[j]))
    return worst


@kernel
def _constraint_jacobian(table, J):
    """J (n_free, n_free) row-major into J from the elements' De in slot de, its rows and
    columns in their banded order (slots j_row_position, j_column_position)."""
    dims = _i(table, _DIMS)
    nf = dims[ed.NFREE]
    J[:] = 0.0
    rpos, cpos = _i(table, _J_ROW_POS), _i(table, _J_COL_POS)
    row_of_def, col_of_coord = _i(table, _ROW_OF_DEF), _i(table, _COL_OF_COORD)
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = _group_deformations(table, g)
        for i in range(n):
            for b in range(k):
                r = row_of_def[defs[i * k + b]]
                if r < 0:
                    continue
                for a in range(m):
                    c = col_of_coord[coords[i * m + a]]
                    if c >= 0:
                        J[rpos[r] * nf + cpos[c]] = De[(i * k + b) * m + a]
    n_def = dims[ed.NRIGID] + dims[ed.NEDOF]
    positions = _i(table, _DOF_POS)
    for j in range(dims[ed.NXDOF]):
        J[rpos[n_def + j] * nf + cpos[positions[j]]] = 1.0


@kernel
def _j_factor(table):
    """J at the deformations' De into slot lu, factored (banded); the pivot ratio."""
    dims = _i(table, _DIMS)
    lu = _f(table, _LU)
    _constraint_jacobian(table, lu)
    return banded.factor(lu, dims[ed.NFREE], _i(table, _PIVOTS), dims[ed.J_KL], dims[ed.J_KU])


@kernel
def _j_solve(table, b):
    """b (n_free,: on J's rows) <- J^-1 b (on the free coordinates), with the factors in
    slot lu."""
    dims = _i(table, _DIMS)
    nf = dims[ed.NFREE]
    rpos, cpos, t = _i(table, _J_ROW_POS), _i(table, _J_COL_POS), _f(table, _BAND_SCRATCH)
    for r in range(nf):
        t[rpos[r]] = b[r]
    banded.solve(_f(table, _LU), nf, _i(table, _PIVOTS), dims[ed.J_KL], dims[ed.J_KU], t)
    for c in range(nf):
        b[c] = t[cpos[c]]


@kernel
def _j_solve_transposed(table, b):
    """b (n_free,: on the free coordinates) <- J^-T b (on J's rows)."""
    dims = _i(table, _DIMS)
    nf = dims[ed.NFREE]
    rpos, cpos, t = _i(table, _J_ROW_POS), _i(table, _J_COL_POS), _f(table, _BAND_SCRATCH)
    for c in range(nf):
        t[cpos[c]] = b[c]
    banded.solve_transposed(_f(table, _LU), nf, _i(table, _PIVOTS), dims[ed.J_KL],
                            dims[ed.J_KU], t)
    for r in range(nf):
        b[r] = t[rpos[r]]


@kernel
def _store(table, q, x):
    """Factor J at the solved x (deformations of order 2 evaluated there) and keep both as the
    next warm start; status SINGULAR_CONSTRAINTS if J's pivots say the configuration is
    singular."""
    dims = _i(table, _DIMS)
    nx = dims[ed.NX]
    ratio = _j_factor(table)
    if not ratio > _f(table, _SETTINGS)[ed.SINGULAR_RATIO]:
        return ed.SINGULAR_CONSTRAINTS
    _f(table, _X)[:nx] = x[:nx]
    _f(table, _Q)[:] = q
    dims[ed.WARM] = 1
    return ed.OK


@kernel
def _dof_rows(table, v, out):
    """out (n_free,) = [0; v_e; v_x]: a DOF vector v (NDOF,: coordinate DOFs first) on the rows
    of J (rigid rows, DOF deformation rows, DOF coordinate rows), so that J^-1 out = DF v."""
    dims = _i(table, _DIMS)
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    out[:] = 0.0
    for j in range(n_xdof):
        out[n_rigid + n_edof + j] = v[j]
    for j in range(n_edof):
        out[n_rigid + j] = v[n_xdof + j]


@kernel
def compute_DF(table):
    """DF (NX, NDOF) into slot DF from the LU of J of the last kinematic solution: J DF =
    [0; I] column by column (NDOF solves)."""
    dims = _i(table, _DIMS)
    ndof, nf = dims[ed.NDOF], dims[ed.NFREE]
    DF, column, unit = _f(table, _DF), _f(table, _DX), _f(table, _REDUCED_FORCE)
    free = _i(table, _FREE)
    DF[:] = 0.0
    for j in range(ndof):
        unit[:] = 0.0
        unit[j] = 1.0
        _dof_rows(table, unit, column)
        _j_solve(table, column)
        for a in range(nf):
            DF[free[a] * ndof + j] = column[a]


@kernel
def solve_kinematics(table, q):
    """x = F(q) into slot x, with e, De, D2e and the LU of J there; a status code."""
    dims = _i(table, _DIMS)
    dims[ed.MASS_CURRENT] = dims[ed.REDUCED] = 0  # DF and M_bar are of another state now
    nx, nf = dims[ed.NX], dims[ed.NFREE]
    tolerance = _f(table, _SETTINGS)[ed.TOLERANCE]
    x, g, dx, free = _f(table, _X_TRIAL), _f(table, _G), _f(table, _DX), _i(table, _FREE)
    if dims[ed.WARM] == 1:
        # the first-order prediction x_prev + DF_prev (q - q_prev): with DF where the reduced
        # form keeps it (every solution computes it there), else as J_prev^-1 [0; dq] with the
        # factors kept from the previous solution
        x_prev, q_prev, dq = _f(table, _X), _f(table, _Q), _f(table, _REDUCED_FORCE)
        ndof = dims[ed.NDOF]
        for j in range(ndof):
            dq[j] = q[j] - q_prev[j]
        if dims[ed.AUGMENTED] == 0:
            DF = _f(table, _DF)
            for a in range(nx):
                s = x_prev[a]
                for j in range(ndof):
                    s += DF[a * ndof + j] * dq[j]
                x[a] = s
        else:
            _dof_rows(table, dq, dx)
            _j_solve(table, dx)
            x[:nx] = x_prev[:nx]
            for a in range(nf):
                x[free[a]] += dx[a]
        deformations(table, x, 2)  # with the derivatives: usually x needs no correction
        if _residual(table, x, q, g) <= tolerance:
            return _store(table, q, x)
        for _ in range(dims[ed.CHORD_ITERATIONS]):
            dx[:] = g
            _j_solve(table, dx)
            step = 0.0
            for a in range(nf):
                x[free[a]] -= dx[a]
                step = max(step, abs(dx[a]))
            if not np.isfinite(step):
                break
            deformations(table, x, 2)
            if _residual(table, x, q, g) <= tolerance or step <= tolerance:
                return _store(table, q, x)
    else:
        x[:] = _f(table, _X_START)
    if not np.all(np.isfinite(x)):
        x[:] = _f(table, _X)
    for _ in range(dims[ed.MAX_NEWTON]):  # full Newton
        deformations(table, x, 1)
        _residual(table, x, q, g)
        if not _j_factor(table) > 0.0:
            return ed.SINGULAR_CONSTRAINTS
        dx[:] = g
        _j_solve(table, dx)
        step = 0.0
        for a in range(nf):
            x[free[a]] -= dx[a]
            step = max(step, abs(dx[a]))
        if not np.isfinite(step):
            return ed.NOT_CONVERGED
        if step <= tolerance:
            deformations(table, x, 2)
            return _store(table, q, x)
    return ed.NOT_CONVERGED


# -- equations of motion ------------------------------------------------------------------------
@kernel
def evaluate(table, q, qdot):
    """qddot (NDOF,) into slot qddot for DOFs q, velocities qdot and the inputs in slot inputs.

    The accelerations come from the augmented system on the free coordinates (no DF, no
    M_bar: the cost of forming DF^T M DF grew as NDOF^2 per element)

        [M_ff  J_o^T] [xddot_f]   [r_f     ]      r = f - De^T sigma_c - g_conv
        [J_o   0    ] [lambda ] = [-h_o    ]      h_i = xdot^T D2e_i xdot

    with J_o the rigid rows of J; then qddot = [xddot on the DOF coordinates; De_m xddot +
    h_m]. This is the reduced equation M_bar qddot = DF^T (r - M conv) (DF spans the null space
    of J_o). Leaves in the packed arrays what the tangent needs: the kinematics with J's LU,
    the constitutive stress resultants (slot sigma), r (slot force), xdot, conv = (D2F qdot)
    qdot (slot conv) and xddot (slot xddot); a status. `reduced_mass` adds DF and M_bar."""
    status = solve_kinematics(table, q)
    if status != ed.OK:
        return status
    dims = _i(table, _DIMS)
    nx, ndof, nf = dims[ed.NX], dims[ed.NDOF], dims[ed.NFREE]
    n_rigid, n_xdof = dims[ed.NRIGID], dims[ed.NXDOF]
    x, xdot, free = _f(table, _X), _f(table, _XDOT), _i(table, _FREE)
    dx = _f(table, _DX)
    moving = False
    for j in range(ndof):
        if qdot[j] != 0.0:
            moving = True
    reduced = dims[ed.AUGMENTED] == 0
    if reduced:  # xdot = DF qdot
        compute_DF(table)
        DF = _f(table, _DF)
        for a in range(nx):
            s = 0.0
            for j in range(ndof):
                s += DF[a * ndof + j] * qdot[j]
            xdot[a] = s
    else:  # xdot = J^-1 [0; qdot]
        _dof_rows(table, qdot, dx)
        _j_solve(table, dx)
        xdot[:] = 0.0
        for a in range(nf):
            xdot[free[a]] = dx[a]
    # edot and, if moving, the quadratic forms h of the constraint rows (slot g)
    _element_rates(table, xdot, moving)
    # sigma_c = S e_s + D edot_s
    sigma, e, edot = _f(table, _SIGMA), _f(table, _E), _f(table, _EDOT)
    stressed, S, D = _i(table, _STRESSED), _f(table, _S), _f(table, _D)
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
    # coordinate force r = f - De^T sigma_c, then gravity and g_conv of the element masses
    r = _f(table, _FORCE)
    r[:] = _f(table, _CONST_FORCE)
    inputs, input_coords = _f(table, _INPUTS), _i(table, _INPUT_COORDS)
    for j in range(inputs.size):
        r[input_coords[j]] += inputs[j]
    _scatter_stress(table, sigma, r)
    quad, conv = _f(table, _G), _f(table, _CONV)
    conv[:] = 0.0
    if moving:  # conv = (D2F qdot) qdot = -J^-1 [h on the constraint rows], for the tangent
        for a in range(nf):
            dx[a] = quad[a]
        _j_solve(table, dx)
        for a in range(nf):
            conv[free[a]] = -dx[a]
    qddot = _f(table, _QDDOT)
    if reduced:  # the reduced form: M_bar, M_bar qddot = DF^T r
        _inertia_reduced(table, x, xdot, conv, moving, r)  # r -= M conv + g_conv here
        DF, rq = _f(table, _DF), _f(table, _REDUCED_FORCE)
        for j in range(ndof):
            s = 0.0
            for a in range(nx):
                s += DF[a * ndof + j] * r[a]
            rq[j] = s
        mass_lu = _f(table, _MASS_LU)
        mass_lu[:] = _f(table, _MASS)
        dims[ed.REDUCED] = dims[ed.MASS_CURRENT] = 1
        if not lu_factor(mass_lu, ndof, _i(table, _MASS_PIVOTS)) > 0.0:
            return ed.SINGULAR_MASS
        qddot[:] = rq
        lu_solve(mass_lu, ndof, _i(table, _MASS_PIVOTS), qddot)
        return ed.OK
    dims[ed.REDUCED] = dims[ed.MASS_CURRENT] = 0
    na = nf + n_rigid
    A, rhs = _f(table, _AUG), _f(table, _AUG_RHS)
    A[: na * na] = 0.0
    _inertia_forces(table, x, xdot, moving, r, A, na)
    _rigid_rows(table, A, na)
    apos, t = _i(table, _AUG_POS), _f(table, _BAND_SCRATCH)
    for a in range(nf):
        t[apos[a]] = r[free[a]]
    for o in range(n_rigid):
        t[apos[nf + o]] = -quad[o] if moving else 0.0
    kl, ku = dims[ed.A_KL], dims[ed.A_KU]
    if not banded.factor(A, na, _i(table, _AUG_PIVOTS), kl, ku) > 0.0:
        return ed.SINGULAR_MASS
    banded.solve(A, na, _i(table, _AUG_PIVOTS), kl, ku, t)
    for u in range(na):
        rhs[u] = t[apos[u]]
    xddot = _f(table, _XDDOT)
    xddot[:] = 0.0
    for a in range(nf):
        xddot[free[a]] = rhs[a]
    positions = _i(table, _DOF_POS)
    for j in range(n_xdof):
        qddot[j] = rhs[positions[j]]
    _dof_deformation_accelerations(table, xddot, quad, moving, qddot)
    return ed.OK


@kernel
def _rigid_rows(table, A, na):
    """The rigid rows J_o of J (De of the deformations prescribed zero on the free coordinates)
    into A (na, na) as [., J_o^T; J_o, 0] beside the mass block of the n_free coordinates."""
    dims = _i(table, _DIMS)
    nf = dims[ed.NFREE]
    row_of_def, col_of_coord = _i(table, _ROW_OF_DEF), _i(table, _COL_OF_COORD)
    n_rigid = dims[ed.NRIGID]
    apos = _i(table, _AUG_POS)
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = _group_deformations(table, g)
        for i in range(n):
            for b in range(k):
                o = row_of_def[defs[i * k + b]]
                if o < 0 or o >= n_rigid:
                    continue
                po = apos[nf + o]
                for a in range(m):
                    c = col_of_coord[coords[i * m + a]]
                    if c >= 0:
                        v = De[(i * k + b) * m + a]
                        A[po * na + apos[c]] = v
                        A[apos[c] * na + po] = v


@kernel
def _dof_deformation_accelerations(table, xddot, quad, moving, qddot):
    """qddot of the DOF deformations: De_m xddot + h_m (the constraint rows of those DOFs)."""
    dims = _i(table, _DIMS)
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    row_of_def = _i(table, _ROW_OF_DEF)
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = _group_deformations(table, g)
        for i in range(n):
            for b in range(k):
                rr = row_of_def[defs[i * k + b]]
                if rr < n_rigid or rr >= n_rigid + n_edof:
                    continue
                s = quad[rr] if moving else 0.0
                base = (i * k + b) * m
                for a in range(m):
                    s += De[base + a] * xddot[coords[i * m + a]]
                qddot[n_xdof + rr - n_rigid] = s


@kernel
def _element_rates(table, xdot, moving):
    """edot = De xdot (slot edot) and, if moving, xdot^T D2e_i xdot of the constraint rows
    into slot g (n_free,: zero on the unit rows of the DOF coordinates)."""
    dims = _i(table, _DIMS)
    edot, quad = _f(table, _EDOT), _f(table, _G)
    row_of_def = _i(table, _ROW_OF_DEF)
    quad[:] = 0.0
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = _group_deformations(table, g)
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
def _scatter_stress(table, sigma, r):
    """r -= De^T sigma, element by element."""
    dims = _i(table, _DIMS)
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = _group_deformations(table, g)
        for i in range(n):
            for b in range(k):
                s = sigma[defs[i * k + b]]
                if s == 0.0:
                    continue
                base = (i * k + b) * m
                for a in range(m):
                    r[coords[i * m + a]] -= De[base + a] * s


@kernel
def _inertia_forces(table, x, xdot, moving, r, A, na):
    """The mass of the free coordinates M_ff = diag(lumped) + sum Dp^T Mp Dp into A's first
    n_free rows and columns (row length na); gravity on the element masses into r and, if
    moving, r -= g_conv = Dp^T Mp (D2p xdot) xdot. Element by element through the inertia
    points."""
    dims = _i(table, _DIMS)
    nx = dims[ed.NX]
    lumped, col_of_coord = _f(table, _LUMPED), _i(table, _COL_OF_COORD)
    apos = _i(table, _AUG_POS)
    for a in range(nx):
        c = col_of_coord[a]
        if c >= 0:
            A[apos[c] * na + apos[c]] += lumped[a]
    local = _f(table, _LOCAL)
    max_m, max_p = dims[ed.MAX_M], dims[ed.MAX_P]
    data = _f(table, _GROUP_DATA)
    for g in range(dims[ed.NGROUPS]):
        row = _group(table, g)
        P = row[ed.G_P]
        if P == 0:
            continue
        n, m, width = row[ed.G_COUNT], row[ed.G_M], row[ed.G_REF_WIDTH]
        function = row[ed.G_INERTIA_ENTRY]
        coords = _i(table, _COORD_INDEX)[row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        refs = data.ctypes.data + 8 * row[ed.G_DATA_OFFSET]
        # scratch: x, v (m), the point forces, acc, w (P), Dp (P, m), Mp Dp (P, m)
        xl, vl = local[:max_m], local[max_m: 2 * max_m]
        o = 2 * max_m
        point, acc, w = local[o: o + max_p], local[o + max_p: o + 2 * max_p], \
            local[o + 2 * max_p: o + 3 * max_p]
        o += 3 * max_p
        Dp = local[o: o + P * m].reshape((P, m))
        o += max_p * max_m
        MpDp = local[o: o + P * m].reshape((P, m))
        gravity = data[row[ed.G_GRAVITY_OFFSET]: row[ed.G_GRAVITY_OFFSET] + P]
        for i in range(n):
            Mp = data[row[ed.G_MASS_OFFSET] + i * P * P: row[ed.G_MASS_OFFSET] + (i + 1) * P * P]
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
                vl[a] = xdot[coords[i * m + a]]
            call_inertia(function, xl.ctypes.data, vl.ctypes.data, refs + 8 * i * width,
                         2 if moving else 1, point.ctypes.data, Dp.ctypes.data,
                         acc.ctypes.data, m, P, width)
            for pp in range(P):
                point[pp] = gravity[pp] - acc[pp] if moving else gravity[pp]
            for pp in range(P):  # w = Mp (point forces), MpDp = Mp Dp
                s = 0.0
                for a in range(m):
                    MpDp[pp, a] = 0.0
                for qq in range(P):
                    mpq = Mp[pp * P + qq]
                    if mpq == 0.0:
                        continue
                    s += mpq * point[qq]
                    for a in range(m):
                        MpDp[pp, a] += mpq * Dp[qq, a]
                w[pp] = s
            for a in range(m):  # r += Dp^T w, M_ff += Dp^T Mp Dp
                s = 0.0
                for pp in range(P):
                    s += Dp[pp, a] * w[pp]
                r[coords[i * m + a]] += s
                ca = col_of_coord[coords[i * m + a]]
                if ca < 0:
                    continue
                ca = apos[ca]
                for b in range(m):
                    cb = col_of_coord[coords[i * m + b]]
                    if cb < 0:
                        continue
                    cb = apos[cb]
                    s = 0.0
                    for pp in range(P):
                        s += Dp[pp, a] * MpDp[pp, b]
                    A[ca * na + cb] += s


@kernel
def _inertia_reduced(table, x, xdot, conv, moving, r):
    """M_bar = DF^T M DF into slot mass (`_reduced_mass_of`); gravity on the element masses
    into r; and, if moving, r -= M conv + g_conv."""
    _reduced_mass_of(table, x, xdot, conv, moving, r, True)


@kernel
def reduced_mass(table):
    """DF (slot DF), M_bar = DF^T M DF (slot mass) and its LU (slot mass_lu) at the state of
    the last `evaluate`, for the tangent and the implicit form (already there when that took
    the reduced form); a status (SINGULAR_MASS)."""
    dims = _i(table, _DIMS)
    if dims[ed.MASS_CURRENT] == 1:
        return ed.OK
    compute_DF(table)
    x = _f(table, _X)
    _reduced_mass_of(table, x, x, x, False, x, False)
    ndof = dims[ed.NDOF]
    mass_lu = _f(table, _MASS_LU)
    mass_lu[:] = _f(table, _MASS)
    if not lu_factor(mass_lu, ndof, _i(table, _MASS_PIVOTS)) > 0.0:
        return ed.SINGULAR_MASS
    dims[ed.MASS_CURRENT] = 1
    return ed.OK


@kernel
def _reduced_mass_of(table, x, xdot, conv, moving, r, with_forces):
    """M_bar = DF^T M DF into slot mass, element by element through the inertia points
    (M_bar += (Dp DF_e)^T Mp (Dp DF_e)) and the lumped masses; with_forces: also gravity on
    the element masses into r and, if moving, r -= M conv + g_conv (xdot, conv, r are not
    read otherwise)."""
    dims = _i(table, _DIMS)
    nx, ndof = dims[ed.NX], dims[ed.NDOF]
    DF, mass, lumped = _f(table, _DF), _f(table, _MASS), _f(table, _LUMPED)
    mass[:] = 0.0
    for a in range(nx):  # the lumped masses
        la = lumped[a]
        if la == 0.0:
            continue
        if with_forces and moving:
            r[a] -= la * conv[a]
        for i in range(ndof):
            di = la * DF[a * ndof + i]
            if di == 0.0:
                continue
            for j in range(ndof):
                mass[i * ndof + j] += di * DF[a * ndof + j]
    local = _f(table, _LOCAL)
    max_m, max_p = dims[ed.MAX_M], dims[ed.MAX_P]
    data = _f(table, _GROUP_DATA)
    for g in range(dims[ed.NGROUPS]):
        row = _group(table, g)
        P = row[ed.G_P]
        if P == 0:
            continue
        n, m, width = row[ed.G_COUNT], row[ed.G_M], row[ed.G_REF_WIDTH]
        function = row[ed.G_INERTIA_ENTRY]
        coords = _i(table, _COORD_INDEX)[row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
        refs = data.ctypes.data + 8 * row[ed.G_DATA_OFFSET]
        # scratch: x, v (m), the point forces, acc, w (P), Dp (P, m), B = Dp DF_e and Mp B
        # (P, ndof)
        xl, vl = local[:max_m], local[max_m: 2 * max_m]
        o = 2 * max_m
        point, acc, w = local[o: o + max_p], local[o + max_p: o + 2 * max_p], \
            local[o + 2 * max_p: o + 3 * max_p]
        o += 3 * max_p
        Dp = local[o: o + P * m].reshape((P, m))
        o += 2 * max_p * max_m
        B = local[o: o + max_p * ndof]
        o += max_p * ndof
        MpB = local[o: o + max_p * ndof]
        gravity = data[row[ed.G_GRAVITY_OFFSET]: row[ed.G_GRAVITY_OFFSET] + P]
        order = 2 if with_forces and moving else 1
        for i in range(n):
            Mp = data[row[ed.G_MASS_OFFSET] + i * P * P: row[ed.G_MASS_OFFSET] + (i + 1) * P * P]
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
                vl[a] = xdot[coords[i * m + a]] if with_forces else 0.0
            call_inertia(function, xl.ctypes.data, vl.ctypes.data, refs + 8 * i * width,
                         order, point.ctypes.data, Dp.ctypes.data, acc.ctypes.data, m, P, width)
            B[: P * ndof] = 0.0
            for pp in range(P):  # B = Dp DF_e, and the point forces gravity - Dp conv - acc
                f = gravity[pp]
                for a in range(m):
                    d = Dp[pp, a]
                    if d != 0.0:
                        row_df = coords[i * m + a] * ndof
                        for j in range(ndof):
                            B[pp * ndof + j] += d * DF[row_df + j]
                        if order == 2:
                            f -= d * conv[coords[i * m + a]]
                point[pp] = f - acc[pp] if order == 2 else f
            for pp in range(P):  # w = Mp (point forces), MpB = Mp B
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
            if with_forces:
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
def tangent(table, qddot):
    """Stiffness K0 + G0 and damping C0 (NDOF, NDOF) into slot stiffness, slot damping at the
    state of the last `evaluate`, with the dynamic balance taken at accelerations qddot; DF,
    M_bar and its LU as `reduced_mass` does. A status."""
    status = reduced_mass(table)
    if status != ed.OK:
        return status
    dims = _i(table, _DIMS)
    nx, ndof, nf = dims[ed.NX], dims[ed.NDOF], dims[ed.NFREE]
    DF, x, conv = _f(table, _DF), _f(table, _X), _f(table, _CONV)
    # r_full = r - M xddot with xddot = DF qddot + conv (the reduced form's r holds - M conv
    # already), then the multipliers J^-T r_full on the free coordinates
    acc = _f(table, _XDDOT)
    with_conv = dims[ed.REDUCED] == 0
    for a in range(nx):
        s = conv[a] if with_conv else 0.0
        for j in range(ndof):
            s += DF[a * ndof + j] * qddot[j]
        acc[a] = s
    r_full = _f(table, _X_TRIAL)
    r_full[:] = _f(table, _FORCE)
    _mass_times(table, x, acc, r_full)
    free, lam = _i(table, _FREE), _f(table, _DX)
    for a in range(nf):
        lam[a] = r_full[free[a]]
    _j_solve_transposed(table, lam)
    sigma = _f(table, _EDOT)  # reused: the full stress resultants
    sigma[:] = _f(table, _SIGMA)
    rows = _i(table, _ROWS)
    for j in range(rows.size):
        sigma[rows[j]] += lam[j]
    # DeF = De DF (NE, NDOF) and G0 = sum DF_e^T (sum_i sigma_i D2e_i) DF_e
    DeF, K, C = _f(table, _DEF), _f(table, _STIFFNESS), _f(table, _DAMPING)
    K[:] = 0.0
    C[:] = 0.0
    DeF[:] = 0.0
    local = _f(table, _LOCAL)
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = _group_deformations(table, g)
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
    stressed, S, D = _i(table, _STRESSED), _f(table, _S), _f(table, _D)
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
    return ed.OK


@kernel
def _mass_times(table, x, v, out):
    """out -= M(x) v for a coordinate vector v (NX,): lumped plus element masses."""
    dims = _i(table, _DIMS)
    nx = dims[ed.NX]
    lumped = _f(table, _LUMPED)
    for a in range(nx):
        out[a] -= lumped[a] * v[a]
    local = _f(table, _LOCAL)
    max_m, max_p = dims[ed.MAX_M], dims[ed.MAX_P]
    data = _f(table, _GROUP_DATA)
    ndof = dims[ed.NDOF]
    for g in range(dims[ed.NGROUPS]):
        row = _group(table, g)
        P = row[ed.G_P]
        if P == 0:
            continue
        n, m, width = row[ed.G_COUNT], row[ed.G_M], row[ed.G_REF_WIDTH]
        function = row[ed.G_INERTIA_ENTRY]
        coords = _i(table, _COORD_INDEX)[row[ed.G_COORD_OFFSET]: row[ed.G_COORD_OFFSET] + n * m]
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
def first_order_rhs(table, y, ydot):
    """ydot = [qdot, qddot] for the state y = [q - q_ref, qdot]; a status code.

    The absolute DOFs are formed in the last NDOF entries of the scratch array, which no
    other part of an evaluation uses."""
    n = _i(table, _DIMS)[ed.NDOF]
    for j in range(2 * n):
        if not np.isfinite(y[j]):
            return ed.NONFINITE_STATE
    q_abs = _f(table, _LOCAL)[_f(table, _LOCAL).size - n:]
    q_ref = _f(table, _Q_REF)
    for j in range(n):
        q_abs[j] = q_ref[j] + y[j]
    status = evaluate(table, q_abs, y[n: 2 * n])
    if status != ed.OK:
        return status
    qddot = _f(table, _QDDOT)
    for j in range(n):
        if not np.isfinite(qddot[j]):
            return ed.NONFINITE_RESULT
    if ydot.size:  # empty when only the evaluation left in F is wanted
        for j in range(n):
            ydot[j] = y[n + j]
            ydot[n + j] = qddot[j]
    return ed.OK


@kernel
def first_order_jacobian(table, y, J, column_major):
    """d ydot / d y (2n, 2n) into J (flat; column-major for SUNDIALS' dense matrix):
    [[0, I], [-M_bar^-1 K, -M_bar^-1 C]] with the model's tangent at y; a status code."""
    status = first_order_rhs(table, y, _f(table, _DX)[: 0])
    if status != ed.OK:
        return status
    n = _i(table, _DIMS)[ed.NDOF]
    status = tangent(table, _f(table, _QDDOT))
    if status != ed.OK:
        return status
    K, C = _f(table, _STIFFNESS), _f(table, _DAMPING)
    mass_lu, piv = _f(table, _MASS_LU), _i(table, _MASS_PIVOTS)
    column = _f(table, _REDUCED_FORCE)
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


@kernel
def _put(J, N, i, j, value, column_major):
    if column_major:
        J[j * N + i] = value
    else:
        J[i * N + j] = value


@kernel
def implicit_residual(table, y, yp, res):
    """IDA's residual [qp - qdot; M_bar (qddot_p - qddot(q, qdot))]; a status code."""
    status = first_order_rhs(table, y, _f(table, _DX)[: 0])
    if status != ed.OK:
        return status
    status = reduced_mass(table)
    if status != ed.OK:
        return status
    n = _i(table, _DIMS)[ed.NDOF]
    mass, qddot = _f(table, _MASS), _f(table, _QDDOT)
    for i in range(n):
        res[i] = yp[i] - y[n + i]
        s = 0.0
        for j in range(n):
            s += mass[i * n + j] * (yp[n + j] - qddot[j])
        res[n + i] = s
    return ed.OK


@kernel
def implicit_jacobian(table, y, yp, cj, J):
    """IDA's d res / d y + cj d res / d yp, column-major (2n, 2n): [[cj I, -I], [K, C + cj
    M_bar]] with the tangent's dynamic balance at qddot = yp[n:]; a status code."""
    status = first_order_rhs(table, y, _f(table, _DX)[: 0])
    if status != ed.OK:
        return status
    n = _i(table, _DIMS)[ed.NDOF]
    status = tangent(table, yp[n: 2 * n])
    if status != ed.OK:
        return status
    K, C, mass = _f(table, _STIFFNESS), _f(table, _DAMPING), _f(table, _MASS)
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
    OP_RESIDUAL_JACOBIAN (y, yp, J; s = cj), OP_KINEMATICS (q; with DF), OP_DEFORMATIONS (x;
    s = order), OP_EVALUATE (q, qdot; with DF and M_bar), OP_TANGENT (qddot). Returns the
    status code."""
    table = address_of(user_data)
    dims = _i(table, _DIMS)
    nx, ndof = dims[ed.NX], dims[ed.NDOF]
    n = 2 * ndof
    f8 = np.float64
    if op == OP_RHS:
        return first_order_rhs(table, carray(a, (n,), f8), carray(b, (n,), f8))
    if op == OP_JACOBIAN:
        return first_order_jacobian(table, carray(a, (n,), f8), carray(b, (n * n,), f8),
                                    s != 0.0)
    if op == OP_RESIDUAL:
        return implicit_residual(table, carray(a, (n,), f8), carray(b, (n,), f8),
                                 carray(c, (n,), f8))
    if op == OP_RESIDUAL_JACOBIAN:
        return implicit_jacobian(table, carray(a, (n,), f8), carray(b, (n,), f8), s,
                                 carray(c, (n * n,), f8))
    if op == OP_KINEMATICS:
        status = solve_kinematics(table, carray(a, (ndof,), f8))
        if status == ed.OK:
            compute_DF(table)
        return status
    if op == OP_DEFORMATIONS:
        deformations(table, carray(a, (nx,), f8), int(s))
        return ed.OK
    if op == OP_EVALUATE:
        status = evaluate(table, carray(a, (ndof,), f8), carray(b, (ndof,), f8))
        return reduced_mass(table) if status == ed.OK else status
    if op == OP_TANGENT:
        return tangent(table, carray(a, (ndof,), f8))
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
