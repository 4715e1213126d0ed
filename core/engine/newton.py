"""The ESDIRK's Newton matrix on the free coordinates, sparse: no dense DOF-space algebra.

For the first-order Jacobian J = [[0, I], [-M_bar^-1 K_bar, -M_bar^-1 C_bar]] the Newton
system (I - hg J) [dq; dv] = [r1; r2] (hg in s) is dq = r1 + hg dv with

    (M_bar + hg C_bar + hg^2 K_bar) dv = M_bar r2 - hg K_bar r1.

With M_bar = DF^T M DF, C_bar = DF^T C_x DF, K_bar = DF^T K_x DF (the coordinate-space
damping C_x = De_s^T D De_s and tangent K_x = De_s^T S De_s + sum_e sum_i sigma_i D2e_i - the
load stiffness of gravity on element masses that hang on rotations (`gravity_stiffness`) and
of the moment inputs, sigma the stress resultants of the full dynamic balance as
`tangent` has them: sigma_c plus the multipliers J^-T (r - M xddot) on every row of J) and
DF = J^-1 [0; I], that is the saddle-point system on the free coordinates

    [H    J_o^T] [dx    ]   [p]     H = M + hg C_x + hg^2 K_x,   p = M a - hg K_x b,
    [J_o  0    ] [lambda] = [0],    a = J^-1 [0; r2],  b = J^-1 [0; r1],

and dv = (J's DOF rows) dx: DF^T J_o^T = 0, and J_o dx = 0 makes dx = DF dv. H has the
pattern of the augmented system's mass block (each element couples its own coordinates in M,
C_x and K_x alike; `newton_packing` checks it), so its sparse LU (`numerics.sparse_lu`) costs
in proportion to the elements, as do J's solves and the products with M and K_x. With rigid
clusters all of it is on the reduced free coordinates z, J the reduced one (`rigid`), and H's
terms of the clusters are `newton_rigid`'s.

Four operations (each the body of its C entry, compiled only for the models that take this
path, dims[NEWTON_SPARSE] = 1):

    NEWTON_JACOBIAN  y: one evaluation at y, then M (with J_o beside and below it), C_x and
                     K_x on H's pattern (slot newton_parts) and J's LU at y (slot newton_j);
                     the ESDIRK's "new Jacobian"
    NEWTON_FACTOR    s = hg: H from them, factored (kept pivots, else pivoting afresh)
    NEWTON_SOLVE     v (2 NDOF,) <- (I - hg J)^-1 v; s = hg of the last NEWTON_FACTOR
    NEWTON_FORCE_SOLVE  the same for v = [r1; hg g], the velocity half as a force
                     (`stage_force`, whose OP_STAGE_FORCE comes with these)

Everything is at the Jacobian's state (its own copies of J's LU and values), so the solve is
(I - hg J)^-1 of the dense path's J to round-off (tests/test_sparse_newton.py). Units: M kg,
C_x N s/m, K_x N/m (and their rotational counterparts), hg s.
"""

import numpy as np

from ..numerics import sparse_lu
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, carray
from ..numerics.rotation_kernels import rates_coefficient
from ..numerics.sparse_lu_pair import solve_pair
from . import data as ed
from . import slots as slot
from .actuators import evaluated_port_values
from .factors import scatter_de
from .gravity_stiffness import has_gravity, subtract_gravity_stiffness
from .kinematics import dof_rows
from .motion import any_nonzero
from .newton_rigid import mass_block, own_tangent, slave_curvature, touching_tangent
from .operations import (
    ENTRY,
    HESSIANS,
    NEWTON_OPERATIONS,
    OP_ACCELERATIONS,
    OP_FORMED_RATES,
    OP_NEWTON_JACOBIAN,
    OP_RHS,
    OP_STAGE_FORCE,
    run,
)
from .point_masses import element_mass, element_points, massless
from .ports import PORT_WIDTH, ROTATION
from .slots import float_array as _f
from .slots import group, group_deformations, group_inertia, inertia_scratch, rigid_element
from .slots import int_array as _i
from .sparse_factors import constraint_values
from .sparse_products import (
    pattern_product,
    pattern_product_pair,
    pattern_product_transposed,
)
from .tangent import balance_force, balance_multipliers

OPERATIONS = NEWTON_OPERATIONS  # this module's entries' operations, in `engine.ENTRIES`
# the operations they call (`engine.CALLS`): the stage force runs the evaluation's parts
CALLS = {OP_NEWTON_JACOBIAN: (OP_RHS,), OP_STAGE_FORCE: (OP_ACCELERATIONS,)}
EULER_PAIRS = 16  # `newton_packing.EULER_PAIRS`


@kernel
def newton_parts(table):
    """(M, C_x, K_x) on H's pattern: views of slot newton_parts."""
    parts = _f(table, slot.NEWTON_PARTS)
    nnz = parts.size // 3
    return parts[:nnz], parts[nnz: 2 * nnz], parts[2 * nnz:]


@kernel
def factor_kept(table, ints, floats):
    """The sparse LU of the values in `floats` with the kept pivots, else pivoting afresh
    (counted in counters[SPARSE_PIVOTING]); whether it could be factored."""
    if sparse_lu.refactor(ints, floats, sparse_lu.THRESHOLD) >= 0.0:
        return True
    _i(table, slot.COUNTERS)[ed.SPARSE_PIVOTING] += 1
    return sparse_lu.factor(ints, floats, sparse_lu.THRESHOLD) >= 0.0


@kernel
def _full_stresses(table):
    """The stress resultants of the full dynamic balance into slot edot (as `tangent`):
    sigma_c plus the multipliers J^-T (r - M xddot) on J's rows, at the last evaluation and
    its accelerations (slot xddot)."""
    r_full = balance_force(table, _f(table, slot.XDDOT), True)
    sigma = _f(table, slot.EDOT)
    balance_multipliers(table, r_full, _f(table, slot.DX), sigma)
    return sigma


@kernel
def element_tangent(table, g, i, sigma, Ke, Ce, row, crow, x, gravity_scratch):
    """K_e = De^T S_e De + sum_b sigma_b D2e_b - d f_g / dx and C_e = De^T D_e De (m * m
    each, row by row) of element i of group g at the coordinates x, S_e and D_e its block of
    S and D (compressed rows), f_g the gravity on its masses where they hang on rotations
    (`gravity_stiffness`; gravity_scratch: where its scratch in slot local starts, -1 for a
    group without gravity, `has_gravity`)."""
    n, m, k, coords, defs, De, D2e = group_deformations(table, g)
    stress_row, stressed = _i(table, slot.NEWTON_STRESS_ROW), _i(table, slot.STRESSED)
    S, D = _f(table, slot.S), _f(table, slot.D)
    pointers, columns = _i(table, slot.STRESS_POINTERS), _i(table, slot.STRESS_COLUMNS)
    damped = _i(table, slot.DIMS)[ed.HAS_DAMPING] == 1
    Ke[: m * m] = 0.0
    Ce[: m * m] = 0.0
    for b in range(k):
        s = sigma[defs[i * k + b]]
        if s != 0.0:
            base2 = (i * k + b) * m * m
            for a in range(m * m):
                Ke[a] += s * D2e[base2 + a]
    for b1 in range(k):
        a1 = stress_row[defs[i * k + b1]]
        if a1 < 0:
            continue
        row[:m] = 0.0
        crow[:m] = 0.0
        for p in range(pointers[a1], pointers[a1 + 1]):
            d2 = stressed[columns[p]]
            for b2 in range(k):  # the element's own deformation (`newton_packing`)
                if defs[i * k + b2] == d2:
                    base = (i * k + b2) * m
                    for c in range(m):
                        row[c] += S[p] * De[base + c]
                        if damped:
                            crow[c] += D[p] * De[base + c]
        base1 = (i * k + b1) * m
        for a in range(m):
            da = De[base1 + a]
            if da == 0.0:
                continue
            for c in range(m):
                Ke[a * m + c] += da * row[c]
                if damped:
                    Ce[a * m + c] += da * crow[c]
    if gravity_scratch >= 0:
        subtract_gravity_stiffness(table, g, i, x, Ke, gravity_scratch)


@kernel(inline="always")  # into its operation's entry, its one caller
def jacobian(table, y):
    """NEWTON_JACOBIAN at the state y (2 NDOF,): M, C_x, K_x on H's pattern and J's LU; a
    status."""
    status = run(table, OP_RHS, y.ctypes.data, 0, 0.0)  # the evaluation only
    if status != ed.OK:
        return status
    run(table, OP_FORMED_RATES, 0, 0, HESSIANS)  # D2e where the evaluation formed h without it
    dims = _i(table, slot.DIMS)
    nf = dims[ed.NFREE]
    rigid = dims[ed.NSLAVES] > 0
    Mv, Cv, Kv = newton_parts(table)
    if rigid:  # M_z with J_o as the evaluation assembles them (before slot x_trial's r_full)
        mass_block(table, Mv)
    sigma = _full_stresses(table)
    if not rigid:
        Mv[:] = 0.0
    Cv[:] = 0.0
    Kv[:] = 0.0
    hmap, De, x = _i(table, slot.NEWTON_H_MAP), _f(table, slot.DE), _f(table, slot.X)
    lumped, col_of_coord = _f(table, slot.LUMPED), _i(table, slot.COL_OF_COORD)
    if not rigid:
        for a in range(dims[ed.NX]):
            c = col_of_coord[a]
            if c >= 0:
                Mv[hmap[c]] += lumped[a]
        scatter_de(table, De, hmap, nf, nf + De.size, Mv)  # J_o below and beside
    local, columns = _f(table, slot.LOCAL), _i(table, slot.POINT_COLUMNS)
    work = _f(table, slot.NEWTON_SCRATCH)[3 * (nf + dims[ed.NRIGID]):]  # past the solve's
    base = nf + 2 * De.size  # the element pairs' part of the map
    rigid_base = base  # then the rigid clusters' parts (`newton_packing._rigid_pairs`)
    for g in range(dims[ed.NGROUPS]):
        rigid_base += group(table, g)[ed.G_COUNT] * group(table, g)[ed.G_M] ** 2
    for g in range(dims[ed.NGROUPS]):
        n, m, k, _, _, _, _ = group_deformations(table, g)
        inertia = group_inertia(table, g)
        n_inertia, _, P, _, _, _, _, masses, _, pattern = inertia
        scratch = inertia_scratch(table, 0, P, m)
        _, _, point, _, w, Dp, o = scratch
        Me, Ke, Ce = local[o: o + m * m], local[o + m * m: o + 2 * m * m], \
            local[o + 2 * m * m: o + 3 * m * m]
        row, crow = local[o + 3 * m * m: o + 3 * m * m + m], \
            local[o + 3 * m * m + m: o + 3 * m * m + 2 * m]
        group_row = group(table, g)
        # gravity's load stiffness, as OP_TANGENT's K_x, its scratch past the rows
        past = o + 3 * m * m + 2 * m if has_gravity(table, g) else -1
        for i in range(n):
            t = rigid_element(table, group_row, i) if rigid else -1
            if t >= 0:  # on its z-coordinates; its mass is in M_z already
                if own_tangent(table, t):
                    element_tangent(table, g, i, sigma, Ke, Ce, row, crow, x, past)
                    touching_tangent(table, t, m, Ke, Ce, Kv, Cv, hmap, rigid_base, work)
                continue
            element_tangent(table, g, i, sigma, Ke, Ce, row, crow, x, past)
            Mp = masses[i * P * P: (i + 1) * P * P]
            heavy = not rigid and i < n_inertia and not massless(Mp, pattern)
            if heavy:  # Me = Dp^T Mp Dp (the point values unused)
                element_points(inertia, scratch, i, x, x, 1)
                point[:P] = 0.0
                element_mass(Mp, pattern, P, m, Dp, point, w, Me, columns)
            for e in range(m * m):
                s = hmap[base + i * m * m + e]
                if s >= 0:
                    Kv[s] += Ke[e]
                    Cv[s] += Ce[e]
                    if heavy:
                        Mv[s] += Me[e]
        base += n * m * m
    if rigid:  # the slaves' curvature, with r_full (slot x_trial) and lam (slot dx)
        slave_curvature(table, _f(table, slot.X_TRIAL), _f(table, slot.DX), Kv, hmap,
                        rigid_base)
    input_load_stiffness(table, Kv)
    return _constraint_factors(table)


@kernel
def input_load_stiffness(table, Kv):
    """K_x -= 2 u P_k on the Euler parameters of every moment input u about axis k (the load
    stiffness of `ports.subtract_input_stiffness`, in coordinate space)."""
    specs, inputs = _i(table, slot.INPUT_PORTS), evaluated_port_values(table)
    port_map = _i(table, slot.NEWTON_PORT_MAP)
    for j in range(inputs.size):
        if specs[j * PORT_WIDTH] != ROTATION or inputs[j] == 0.0:
            continue
        k = specs[j * PORT_WIDTH + 5]
        for a in range(4):
            for b in range(4):
                s = port_map[j * EULER_PAIRS + 4 * a + b]
                if s >= 0:
                    Kv[s] -= 2.0 * inputs[j] * rates_coefficient(k, a, b)


@kernel
def _constraint_factors(table):
    """J's values (`sparse_factors.constraint_values`: slot de, the DOF coordinates' unit
    rows, with rigid clusters De_z and T's rows) factored into slot newton_j_values; a
    status."""
    ints, floats = _i(table, slot.NEWTON_J), _f(table, slot.NEWTON_J_VALUES)
    constraint_values(table, _i(table, slot.NEWTON_J_MAP), sparse_lu.matrix_values(ints, floats))
    return ed.OK if factor_kept(table, ints, floats) else ed.SINGULAR_CONSTRAINTS


@kernel(inline="always")  # into its operation's entry, its one caller
def factor(table, hg):
    """NEWTON_FACTOR: H = M + hg C_x + hg^2 K_x (with J_o) factored; a status."""
    ints, floats = _i(table, slot.NEWTON_H), _f(table, slot.NEWTON_H_VALUES)
    H = sparse_lu.matrix_values(ints, floats)
    Mv, Cv, Kv = newton_parts(table)
    h2 = hg * hg
    for p in range(H.size):
        H[p] = Mv[p] + hg * Cv[p] + h2 * Kv[p]
    return ed.OK if factor_kept(table, ints, floats) else ed.SINGULAR_MASS


@kernel(inline="always")  # into its operations' entries, its callers
def solve(table, v, hg, force):
    """NEWTON_SOLVE: v (2 NDOF,) <- (I - hg J)^-1 v with the factors of the last `factor`
    (made with this hg, s) and the Jacobian's J. With `force` (NEWTON_FORCE_SOLVE) v's
    second half is not r2 but hg g, the stage residual's velocity half as a force on the
    DOFs (`stage_force`: hg g = M_bar(z) r2), taken as DF_J^T p = hg g by p = J_J^T [0; hg g]
    in place of M a (DF_J = J_J^-1 [0; I], so DF_J^T J_J^T [0; w] = w), and J's solve and
    K_x's product of r1 are left out when r1 is zero."""
    dims = _i(table, slot.DIMS)
    ndof, nf = dims[ed.NDOF], dims[ed.NFREE]
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    j_ints, j_floats = _i(table, slot.NEWTON_J), _f(table, slot.NEWTON_J_VALUES)
    h_ints, h_floats = _i(table, slot.NEWTON_H), _f(table, slot.NEWTON_H_VALUES)
    scratch = _f(table, slot.NEWTON_SCRATCH)
    na = nf + n_rigid
    a, b, rhs = scratch[:nf], scratch[na: na + nf], scratch[2 * na: 3 * na]
    Mv, _, Kv = newton_parts(table)
    dof_rows(table, v[ndof: 2 * ndof], a)  # [0; r2] (or [0; hg g]) on J's rows
    dof_rows(table, v[:ndof], b)
    if force:  # [J_J^T [0; hg g] - hg K_x b; 0], b = J^-1 [0; r1]
        rhs[:] = 0.0
        pattern_product_transposed(j_ints, j_floats, sparse_lu.matrix_values(j_ints, j_floats),
                                   a, rhs)
        # with r1 zero to the bit (the stages keep it so on this path:
        # `esdirk_newton.consistent_positions`) b = 0 and its term adds nothing
        if any_nonzero(v[:ndof]):
            sparse_lu.solve(j_ints, j_floats, b, False)
            pattern_product(h_ints, h_floats, Kv, b, rhs, nf, -hg)
    else:  # a = J^-1 [0; r2], b = J^-1 [0; r1]; [M a - hg K_x b; 0]
        solve_pair(j_ints, j_floats, a, b, rhs)  # rhs: its scratch until filled
        rhs[:] = 0.0
        pattern_product_pair(h_ints, h_floats, Mv, a, Kv, b, rhs, nf, -hg)
    sparse_lu.solve(h_ints, h_floats, rhs, False)
    a[:] = 0.0  # J dx on J's rows: the DOF rows are dv
    pattern_product(j_ints, j_floats, sparse_lu.matrix_values(j_ints, j_floats), rhs, a, nf, 1.0)
    for j in range(n_xdof):
        dv = a[n_rigid + n_edof + j]
        v[ndof + j] = dv
        v[j] += hg * dv
    for e in range(n_edof):
        dv = a[n_rigid + e]
        v[ndof + n_xdof + e] = dv
        v[n_xdof + e] += hg * dv


@entry(ENTRY)
def jacobian_entry(op, user_data, t, a, b, c, s):
    """OP_NEWTON_JACOBIAN: y (a)."""
    table = address_of(user_data)
    return jacobian(table, carray(a, (2 * _i(table, slot.DIMS)[ed.NDOF],), np.float64))


@entry(ENTRY)
def factor_entry(op, user_data, t, a, b, c, s):
    """OP_NEWTON_FACTOR: s = hg (s)."""
    return factor(address_of(user_data), s)


@entry(ENTRY)
def solve_entry(op, user_data, t, a, b, c, s):
    """OP_NEWTON_SOLVE: v (a); s = hg (s)."""
    table = address_of(user_data)
    solve(table, carray(a, (2 * _i(table, slot.DIMS)[ed.NDOF],), np.float64), s, False)
    return ed.OK


@entry(ENTRY)
def force_solve_entry(op, user_data, t, a, b, c, s):
    """OP_NEWTON_FORCE_SOLVE: v = [r1; hg g] (a); s = hg (s)."""
    table = address_of(user_data)
    solve(table, carray(a, (2 * _i(table, slot.DIMS)[ed.NDOF],), np.float64), s, True)
    return ed.OK
