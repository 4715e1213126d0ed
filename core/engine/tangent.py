"""The tangent of the equations of motion in the compiled engine: the integrators' Newton
matrix.

At the state of the last `motion.evaluate` and accelerations qddot: mass M_bar,
damping C0 = DeF_s^T D DeF_s (N s/m, N m s/rad) and stiffness K0 + G0 (N/m, N m/rad),

    K0 = DeF_s^T S DeF_s,   G0 = sum_e DF_e^T (sum_i sigma_i D2e_i) DF_e - DF^T (df/dx) DF,
    DeF = De DF, df/dx the load stiffness of gravity on element masses that hang on
    rotations (`gravity_stiffness`; zero without gravity) and of the moment inputs (`ports`;
    zero without them; an actuator's moment at its value of that evaluation, `actuators`),

with sigma the stress resultants of the full dynamic balance: sigma_c plus the multipliers
J^-T (r - M DF qddot) on the constraint rows (the subscript s: the stressed deformations).
"""

from ..numerics.dense import add_row_products, copy
from ..numerics.jit import kernel
from . import data as ed
from . import slots as slot
from .actuators import evaluated_port_values
from .convective import convective_accelerations
from .factors import j_solve
from .gravity_stiffness import has_gravity, scratch_base, subtract_gravity_stiffness
from .motion import any_nonzero
from .operations import (
    HESSIANS,
    OP_FORMED_RATES,
    OP_INPUT_STIFFNESS,
    OP_MASS,
    OP_RIGID_BODIES,
    OP_RIGID_CONDENSE,
    OP_RIGID_GEOMETRIC,
    OP_ROW_PRODUCTS,
    ROW_GROUPS_FROM,
    run,
)
from .point_masses import element_points, massless, point_forces
from .ports import has_moment_inputs
from .rigid_inertia_kernels import FOLDED_AT_REST, FOLDED_MOVING
from .slots import float_array as _f
from .slots import (
    group_deformations,
    group_inertia,
    inertia_scratch,
)
from .slots import int_array as _i


@kernel(inline="always")  # into its operation's entry, its one caller
def tangent(table, qddot):
    """Stiffness K0 + G0 and damping C0 (NDOF, NDOF) into slot stiffness, slot damping at the
    state of the last `evaluate`, with the dynamic balance taken at accelerations qddot; DF,
    M_bar and its LU as `reduced_mass` does (on the statics' packed model, dims.static, the
    evaluation left M_bar out and marked it current). A status.

    Both on the coordinates first, element by element, then carried to the DOFs once:
    K = DF^T W with W = K_x DF (slot tangent_rows, on the rows of the stressed elements'
    coordinates), K_x = sum_e (De_e^T S_e De_e + sum_i sigma_i D2e_i - df_e/dx) (`coordinate_rows`;
    df_e/dx gravity's, `gravity_stiffness`);
    C likewise with C_x = sum_e De_e^T D_e De_e. A row of K_x is the few elements at one
    coordinate, so the product DF^T W costs (the touched coordinates) NDOF^2, where adding
    each element's DF_e^T H DF_e and each stressed deformation's DeF^T S DeF cost (the
    elements' coordinates plus the stressed deformations) NDOF^2."""
    status = run(table, OP_MASS, 0, 0, 0.0)  # motion.reduced_mass
    if status != ed.OK:
        return status
    run(table, OP_FORMED_RATES, 0, 0, HESSIANS)  # D2e where the solution formed h without it
    dims = _i(table, slot.DIMS)
    nx, ndof = dims[ed.NX], dims[ed.NDOF]
    DF = _f(table, slot.DF)
    r_full, lam = balance_force_at(table, qddot), _f(table, slot.DX)
    sigma = _f(table, slot.EDOT)  # reused: the full stress resultants
    balance_multipliers(table, r_full, lam, sigma)
    rigid = dims[ed.NSLAVES] > 0
    K, C = _f(table, slot.STIFFNESS), _f(table, slot.DAMPING)
    W, ranges = _f(table, slot.TANGENT_ROWS), _i(table, slot.TANGENT_RANGES)
    row_ranges(DF, nx, ndof, ranges)
    # K0 + G0 = DF^T (K_x DF), then (with damping) C0 = DF^T (C_x DF)
    for damping in range(1 + dims[ed.HAS_DAMPING]):
        target = C if damping else K
        target[:] = 0.0  # (C stays as packed, zero, on a model without damping)
        count = coordinate_rows(table, sigma, _f(table, slot.D if damping else slot.S),
                                damping == 0, W, ranges)
        if ndof >= ROW_GROUPS_FROM:  # the product that is faster there (`dense`)
            status = run(table, OP_ROW_PRODUCTS, target.ctypes.data, 0, float(count))
            if status != ed.OK:
                return status
        else:
            add_row_products(DF, W, ndof, ranges[:nx], count, ranges, True, target)
    if rigid:  # what the eliminated rigid rows' multipliers added
        run(table, OP_RIGID_GEOMETRIC, r_full.ctypes.data, lam.ctypes.data, 0.0)
    # the moments of the last evaluation: an input's, or an actuator's (Km sat(G u), Km i)
    specs, inputs = _i(table, slot.INPUT_PORTS), evaluated_port_values(table)
    if has_moment_inputs(specs, inputs):  # - DF^T df/dx DF: a moment's force depends on x
        return run(table, OP_INPUT_STIFFNESS, 0, 0, 0.0)  # (`port_entries`)
    return ed.OK


@kernel
def row_ranges(DF, nx, ndof, ranges):
    """Per row a of DF (nx, ndof) the columns [first, end) of its entries into
    ranges[nx + a], ranges[2 nx + a] (an empty row: [0, 0))."""
    for a in range(nx):
        first, end = 0, 0
        row = DF[a * ndof: (a + 1) * ndof]
        for j in range(ndof):
            if row[j] != 0.0:
                first = j
                break
        for j in range(ndof - 1, first - 1, -1):
            if row[j] != 0.0:
                end = j + 1
                break
        ranges[nx + a], ranges[2 * nx + a] = first, end


@kernel
def coordinate_rows(table, sigma, values, hessians, W, ranges):
    """W = X DF (slot tangent_rows' layout, (nx, ndof)) on the rows it has, for the
    coordinate-space X = sum_e De_e^T V_e De_e (+ sum_i sigma_i D2e_i - df_e/dx with
    `hessians`, df_e/dx the load stiffness of gravity on the element's mass), V
    the packed S or D (`values`, by compressed rows on the stressed deformations; an
    element's V couples its own deformations only); element by element: H (m, m) of the
    element, then W's rows of its coordinates += H DF_e over DF's column ranges
    (`row_ranges`, in `ranges`). A row's range in W (ranges[3 nx + a], ranges[4 nx + a])
    grows to cover what is added to it, zeroed as it grows. The rows W has, ascending, into
    ranges[:count]; returns count."""
    dims = _i(table, slot.DIMS)
    nx, ndof, DF = dims[ed.NX], dims[ed.NDOF], _f(table, slot.DF)
    first, end = ranges[nx: 2 * nx], ranges[2 * nx: 3 * nx]
    w_first, w_end = ranges[3 * nx: 4 * nx], ranges[4 * nx: 5 * nx]
    for a in range(nx):
        w_first[a], w_end[a] = ndof, 0
    stressed, position = _i(table, slot.STRESSED), _i(table, slot.STRESSED_POSITION)
    pointers, columns = _i(table, slot.STRESS_POINTERS), _i(table, slot.STRESS_COLUMNS)
    local, x = _f(table, slot.LOCAL), _f(table, slot.X)
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = group_deformations(table, g)
        H = local[: m * m]
        weighed = hessians and has_gravity(table, g)  # gravity's load stiffness there
        past = scratch_base(table)
        for i in range(n):
            H[:] = 0.0
            empty = True
            if weighed and subtract_gravity_stiffness(table, g, i, x, H, past):
                empty = False
            if hessians:  # sum_i sigma_i D2e_i
                for b in range(k):
                    s = sigma[defs[i * k + b]]
                    if s == 0.0:
                        continue
                    empty = False
                    base2 = (i * k + b) * m * m
                    for a in range(m * m):
                        H[a] += s * D2e[base2 + a]
            for b in range(k):  # De_e^T V_e De_e, V's entries row by row
                row = position[defs[i * k + b]]
                if row < 0:
                    continue
                base = (i * k + b) * m
                for p in range(pointers[row], pointers[row + 1]):
                    v, other = values[p], stressed[columns[p]]
                    if v == 0.0:
                        continue
                    empty = False
                    for c in range(k):
                        if defs[i * k + c] == other:
                            base_c = (i * k + c) * m
                            for a in range(m):
                                va = v * De[base + a]
                                if va != 0.0:
                                    for d in range(m):
                                        H[a * m + d] += va * De[base_c + d]
            if empty:  # H = 0 adds nothing (an element inside a rigid cluster)
                continue
            lo, hi = ndof, 0  # the columns of the element's rows of DF
            for a in range(m):
                row = coords[i * m + a]
                if end[row] > first[row]:
                    lo, hi = min(lo, first[row]), max(hi, end[row])
            if hi <= lo:
                continue
            for a in range(m):  # W's rows cover [lo, hi), zeroed where they grow
                row = W[coords[i * m + a] * ndof: (coords[i * m + a] + 1) * ndof]
                w0, w1 = w_first[coords[i * m + a]], w_end[coords[i * m + a]]
                if w1 <= w0:
                    w0 = w1 = lo
                for j in range(lo, w0):
                    row[j] = 0.0
                for j in range(w1, hi):
                    row[j] = 0.0
                w_first[coords[i * m + a]], w_end[coords[i * m + a]] = min(w0, lo), max(w1, hi)
            for c in range(m):  # W's rows += H DF_e, a column of H at a time
                source_row = coords[i * m + c]
                c0, c1 = first[source_row], end[source_row]
                if c1 <= c0:
                    continue
                source = DF[source_row * ndof + c0: source_row * ndof + c1]
                for a in range(m):
                    h = H[a * m + c]
                    if h == 0.0:
                        continue
                    target_row = coords[i * m + a] * ndof
                    target = W[target_row + c0: target_row + c1]
                    for j in range(c1 - c0):
                        target[j] += h * source[j]
    count = 0
    for a in range(nx):
        if w_end[a] > w_first[a]:
            ranges[count] = a
            count += 1
    return count


@kernel
def balance_force_at(table, qddot):
    """r_full = r - M xddot (slot x_trial, NX) at the last evaluation and accelerations qddot
    (NDOF,): `balance_force` with xddot = DF qddot + conv (`coordinate_accelerations`)."""
    moving = coordinate_accelerations(table, qddot)
    return balance_force(table, _f(table, slot.XDDOT), moving)


@kernel
def coordinate_accelerations(table, qddot):
    """xddot = DF qddot + conv (m/s^2, and the rotation parameters' second derivatives) into
    slot xddot for accelerations qddot (NDOF,; the reduced form's r holds - M conv already,
    so there xddot = DF qddot); whether they may be nonzero: False when qddot and conv are
    all zero (the statics), slot xddot then left as it was. Needs DF (slot DF) when qddot is
    not zero."""
    dims = _i(table, slot.DIMS)
    nx, ndof = dims[ed.NX], dims[ed.NDOF]
    DF, conv = _f(table, slot.DF), _f(table, slot.CONV)
    with_conv = dims[ed.REDUCED] == 0
    if with_conv:
        convective_accelerations(table)
    if not (any_nonzero(qddot) or (with_conv and any_nonzero(conv))):
        return False
    acc = _f(table, slot.XDDOT)
    for a in range(nx):
        s = conv[a] if with_conv else 0.0
        for j in range(ndof):
            s += DF[a * ndof + j] * qddot[j]
        acc[a] = s
    return True


@kernel
def balance_force(table, xddot, moving):
    """r_full = r - M xddot (slot x_trial, NX) at the last evaluation for the coordinate
    accelerations xddot (NX,) given; without `moving` xddot is taken as zero and r_full = r
    (the statics). The augmented form's r leaves the folded elements' forces to their
    clusters' rigid bodies (`rigid_inertia_kernels`): they are added here. Each element's
    share of r sits on its own coordinates, as the multipliers and the slaves' geometric
    stiffness (`rigid_kernels.rigid_geometric`) read it. Units: N (N m, N for the rotation
    parameters' generalised forces)."""
    dims = _i(table, slot.DIMS)
    r_full = _f(table, slot.X_TRIAL)
    copy(r_full, _f(table, slot.FORCE))
    if dims[ed.REDUCED] == 0 and _i(table, slot.RIGID_BODIES).size:  # the folded elements'
        # forces, on slots x and xdot (`rigid_inertia_kernels.add_folded_forces`)
        moving_x = any_nonzero(_f(table, slot.XDOT))
        run(table, OP_RIGID_BODIES, r_full.ctypes.data, 0,
            FOLDED_MOVING if moving_x else FOLDED_AT_REST)
    if moving:
        _mass_times(table, _f(table, slot.X), xddot, r_full)
    return r_full


@kernel
def balance_multipliers(table, r_full, lam, sigma):
    """The multipliers lam = J^-T r_full on J's rows (n_free,; with rigid clusters J_z^-T
    T^T r_full) and the stress resultants of the full balance sigma (NE,) = sigma_c plus lam
    on J's rows (N, or N m over l0)."""
    dims = _i(table, slot.DIMS)
    if dims[ed.NSLAVES] > 0:  # on the reduced coordinates: T^T r_full
        run(table, OP_RIGID_CONDENSE, r_full.ctypes.data, lam.ctypes.data, 0.0)
    else:
        free = _i(table, slot.FREE)
        for a in range(dims[ed.NFREE]):
            lam[a] = r_full[free[a]]
    j_solve(table, lam, True)  # J^-T
    copy(sigma, _f(table, slot.SIGMA))
    rows = _i(table, slot.ROWS)
    for j in range(rows.size):
        sigma[rows[j]] += lam[j]


@kernel
def _mass_times(table, x, v, out):
    """out -= M(x) v for a coordinate vector v (NX,): lumped plus element masses."""
    dims = _i(table, slot.DIMS)
    nx = dims[ed.NX]
    lumped = _f(table, slot.LUMPED)
    for a in range(nx):
        out[a] -= lumped[a] * v[a]
    max_m, ndof = dims[ed.MAX_M], dims[ed.NDOF]
    for g in range(dims[ed.NGROUPS]):
        inertia = group_inertia(table, g)
        n, m, P, _, _, coords, _, masses, _, pattern = inertia
        # scratch past what `tangent` keeps in LOCAL: SD and DD (2 ndof), H and HD (max_m^2,
        # max_m ndof), as if they were laid end to end
        scratch = inertia_scratch(table, 2 * ndof + max_m * max_m + max_m * ndof, P, m)
        _, _, _, acc, w, Dp, _ = scratch
        for i in range(n):
            Mp = masses[i * P * P: (i + 1) * P * P]
            if massless(Mp, pattern):  # M v = 0 there
                continue
            element_points(inertia, scratch, i, x, x, 1)  # order 1: no velocities are read
            for pp in range(P):
                s = 0.0
                for a in range(m):
                    s += Dp[pp, a] * v[coords[i * m + a]]
                acc[pp] = s
            point_forces(Mp, pattern, P, acc, w)  # w = Mp acc over the entries Mp has
            for a in range(m):
                s = 0.0
                for pp in range(P):
                    s += Dp[pp, a] * w[pp]
                out[coords[i * m + a]] -= s

