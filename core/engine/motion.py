"""Equations of motion in the compiled engine: the accelerations qddot (m/s^2, rad/s^2).

For DOFs q, velocities qdot (m/s, rad/s) and the held inputs u (N, N m; an actuated input's
force or moment from its drive signal or its coil current: `actuators`), in the reduced form
of the course notes (or, for models with many DOFs, in the augmented form on the free
coordinates that `evaluate` describes, which gives the same qddot without forming DF and
M_bar; `data.evaluation_cost` picks one per model):

    M_bar qddot = DF^T (f - M (D2F qdot) qdot - g_conv - De^T sigma_c),  M_bar = DF^T M DF

with f the constant loads, gravity and the inputs (a moment input's force depends on x:
`ports`), sigma_c = S e + D edot on the stressed
deformations (S and D kept by compressed rows), M = diag(lumped) + sum Dp^T Mp Dp over the
inertia points p of the element masses, g_conv = sum Dp^T Mp (D2p xdot) xdot, and (D2F qdot)
qdot = -J^-1 [xdot^T H_i xdot] on the constraint rows. Gravity acts on the inertia points;
the tangent (`tangent`) leaves out its load stiffness, which is not zero where the points
hang on rotations (a BEAM's consistent mass): 5e-9 of K's largest entry on a spatial
cantilever under gravity (tests/test_static_engine.py checks it against the numpy
reference's `gravity_stiffness`). Q is exact; only Newton's rate there is affected.

With rigid clusters (`rigid`) xdot, conv and xddot are solved on the reduced coordinates z and
filled on the slaves' rows (T zdot; T conv_z + c; T zddot + c), the augmented system is the
one on z (a touching element's mass Dp_z^T Mp Dp_z, the forces T^T (r - M c)), and the
reduced form is unchanged on x with DF's slave rows T DF_z.

M_bar is accumulated element by element from (Dp DF_e)^T Mp (Dp DF_e), never from a dense
(NX, NX) M; the augmented system is assembled and factored banded or sparse as the model was
packed (`factors`), so an evaluation in the augmented form costs in proportion to the element
count.
"""

from ..numerics.dense import copy, lu_factor, lu_solve
from ..numerics.jit import kernel
from ..numerics.native import call_engine
from . import data as ed
from . import slots as slot
from .actuators import port_values
from .convective import keep_convective
from .deformation_rates import (
    dof_deformation_accelerations,
    element_rates,
    scatter_stress,
    stress_resultants,
)
from .factors import (
    add_element_mass,
    add_lumped,
    add_rigid_rows,
    augmented_matrix,
    augmented_solve,
    j_solve,
    mass_entries_start,
)
from .kinematics import dof_rows
from .operations import (
    OP_BEAM_MASSES,
    OP_CONFIGURATION,
    OP_DF,
    OP_MASS_OF,
    OP_RIGID_BODIES,
    OP_RIGID_CONDENSE,
    OP_RIGID_CONVECTIVE,
    OP_RIGID_EXPAND,
    OP_RIGID_RATES,
    OP_STAGE_FORCE,
    REFINED_ACCELERATIONS,
    run,
)
from .point_masses import (
    add_point_forces,
    element_mass,
    element_points,
    mass_rows_product,
    massless,
    point_columns,
    point_forces,
)
from .ports import add_input_forces
from .rigid_inertia_kernels import BODIES_AT_REST, BODIES_MOVING, own_mass
from .rigid_kernels import touching, touching_mass
from .slots import float_array as _f
from .slots import (
    group,
    group_inertia,
    inertia_scratch,
    rigid_element,
)
from .slots import int_array as _i


@kernel(inline="always")  # into its operation's entry, its one caller
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
    qdot (slot conv) and xddot (slot xddot); the augmented system's factors (or, solved by
    refinement, dims[A_FACTORS] = A_AT_STAGE) and the inputs (`input_response`); a status.
    With rigid clusters and the sparse Newton matrix the system is solved by refinement with
    the factors of an earlier state to 1e-12 of xddot on z (`refined_accelerations`), A
    assembled and factored only when none are kept or they no longer contract fast.
    `reduced_mass` adds DF and M_bar. Counted in counters[EVALUATIONS]."""
    status, moving = coordinate_forces(table, q, qdot)
    if status != ed.OK:
        return status
    dims = _i(table, slot.DIMS)
    nx, ndof, nf = dims[ed.NX], dims[ed.NDOF], dims[ed.NFREE]
    n_rigid = dims[ed.NRIGID]
    x, xdot, free = _f(table, slot.X), _f(table, slot.XDOT), _i(table, slot.FREE)
    reduced = dims[ed.AUGMENTED] == 0
    rigid = dims[ed.NSLAVES] > 0
    r = _f(table, slot.FORCE)
    quad = _f(table, slot.G)
    rigid_h = _f(table, slot.RIGID_H)
    if moving and rigid:  # h of the reduced coordinates: with the slaves' c
        run(table, OP_RIGID_RATES, 0, 0, 0.0)
    # conv = (D2F qdot) qdot = -J^-1 [h on the constraint rows]: the reduced form's r reads
    # it here, the augmented form's tangent later (`convective`)
    keep_convective(table, moving, rigid, not reduced)
    qddot = _f(table, slot.QDDOT)
    if reduced:  # the reduced form: M_bar, M_bar qddot = DF^T r
        # M_bar, and r -= M conv + g_conv (`reduced_mass_of`, on slots x, xdot, conv, force);
        # the statics' packed model (dims.static): the element masses' gravity, no M_bar
        static = dims[ed.STATIC] == 1
        run(table, OP_MASS_OF, 0, 0, -1.0 if static else 2.0 if moving else 1.0)
        DF, rq = _f(table, slot.DF), _f(table, slot.REDUCED_FORCE)
        for j in range(ndof):
            rq[j] = 0.0
        for a in range(nx):  # DF^T r row by row: DF read along its rows
            ra = r[a]
            if ra != 0.0:
                row = DF[a * ndof: (a + 1) * ndof]
                for j in range(ndof):
                    rq[j] += row[j] * ra
        if static:  # DF^T r is what the statics reads; the tangent finds M_bar "current"
            dims[ed.REDUCED] = dims[ed.MASS_CURRENT] = 1
            return ed.OK
        mass_lu = _f(table, slot.MASS_LU)
        copy(mass_lu, _f(table, slot.MASS))
        dims[ed.REDUCED] = dims[ed.MASS_CURRENT] = 1
        if not lu_factor(mass_lu, ndof, _i(table, slot.MASS_PIVOTS)) > 0.0:
            return ed.SINGULAR_MASS
        copy(qddot, rq)
        lu_solve(mass_lu, ndof, _i(table, slot.MASS_PIVOTS), qddot)
        return ed.OK
    dims[ed.REDUCED] = dims[ed.MASS_CURRENT] = 0
    na = nf + n_rigid
    inputs = _f(table, slot.INPUTS)  # for `input_response`
    rhs = _f(table, slot.AUG_RHS)
    # with rigid clusters and the sparse Newton matrix, A's solution refined with kept factors
    # (`refined_accelerations`), else made here; NOT_CONNECTED: not given its operation
    status = ed.NOT_CONNECTED
    if rigid and dims[ed.NEWTON_SPARSE] == 1:
        status = run(table, OP_STAGE_FORCE, rhs.ctypes.data, 0, REFINED_ACCELERATIONS)
    if status != ed.NOT_CONNECTED:
        if status == ed.OK:  # A of no state: the response refines, or has A made, at it
            dims[ed.A_FACTORS] = ed.A_AT_STAGE
        else:  # b in rhs and the element masses' forces in r: A at this state, r untouched
            A = augmented_matrix(table)
            inertia_forces(table, x, xdot, moving, _f(table, slot.X_TRIAL), A, na)
            add_rigid_rows(table, A, na)
            if not augmented_solve(table, A, na, rhs):
                return ed.SINGULAR_MASS
        copy(_f(table, slot.EVALUATED_INPUTS)[: inputs.size], inputs)
        qddot_of_solution(table, rhs, _f(table, slot.XDDOT), True, quad, moving, qddot)
        return ed.OK
    A = augmented_matrix(table)
    inertia_forces(table, x, xdot, moving, r, A, na)
    add_rigid_rows(table, A, na)
    if rigid:  # T^T (r - M c): the slaves' forces on their masters
        total = _f(table, slot.X_TRIAL)
        rigid_force = _f(table, slot.RIGID_FORCE)
        for a in range(nx):
            total[a] = r[a] + rigid_force[a]
        run(table, OP_RIGID_CONDENSE, total.ctypes.data, rhs.ctypes.data, 0.0)
    else:
        for a in range(nf):
            rhs[a] = r[free[a]]
    for o in range(n_rigid):
        if not moving:
            rhs[nf + o] = 0.0
        else:
            rhs[nf + o] = -(quad[o] + rigid_h[o]) if rigid else -quad[o]
    if not augmented_solve(table, A, na, rhs):
        return ed.SINGULAR_MASS
    copy(_f(table, slot.EVALUATED_INPUTS)[: inputs.size], inputs)
    qddot_of_solution(table, rhs, _f(table, slot.XDDOT), True, quad, moving, qddot)
    return ed.OK


@kernel(inline="always")  # into the entries of `evaluate` and `stage_force`, its callers
def coordinate_forces(table, q, qdot):
    """The front half of an evaluation at DOFs q and velocities qdot, shared by `evaluate`
    and the ESDIRK's stage residual (`stage_force`): the kinematics with J's LU (slot x),
    xdot (slot xdot), the slaves' c, the element rates (edot, and h into slot g if moving),
    the stress resultants (slot sigma) and the coordinate force r = f + B u - De^T sigma_c
    (slot force; N, N m) without the element masses' part. Counted in
    counters[EVALUATIONS]. Returns (status, moving: whether any qdot is nonzero)."""
    _i(table, slot.COUNTERS)[ed.EVALUATIONS] += 1
    status = run(table, OP_CONFIGURATION, q.ctypes.data, 0, 0.0)  # solve_kinematics
    if status != ed.OK:
        return status, False
    dims = _i(table, slot.DIMS)
    nx, ndof, nf = dims[ed.NX], dims[ed.NDOF], dims[ed.NFREE]
    x, xdot, free = _f(table, slot.X), _f(table, slot.XDOT), _i(table, slot.FREE)
    dx = _f(table, slot.DX)
    moving = any_nonzero(qdot)
    reduced = dims[ed.AUGMENTED] == 0
    rigid = dims[ed.NSLAVES] > 0
    if reduced:  # xdot = DF qdot (zero at rest: the statics)
        run(table, OP_DF, 0, 0, 0.0)  # kinematics.compute_DF
        DF = _f(table, slot.DF)
        for a in range(nx):
            s = 0.0
            if moving:
                for j in range(ndof):
                    s += DF[a * ndof + j] * qdot[j]
            xdot[a] = s
    else:  # xdot = J^-1 [0; qdot]
        dof_rows(table, qdot, dx)
        j_solve(table, dx, False)
        xdot[:] = 0.0
        for a in range(nf):
            xdot[free[a]] = dx[a]
        if rigid:  # the slaves': T zdot
            run(table, OP_RIGID_EXPAND, xdot.ctypes.data, 0, 0.0)
    if rigid:  # the slaves' second-order accelerations c (zero at rest)
        run(table, OP_RIGID_CONVECTIVE, x.ctypes.data, xdot.ctypes.data, 0.0)
    # edot and, if moving, the quadratic forms h of the constraint rows (slot g)
    element_rates(table, xdot, moving)
    sigma = stress_resultants(table)  # sigma_c = S e_s + D edot_s
    # coordinate force r = f - De^T sigma_c; the caller adds gravity and g_conv of the element
    # masses
    r = _f(table, slot.FORCE)
    copy(r, _f(table, slot.CONST_FORCE))
    # the inputs' forces and moments, or the actuators' (`actuators.port_values`)
    add_input_forces(_i(table, slot.INPUT_PORTS), port_values(table), x, r)
    scatter_stress(table, sigma, r)
    return ed.OK, moving


@kernel
def qddot_of_solution(table, rhs, xddot, with_c, quad, moving, qddot):
    """qddot (NDOF,) from the augmented system's solution `rhs` (xddot on the free
    coordinates first, in their order): xddot (NX,) filled from it (the slaves' T zddot, + c
    `with_c`), then qddot on the DOF coordinates and De_m xddot (+ h_m when `moving`, h in
    `quad`) on the DOF deformations."""
    dims = _i(table, slot.DIMS)
    free = _i(table, slot.FREE)
    xddot[:] = 0.0
    for a in range(dims[ed.NFREE]):
        xddot[free[a]] = rhs[a]
    if dims[ed.NSLAVES] > 0:
        run(table, OP_RIGID_EXPAND, xddot.ctypes.data, 0, 1.0 if with_c else 0.0)
    positions, dof_coords = _i(table, slot.DOF_POS), _i(table, slot.DOF_COORDS)
    for j in range(dims[ed.NXDOF]):
        qddot[j] = rhs[positions[j]] if positions[j] >= 0 else xddot[dof_coords[j]]
    # the walk over every element's deformations finds rows only where a DOF is a
    # deformation: skipped where none is (it writes nothing then)
    if dims[ed.NEDOF] > 0:
        dof_deformation_accelerations(table, xddot, quad, moving, qddot)


@kernel(inline="always")
def any_nonzero(v):
    """Whether any entry of v is nonzero; a bool that numba types as bool throughout (a flag
    set to False and then maybe True in a loop is typed Literal[False] first, and each
    callee it is passed to was compiled once more for that type)."""
    for value in v:
        if value != 0.0:
            return True
    return False


@kernel
def inertia_forces(table, x, xdot, moving, r, A, na):
    """The mass of the free coordinates M_ff = diag(lumped) + sum Dp^T Mp Dp into A's first
    n_free rows and columns (row length na); gravity on the element masses into r and, if
    moving, r -= g_conv = Dp^T Mp (D2p xdot) xdot. Element by element through the inertia
    points, but for the elements folded into their spatial cluster's rigid body
    (`rigid_inertia`): each cluster's mass block onto A and its forces onto slot
    rigid_force at its master's coordinates, from closed formulas."""
    dims = _i(table, slot.DIMS)
    add_lumped(table, A, na)
    local = _f(table, slot.LOCAL)
    columns = _i(table, slot.POINT_COLUMNS)
    mass_entry = mass_entries_start(table)
    rigid = dims[ed.NSLAVES] > 0
    if rigid:
        _f(table, slot.RIGID_FORCE)[:] = 0.0
    for g in range(dims[ed.NGROUPS]):
        row = group(table, g)
        inertia = group_inertia(table, g)
        n, m, P, _, _, coords, _, masses, gravity, pattern = inertia
        # a group of BEAMs in their closed form, through its operation where the model has it
        # (`beam_mass_entry`: not with rigid clusters; on slots x, xdot and force, which x,
        # xdot and r are); NOT_AVAILABLE for another group, NOT_CONNECTED without it
        if n > 0 and not rigid and run(table, OP_BEAM_MASSES, g, mass_entry,
                                       1.0 if moving else 0.0) == ed.OK:
            mass_entry += n * m * m
            continue
        # scratch: x, v (m), the point forces, acc, w (P), Dp (P, m), Me (m, m)
        scratch = inertia_scratch(table, 0, P, m)
        _, _, point, acc, w, Dp, o = scratch
        Me = local[o: o + m * m]
        for i in range(n):
            t = rigid_element(table, row, i) if rigid else -1
            # a massless touching element, or one whose mass is its cluster's rigid body's
            if t >= 0 and not own_mass(table, t):
                mass_entry += m * m
                continue
            element_points(inertia, scratch, i, x, xdot, 2 if moving else 1)
            for pp in range(P):
                point[pp] = gravity[pp] - acc[pp] if moving else gravity[pp]
            if t < 0:
                element_mass(masses[i * P * P: (i + 1) * P * P], pattern, P, m, Dp, point, w,
                              Me, columns)
            else:  # w alone: its mass goes on its z-coordinates (`touching_element_mass`)
                point_columns(P, m, Dp, columns)
                point_forces(masses[i * P * P: (i + 1) * P * P], pattern, P, point, w)
            add_point_forces(r, coords[i * m: (i + 1) * m], P, m, Dp, w, columns)
            if t < 0:  # M_ff += Me on the free coordinates
                position = columns[P * m + P: P * m + P + m]
                add_element_mass(table, A, na, mass_entry, coords[i * m: (i + 1) * m], m, Me,
                                 position)
            else:
                touching_element_mass(table, t, coords[i * m: (i + 1) * m], masses[i * P * P:
                               (i + 1) * P * P], pattern, P, m, Dp, moving, A, na)
            mass_entry += m * m
    if rigid and _i(table, slot.RIGID_BODIES).size:  # the spatial clusters' folded element
        # masses, one rigid body each, through their operation (`rigid_inertia_kernels`): on
        # slots x and xdot, which x and xdot are; A's length as its time argument
        call_engine(dims[ed.ENGINE], OP_RIGID_BODIES, table, float(A.size), A.ctypes.data, 0, 0,
                    BODIES_MOVING if moving else BODIES_AT_REST)


@kernel
def touching_element_mass(table, t, coords, Mp, pattern, P, m, Dp, moving, A, na):
    """A touching element's mass on its z-coordinates, Me_z = Dp_z^T Mp Dp_z with Dp_z =
    Dp T_e, onto A; if moving, its points' forces from the slaves' c, -Dp_z^T Mp Dp c_e (N,
    N m on the z-coordinates), into slot rigid_force (which `evaluate` condenses with T^T:
    a z-coordinate is free, T^T passes it on as it is)."""
    dims = _i(table, slot.DIMS)
    columns = _i(table, slot.POINT_COLUMNS)
    g, i, mz, z, _, mass_offset = touching(table, t)
    Me, force = touching_mass(table, t, Mp, pattern, P, m, Dp, columns, coords, moving)
    if moving:
        rigid_force = _f(table, slot.RIGID_FORCE)
        for a in range(mz):
            rigid_force[z[a]] -= force[a]
    position = columns[P * mz + P: P * mz + P + mz]
    entry = dims[ed.A_RIGID] + 2 * _f(table, slot.RIGID_DE).size + mass_offset
    add_element_mass(table, A, na, entry, z, mz, Me, position)


@kernel(inline="always")  # into its operation's entry, its one caller
def reduced_mass(table):
    """DF (slot DF), M_bar = DF^T M DF (slot mass) and its LU (slot mass_lu) at the state of
    the last `evaluate`, for the tangent and the implicit form (already there when that took
    the reduced form); a status (SINGULAR_MASS)."""
    dims = _i(table, slot.DIMS)
    if dims[ed.MASS_CURRENT] == 1:
        return ed.OK
    run(table, OP_DF, 0, 0, 0.0)  # kinematics.compute_DF
    run(table, OP_MASS_OF, 0, 0, 0.0)  # reduced_mass_of, without forces
    ndof = dims[ed.NDOF]
    mass_lu = _f(table, slot.MASS_LU)
    copy(mass_lu, _f(table, slot.MASS))
    if not lu_factor(mass_lu, ndof, _i(table, slot.MASS_PIVOTS)) > 0.0:
        return ed.SINGULAR_MASS
    dims[ed.MASS_CURRENT] = 1
    return ed.OK


@kernel
def reduced_mass_of(table, x, xdot, conv, moving, r, with_forces, with_mass):
    """M_bar = DF^T M DF into slot mass (with_mass), element by element through the inertia
    points (M_bar += (Dp DF_e)^T Mp (Dp DF_e)) and the lumped masses; with_forces: also
    gravity on the element masses into r and, if moving, r -= M conv + g_conv (xdot, conv, r
    are not read otherwise)."""
    dims = _i(table, slot.DIMS)
    nx, ndof = dims[ed.NX], dims[ed.NDOF]
    DF, mass, lumped = _f(table, slot.DF), _f(table, slot.MASS), _f(table, slot.LUMPED)
    if with_mass:
        mass[:] = 0.0
    for a in range(nx):  # the lumped masses
        la = lumped[a]
        if la == 0.0 or not (with_mass or (with_forces and moving)):
            continue
        if with_forces and moving:
            r[a] -= la * conv[a]
        if not with_mass:
            continue
        for i in range(ndof):
            di = la * DF[a * ndof + i]
            if di == 0.0:
                continue
            for j in range(ndof):
                mass[i * ndof + j] += di * DF[a * ndof + j]
    local = _f(table, slot.LOCAL)
    max_m, max_p = dims[ed.MAX_M], dims[ed.MAX_P]
    for g in range(dims[ed.NGROUPS]):
        inertia = group_inertia(table, g)
        n, m, P, _, _, coords, _, masses, gravity, pattern = inertia
        # scratch: x, v (m), the point forces, acc, w (P), Dp (P, m), room for the Me of
        # `inertia_forces` (max_p max_m >= m m), B = Dp DF_e and Mp B (P, ndof)
        scratch = inertia_scratch(table, 0, P, m)
        _, _, point, acc, w, Dp, o = scratch
        o += max_p * max_m
        B = local[o: o + max_p * ndof]
        o += max_p * ndof
        MpB = local[o: o + max_p * ndof]
        order = 2 if with_forces and moving else 1
        for i in range(n):
            Mp = masses[i * P * P: (i + 1) * P * P]
            if massless(Mp, pattern):  # no mass, no forces (a rigid body's inner elements)
                continue
            element_points(inertia, scratch, i, x, xdot, order)
            if with_mass:
                B[: P * ndof] = 0.0
            for pp in range(P):  # B = Dp DF_e, and the point forces gravity - Dp conv - acc
                f = gravity[pp]
                for a in range(m):
                    d = Dp[pp, a]
                    if d != 0.0:
                        if with_mass:
                            row_df = coords[i * m + a] * ndof
                            for j in range(ndof):
                                B[pp * ndof + j] += d * DF[row_df + j]
                        if order == 2:
                            f -= d * conv[coords[i * m + a]]
                point[pp] = f - acc[pp] if order == 2 else f
            point_forces(Mp, pattern, P, point, w)  # w = Mp (point forces), MpB = Mp B
            if with_forces:
                for a in range(m):  # r += Dp^T w
                    s = 0.0
                    for pp in range(P):
                        s += Dp[pp, a] * w[pp]
                    r[coords[i * m + a]] += s
            if not with_mass:
                continue
            mass_rows_product(Mp, pattern, P, B, ndof, MpB)
            for pp in range(P):  # M_bar += B^T (Mp B)
                for a in range(ndof):
                    ba = B[pp * ndof + a]
                    if ba == 0.0:
                        continue
                    for b in range(ndof):
                        mass[a * ndof + b] += ba * MpB[pp * ndof + b]

