"""The rigid clusters' maps in the compiled engine: slaves explicit in their masters.

For the packed clusters (`rigid`; their plain twin `mechanics.rigid_bodies.RigidLayout`) and
coordinates x (m, Euler parameters or rad) whose masters are current:

    fill_slaves         x_s = S(x_master) on every slave coordinate, and T's weights there
                        (slot rigid_weights: dx_s / dx_master, DEPENDENCIES per coordinate)
    expand              v_s = T v_master (+ c) on the slave rows of a coordinate vector
    expand_columns      the same on the rows of DF (NX, NDOF)
    convective          c (slot rigid_c): xddot_s - T xddot_master, quadratic in the
                        masters' velocities (zero but on slave translations)
    condense            T^T v on the reduced free coordinates (a force (N, N m) on x)
    transform_rows      T_e itself, in rows of a padded length (for products along rows)
    touching_mass       Me_z = Dp_z^T Mp Dp_z of a touching element, Dp_z = Dp T_e, and
                        the forces Dp_z^T Mp Dp c_e of the slaves' c
    rigid_de            the touching elements' De_z on J's rows into slot rigid_de
    rigid_rates         the slaves' second-order terms on the constraint rows (slot rigid_h)
    slave_forces        the forces rho the eliminated rigid rows carried, on the slaves
    rigid_geometric     the slaves' geometric stiffness -DF^T (sum_s rho_s d2x_s) DF

Every function leaves the model without clusters untouched (its tables are empty).
"""

import numpy as np

from ..mechanics.rigid_bodies import (
    DEPENDENCIES,
    PLANAR_ROTATION,
    PLANAR_TRANSLATION,
    SPATIAL_ROTATION,
    SPATIAL_TRANSLATION,
)
from ..numerics.dense import copy
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, carray
from ..numerics.sparse_lu import unsigned_index as _u
from . import data as ed
from . import rigid as rg
from . import slots as slot
from .operations import (
    ENTRY,
    OP_RIGID_CONDENSE,
    OP_RIGID_CONVECTIVE,
    OP_RIGID_DE,
    OP_RIGID_EXPAND,
    OP_RIGID_EXPAND_COLUMNS,
    OP_RIGID_FILL,
    OP_RIGID_GEOMETRIC,
    OP_RIGID_RATES,
    WITH_FORCE,
)
from .point_masses import dense_element_mass, padded_width, sparse_rows_product
from .slots import float_array as _f
from .slots import group_deformations
from .slots import int_array as _i

SW, DW, EW = rg.SLAVE_WIDTH, 48, rg.ELEMENT_WIDTH
_F8 = np.float64


@kernel(inline="always")  # into fill_slaves and convective, in their loops
def times_4x4(data, e, v0, v1, v2, v3):
    """(C v) of the 4 x 4 matrix C stored row by row at data[e: e + 16] and v = (v0 ... v3):
    a slave translation's C_r times its master's Euler parameters or their rates, each row
    summed left to right."""
    return (data[e] * v0 + data[e + 1] * v1 + data[e + 2] * v2 + data[e + 3] * v3,
            data[e + 4] * v0 + data[e + 5] * v1 + data[e + 6] * v2 + data[e + 7] * v3,
            data[e + 8] * v0 + data[e + 9] * v1 + data[e + 10] * v2 + data[e + 11] * v3,
            data[e + 12] * v0 + data[e + 13] * v1 + data[e + 14] * v2 + data[e + 15] * v3)


@kernel
def fill_slaves(table, x):
    """x_s = S(x_master) on every slave coordinate of x (NX,), and T's weights at x. The
    packed records read by index, not sliced (a view a record cost as much as its
    arithmetic: 2.7 us against 1.3 for manipulator_control's 180 slaves), the sums in the
    order of the products C_r lambda, then lambda^T (C_r lambda)."""
    slaves, data = _i(table, slot.RIGID_SLAVES), _f(table, slot.RIGID_DATA)
    W = _f(table, slot.RIGID_WEIGHTS)
    row = 0
    for j in range(slaves.size // SW):
        o, d = j * SW, j * DW  # the slave's record: kind, own (4), mt (3), mr (4); its data
        kind = slaves[o]  # the indices its kind reads unsigned: no test for one from the end
        if kind == SPATIAL_TRANSLATION:  # x_m + C_r lambda lambda / 2
            l0, l1, l2, l3 = x[_u(slaves[o + 8])], x[_u(slaves[o + 9])], x[_u(slaves[o + 10])], \
                x[_u(slaves[o + 11])]
            for k in range(3):
                w = (row + k) * DEPENDENCIES
                W[w] = 1.0
                t0, t1, t2, t3 = times_4x4(data, d + 16 * k, l0, l1, l2, l3)
                W[w + 1], W[w + 2], W[w + 3], W[w + 4] = t0, t1, t2, t3
                x[_u(slaves[o + 1 + k])] = x[_u(slaves[o + 5 + k])] + 0.5 * (
                    t0 * l0 + t1 * l1 + t2 * l2 + t3 * l3)
            row += 3
        elif kind == SPATIAL_ROTATION:  # Q lambda_m
            l0, l1, l2, l3 = x[_u(slaves[o + 8])], x[_u(slaves[o + 9])], x[_u(slaves[o + 10])], \
                x[_u(slaves[o + 11])]
            for k in range(4):
                w, c = (row + k) * DEPENDENCIES, d + 4 * k
                W[w], W[w + 1], W[w + 2], W[w + 3] = data[c], data[c + 1], data[c + 2], \
                    data[c + 3]
                x[_u(slaves[o + 1 + k])] = data[c] * l0 + data[c + 1] * l1 + data[c + 2] * l2 \
                    + data[c + 3] * l3
            row += 4
        elif kind == PLANAR_TRANSLATION:  # x_m + R(phi) r
            phi = x[_u(slaves[o + 8])]
            c, s = np.cos(phi), np.sin(phi)
            x[_u(slaves[o + 1])] = x[_u(slaves[o + 5])] + c * data[d] - s * data[d + 1]
            x[_u(slaves[o + 2])] = x[_u(slaves[o + 6])] + s * data[d] + c * data[d + 1]
            W[row * DEPENDENCIES] = 1.0
            W[row * DEPENDENCIES + 1] = -s * data[d] - c * data[d + 1]
            W[(row + 1) * DEPENDENCIES] = 1.0
            W[(row + 1) * DEPENDENCIES + 1] = c * data[d] - s * data[d + 1]
            row += 2
        elif kind == PLANAR_ROTATION:  # phi_m + phi_rel
            x[_u(slaves[o + 1])] = x[_u(slaves[o + 8])] + data[d]
            W[row * DEPENDENCIES] = 1.0
            row += 1


@kernel
def expand(table, v, with_c):
    """v_s = T v_master on the slave rows of v (NX,), plus c (slot rigid_c) if with_c."""
    coords, deps = _i(table, slot.RIGID_COORDS), _i(table, slot.RIGID_DEPS)
    W, c = _f(table, slot.RIGID_WEIGHTS), _f(table, slot.RIGID_C)
    for s in range(coords.size):  # unsigned indices where they are not negative
        t = c[_u(coords[s])] if with_c else 0.0
        for d in range(DEPENDENCIES):
            dep = deps[_u(s * DEPENDENCIES + d)]
            if dep >= 0:
                t += W[_u(s * DEPENDENCIES + d)] * v[_u(dep)]
        v[_u(coords[s])] = t


@kernel
def expand_columns(table, DF, ndof):
    """DF_s = T DF_master on the slave rows of DF (NX, NDOF; flat, row by row)."""
    coords, deps = _i(table, slot.RIGID_COORDS), _i(table, slot.RIGID_DEPS)
    W = _f(table, slot.RIGID_WEIGHTS)
    for s in range(coords.size):
        out = coords[s] * ndof
        for j in range(ndof):
            DF[out + j] = 0.0
        for d in range(DEPENDENCIES):
            dep = deps[s * DEPENDENCIES + d]
            if dep < 0:
                continue
            w = W[s * DEPENDENCIES + d]
            for j in range(ndof):
                DF[out + j] += w * DF[dep * ndof + j]


@kernel
def convective(table, x, xdot):
    """c (slot rigid_c, NX; m/s^2) for the masters' velocities in xdot: C_r lambdadot
    lambdadot on a spatial slave translation, -R(phi) r phidot^2 on a planar one (records
    read by index, as `fill_slaves`)."""
    slaves, data, c = _i(table, slot.RIGID_SLAVES), _f(table, slot.RIGID_DATA), \
        _f(table, slot.RIGID_C)
    for j in range(slaves.size // SW):
        o, d = j * SW, j * DW
        kind = slaves[o]
        if kind == SPATIAL_TRANSLATION:
            m0, m1, m2, m3 = xdot[slaves[o + 8]], xdot[slaves[o + 9]], xdot[slaves[o + 10]], \
                xdot[slaves[o + 11]]
            for k in range(3):
                t0, t1, t2, t3 = times_4x4(data, d + 16 * k, m0, m1, m2, m3)
                c[slaves[o + 1 + k]] = t0 * m0 + t1 * m1 + t2 * m2 + t3 * m3
        elif kind == PLANAR_TRANSLATION:
            phi = x[slaves[o + 8]]
            co, si, w2 = np.cos(phi), np.sin(phi), xdot[slaves[o + 8]] ** 2
            c[slaves[o + 1]] = -(co * data[d] - si * data[d + 1]) * w2
            c[slaves[o + 2]] = -(si * data[d] + co * data[d + 1]) * w2


@kernel
def condense(table, v, out):
    """out (n_free,) = T^T v on the reduced free coordinates, for v (NX,) on x."""
    free, col_of_coord = _i(table, slot.FREE), _i(table, slot.COL_OF_COORD)
    coords, deps = _i(table, slot.RIGID_COORDS), _i(table, slot.RIGID_DEPS)
    W = _f(table, slot.RIGID_WEIGHTS)
    for a in range(free.size):
        out[a] = v[free[a]]
    for s in range(coords.size):  # unsigned indices where they are not negative
        vs = v[_u(coords[s])]
        if vs == 0.0:
            continue
        for d in range(DEPENDENCIES):
            dep = deps[_u(s * DEPENDENCIES + d)]
            if dep >= 0 and col_of_coord[_u(dep)] >= 0:
                out[_u(col_of_coord[_u(dep)])] += W[_u(s * DEPENDENCIES + d)] * vs


@kernel
def condense_pair(table, v, out, w, out_w):
    """out = T^T v and out_w = T^T w (n_free,) for v, w (NX,) in one walk of T's terms, each
    sum in `condense`'s order (the same bits as two calls)."""
    free, col_of_coord = _i(table, slot.FREE), _i(table, slot.COL_OF_COORD)
    coords, deps = _i(table, slot.RIGID_COORDS), _i(table, slot.RIGID_DEPS)
    W = _f(table, slot.RIGID_WEIGHTS)
    for a in range(free.size):
        out[a] = v[free[a]]
        out_w[a] = w[free[a]]
    for s in range(coords.size):  # unsigned indices where they are not negative
        vs, ws = v[_u(coords[s])], w[_u(coords[s])]
        if vs == 0.0 and ws == 0.0:
            continue
        for d in range(DEPENDENCIES):
            dep = deps[_u(s * DEPENDENCIES + d)]
            if dep >= 0 and col_of_coord[_u(dep)] >= 0:
                weight, column = W[_u(s * DEPENDENCIES + d)], _u(col_of_coord[_u(dep)])
                if vs != 0.0:
                    out[column] += weight * vs
                if ws != 0.0:
                    out_w[column] += weight * ws


@kernel
def transform_rows(table, t, m, T, stride):
    """T_e (m, mz) of touching element t into T (m rows of length `stride` >= mz, zero past
    mz; flat)."""
    element = _i(table, slot.RIGID_ELEMENTS)[t * EW: (t + 1) * EW]
    start = element[rg.E_TERM_OFFSET]
    terms, W = _i(table, slot.RIGID_TERMS), _f(table, slot.RIGID_WEIGHTS)
    for r in range(m * stride):
        T[r] = 0.0
    for a in range(m):
        for u in range(DEPENDENCIES):
            p = start + 2 * (a * DEPENDENCIES + u)
            zl, w = terms[p], terms[p + 1]
            if w == -2:
                continue
            T[a * stride + zl] += 1.0 if w == -1 else W[w]


@kernel
def touching_mass(table, t, Mp, pattern, P, m, Dp, columns, coords, with_c):
    """(Me_z, f_c) of touching element t with points Dp (P, m; the non-zero columns of its
    rows in `columns`, `point_masses.point_columns`) and masses Mp on `pattern`
    (`point_masses`): Me_z = Dp_z^T Mp Dp_z (mz * mz, row by row; kg, kg m, kg m^2 by the
    coordinates) with Dp_z = Dp T_e along T_e's rows, then the dense product, all in rows of
    the padded width; with `with_c`, f_c = Dp_z^T Mp Dp c_e (mz,; N per the slaves' c in
    m/s^2, slot rigid_c at the element's coordinates `coords`), else zeros. c_e rides as
    one more column of T_e, in the padding the products compute anyway (the padded width of
    mz + 1), so f_c costs no products of its own. Both views into slot rigid_local."""
    mz = _i(table, slot.RIGID_ELEMENTS)[t * EW + rg.E_MZ]
    local, stride = _f(table, slot.RIGID_LOCAL), padded_width(mz + 1)
    Dz, MD = local[: P * stride], local[P * stride: 2 * P * stride]
    Me = local[2 * P * stride: (2 * P + mz) * stride]
    T = local[(2 * P + mz) * stride: (2 * P + mz + m) * stride]
    force = local[(2 * P + mz + m) * stride: (2 * P + mz + m) * stride + mz]
    transform_rows(table, t, m, T, stride)
    if with_c:
        c = _f(table, slot.RIGID_C)
        for a in range(m):
            T[a * stride + mz] = c[coords[a]]
    sparse_rows_product(P, m, Dp, columns, T, stride, Dz)
    dense_element_mass(Mp, pattern, P, mz, Dz, MD, Me, stride, force)
    return Me[: mz * mz], force


@kernel
def touching(table, t):
    """(group, element, mz, z-coordinates, De_z offset, mass offset) of touching element t."""
    element = _i(table, slot.RIGID_ELEMENTS)[t * EW: (t + 1) * EW]
    mz, zo = element[rg.E_MZ], element[rg.E_Z_OFFSET]
    return (element[rg.E_GROUP], element[rg.E_ELEMENT], mz,
            _i(table, slot.RIGID_Z)[zo: zo + mz], element[rg.E_DE_OFFSET],
            element[rg.E_MASS_OFFSET])


@kernel(inline="always")  # into the loops over J's rows (here and `sparse_factors`)
def row_de_z(rows, elements, j):
    """(the element's record offset in slot rigid_elements, b, mz, at) of entry j of slot
    touching_rows (`rows`, with `elements` that slot): row b of the touching element's De_z,
    whose mz entries start at `at` in slot rigid_de. Read by index, not through views."""
    e = rows[3 * j + 1] * EW
    b, mz = rows[3 * j + 2], elements[e + rg.E_MZ]
    return e, b, mz, elements[e + rg.E_DE_OFFSET] + b * mz


@kernel
def touching_row(table, j):
    """(r, coords, de, z, at) of entry j of slot touching_rows: row r of J is a deformation of
    a touching element with the coordinates `coords` (model indices, m) and `de` its row of
    De (m,); the element's z-coordinates are z (mz,) and that row of its De_z is at `at` in
    slot rigid_de (mz entries)."""
    rows = _i(table, slot.TOUCHING_ROWS)
    r, t, b = rows[3 * j], rows[3 * j + 1], rows[3 * j + 2]
    g, i, mz, z, offset, _ = touching(table, t)
    n, m, k, coords, defs, De, D2e = group_deformations(table, g)
    return (r, coords[i * m: (i + 1) * m], De[(i * k + b) * m: (i * k + b + 1) * m], z,
            offset + b * mz)


@kernel
def rigid_de(table):
    """The touching elements' De_z = De T_e (k, mz) into slot rigid_de on the rows of J
    (slot touching_rows) alone: J and the augmented system's rigid rows read no other (a
    touching element's stressed deformations are not rows of J; on manipulator_control 57
    of its 342 rows), the others are left as they were. Row by row, skipping the zeros of
    De: each entry sums the same products in the same order as the dense product would."""
    out, rows = _f(table, slot.RIGID_DE), _i(table, slot.TOUCHING_ROWS)
    elements = _i(table, slot.RIGID_ELEMENTS)
    terms, W = _i(table, slot.RIGID_TERMS), _f(table, slot.RIGID_WEIGHTS)
    for g in range(_i(table, slot.DIMS)[ed.NGROUPS]):  # the group's views once
        n, m, k, coords, defs, De, D2e = group_deformations(table, g)
        for j in range(rows.size // 3):
            e, b, mz, at = row_de_z(rows, elements, j)
            if elements[e + rg.E_GROUP] != g:
                continue
            start = elements[e + rg.E_TERM_OFFSET]
            de = (elements[e + rg.E_ELEMENT] * k + b) * m
            for c in range(mz):
                out[at + c] = 0.0
            for a in range(m):  # unsigned indices: no test for one from the end
                d = De[_u(de + a)]
                if d == 0.0:
                    continue
                for u in range(DEPENDENCIES):  # a coordinate's terms first, then -2
                    p = _u(start + 2 * (a * DEPENDENCIES + u))
                    zl, w = terms[p], terms[p + 1]
                    if w == -2:
                        break
                    out[_u(at + zl)] += d * (1.0 if w == -1 else W[_u(w)])


@kernel
def rigid_rates(table):
    """slot rigid_h (n_free, on J's rows) = De_s c_s on the rows of the touching elements
    and c_s on the DOF coordinate rows of slaves: what the slaves' second-order terms add to
    the constraints' xdot^T D2e xdot in the reduced coordinates (c from `convective`)."""
    dims = _i(table, slot.DIMS)
    h, c = _f(table, slot.RIGID_H), _f(table, slot.RIGID_C)
    h[:] = 0.0
    rows, elements = _i(table, slot.TOUCHING_ROWS), _i(table, slot.RIGID_ELEMENTS)
    for g in range(dims[ed.NGROUPS]):  # the group's views once, as `rigid_de`
        n, m, k, coords, defs, De, D2e = group_deformations(table, g)
        for j in range(rows.size // 3):
            e = rows[3 * j + 1] * EW
            if elements[e + rg.E_GROUP] != g:
                continue
            i, b = elements[e + rg.E_ELEMENT], rows[3 * j + 2]
            s = 0.0
            for a in range(m):  # unsigned indices: no test for one from the end
                s += De[_u((i * k + b) * m + a)] * c[_u(coords[i * m + a])]
            h[rows[3 * j]] = s
    units, dof_coords = _i(table, slot.RIGID_UNITS), _i(table, slot.DOF_COORDS)
    n_def = dims[ed.NRIGID] + dims[ed.NEDOF]
    for j in range(units.size):
        if units[j] >= 0:
            h[n_def + j] = c[dof_coords[j]]


@kernel
def slave_forces(table, r_full, lam):
    """rho (slot rigid_force, NX; N, N m): the forces the eliminated rigid rows carried, r_full
    on x less the other rows' J^T lam (the touching elements' rows and the DOF coordinate rows
    of slaves); read on the slave coordinates."""
    dims = _i(table, slot.DIMS)
    rho = _f(table, slot.RIGID_FORCE)
    copy(rho, r_full)
    for j in range(_i(table, slot.TOUCHING_ROWS).size // 3):
        r, coords, de, z, at = touching_row(table, j)
        for a in range(coords.size):
            rho[coords[a]] -= de[a] * lam[r]
    units, dof_coords = _i(table, slot.RIGID_UNITS), _i(table, slot.DOF_COORDS)
    n_def = dims[ed.NRIGID] + dims[ed.NEDOF]
    for j in range(units.size):
        if units[j] >= 0:
            rho[dof_coords[j]] -= lam[n_def + j]
    return rho


@kernel
def add_curvature(table, j, rho, H):
    """H (16,: 4 x 4 on the master's rotation coordinates; a planar master's angle in H[0])
    += sum_k rho_k d2 x_k / d(rotation)2 over slave j's translation coordinates k, for the
    forces rho (NX; N) on them: C_r for the Euler parameters (x_s = x_m + C_r lambda lambda /
    2), -R(phi) r for a planar angle (x_s = x_m + R(phi) r). A slave that is not a
    translation adds nothing."""
    slaves, data, x = _i(table, slot.RIGID_SLAVES), _f(table, slot.RIGID_DATA), _f(table, slot.X)
    kind = slaves[j * SW]
    own, mr = slaves[j * SW + 1: j * SW + 5], slaves[j * SW + 8: j * SW + 12]
    d = data[j * DW: (j + 1) * DW]
    if kind == SPATIAL_TRANSLATION:
        for k in range(3):
            f = rho[own[k]]
            for a in range(16):
                H[a] += f * d[k * 16 + a]
    elif kind == PLANAR_TRANSLATION:
        co, si = np.cos(x[mr[0]]), np.sin(x[mr[0]])
        H[0] -= (rho[own[0]] * (co * d[0] - si * d[1])
                 + rho[own[1]] * (si * d[0] + co * d[1]))


@kernel
def rigid_geometric(table, r_full, lam, K):
    """K -= DF_m^T (sum_s rho_s d2 x_s / d lambda_m2) DF_m over the slave translations: the
    forces rho (N) the eliminated rigid rows carried (r_full on x less the other rows' J^T
    lam), acting through the curvature of the slaves' positions in their master's rotation."""
    ndof = _i(table, slot.DIMS)[ed.NDOF]
    rho = slave_forces(table, r_full, lam)
    slaves, DF = _i(table, slot.RIGID_SLAVES), _f(table, slot.DF)
    H = _f(table, slot.RIGID_LOCAL)[:16]
    H[:] = 0.0
    n_slaves = slaves.size // SW
    for j in range(n_slaves):
        kind, mr = slaves[j * SW], slaves[j * SW + 8: j * SW + 12]
        add_curvature(table, j, rho, H)
        # the slaves of one master follow each other: one product per master
        last = j == n_slaves - 1 or slaves[(j + 1) * SW + 8] != mr[0]
        if not last:
            continue
        size = 4 if kind in (SPATIAL_TRANSLATION, SPATIAL_ROTATION) else 1
        for a in range(size):
            for b in range(size):
                h = H[a * size + b]
                if h == 0.0:
                    continue
                ra, rb = mr[a] * ndof, mr[b] * ndof
                for j1 in range(ndof):
                    fa = h * DF[ra + j1]
                    if fa == 0.0:
                        continue
                    for j2 in range(ndof):
                        K[j1 * ndof + j2] -= fa * DF[rb + j2]
        H[:] = 0.0


@entry(ENTRY)
def rigid_entry(op, user_data, t, a, b, c, s):
    """The rigid clusters' operations (OP_RIGID_...: `operations`), one entry of the engine
    (`engine.ENTRIES`) for all of them: a model has clusters or not."""
    table = address_of(user_data)
    dims = _i(table, slot.DIMS)
    nx, nf = dims[ed.NX], dims[ed.NFREE]
    if op == OP_RIGID_FILL:
        fill_slaves(table, carray(a, (nx,), _F8))
    elif op == OP_RIGID_EXPAND:
        expand(table, carray(a, (nx,), _F8), s != 0.0)
    elif op == OP_RIGID_EXPAND_COLUMNS:
        expand_columns(table, _f(table, slot.DF), dims[ed.NDOF])
    elif op == OP_RIGID_CONVECTIVE:
        convective(table, carray(a, (nx,), _F8), carray(b, (nx,), _F8))
    elif op == OP_RIGID_RATES:
        rigid_rates(table)
    elif op == OP_RIGID_CONDENSE and s == WITH_FORCE:
        condense_pair(table, carray(a, (nx,), _F8), carray(b, (nf,), _F8),
                      _f(table, slot.FORCE), _f(table, slot.DX))
    elif op == OP_RIGID_CONDENSE:
        condense(table, carray(a, (nx,), _F8), carray(b, (nf,), _F8))
    elif op == OP_RIGID_GEOMETRIC:
        rigid_geometric(table, carray(a, (nx,), _F8), carray(b, (nf,), _F8),
                                      _f(table, slot.STIFFNESS))
    elif op == OP_RIGID_DE:
        rigid_de(table)
    else:
        return ed.NOT_CONNECTED
    return ed.OK
