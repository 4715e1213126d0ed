"""The statics' Newton step on the sparse Newton matrix's saddle-point system, without DF.

The statics' reduced Newton step solves K dq = Q on the DOFs, Q = DF^T r and K = -dQ/dq =
DF^T K_x DF, with K_x = De_s^T S De_s + sum_i sigma_i D2e_i - df/dx the coordinate-space
tangent at rest (sigma the static balance's stress resultants: sigma_c plus the multipliers
J^-T r on J's rows; `tangent` at qddot = 0). Its -df/dx is the dense tangent's: the load
stiffness of gravity on element masses that hang on rotations (`gravity_stiffness`) and of
the moment inputs; the numpy step differs by 3e-12 to 3e-11 of its largest entry on a
16-BEAM strip under gravity, 1e-12 on manipulator_control (the sparse step from the dense
one 2e-12 to 6e-12: tests/test_static_step.py). On the free coordinates (with rigid
clusters the reduced ones z, r then T^T r) the same step solves

    [K_x        s J_o^T] [dx]   [r]
    [s J_o      0      ] [mu] = [0],        dq = (J's DOF rows) dx,

the ESDIRK's Newton system (`newton`: H = M + hg C_x + hg^2 K_x beside J_o) with the inertia
and damping terms absent. Why it is the same: the second row keeps dx on the constraints'
tangent space, dx = DF dq; the first says K_x dx - r lies in the span of J_o^T, which DF^T
annihilates (J DF = [0; I] has zero rigid rows), so DF^T K_x DF dq = DF^T r = Q
(`analysis.static_augmented` says it for the numpy reference). The constraint rows are scaled
by s = max |K_x| (N/m, or N m over the rotation parameters' units), so that the LU's pivots
compare numbers of one size; s changes mu only, which is not used. K_x is assembled on H's
pattern by the Newton matrix's own element kernels (`newton.element_tangent`,
`newton_rigid`) and factored by its sparse LU, in proportion to the elements, where the
dense step forms DF (NDOF solves of J) and DF^T (K_x DF).

One operation, the body of its C entry (compiled for the statics' sparse packing only: a
packed model with dims[NEWTON_SPARSE] = 1, in the augmented form):

    STATIC_STEP  q (NDOF,), qdot (NDOF,) zeros, out (2 NDOF,): the kinematics at q, the force
                 balance at rest (the element masses' gravity included), then out = [dq; Q]:
                 the step dq (m, rad) and Q = DF^T r (N, N m) as the DOF rows of J^-T r;
                 SINGULAR_MASS when the saddle-point system (so K on the DOFs) is singular

A model with kinematic inputs has no sparse Newton matrix (`newton_packing`), so its statics
keep the dense step.
"""

import numpy as np

from ..numerics import sparse_lu
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, carray
from . import data as ed
from . import slots as slot
from .factors import add_rigid_rows, augmented_matrix, scatter_de
from .gravity_stiffness import has_gravity, scratch_base
from .motion import coordinate_forces, inertia_forces
from .newton import element_tangent, factor_kept, input_load_stiffness, newton_parts
from .newton_rigid import own_tangent, slave_curvature, touching_tangent
from .operations import ENTRY, HESSIANS, OP_FORMED_RATES, OP_RIGID_CONDENSE, run
from .slots import float_array as _f
from .slots import group, group_deformations, rigid_element
from .slots import int_array as _i
from .sparse_factors import constraint_values
from .sparse_products import pattern_product
from .tangent import balance_force, balance_multipliers


@kernel
def _coordinate_tangent(table, sigma, r_full, lam, Kv):
    """K_x at rest onto Kv (H's pattern, zeroed here): each element's De^T S De + sum_b
    sigma_b D2e_b - df/dx of its mass's gravity (a touching element's carried by its T_e),
    the slaves' curvature under the eliminated rows' forces (r_full, lam) and the moment
    inputs' load stiffness."""
    dims = _i(table, slot.DIMS)
    rigid = dims[ed.NSLAVES] > 0
    hmap, De = _i(table, slot.NEWTON_H_MAP), _f(table, slot.DE)
    local, x = _f(table, slot.LOCAL), _f(table, slot.X)
    work = _f(table, slot.NEWTON_SCRATCH)[3 * (dims[ed.NFREE] + dims[ed.NRIGID]):]
    Kv[:] = 0.0
    base = dims[ed.NFREE] + 2 * De.size  # the element pairs' part of the map
    rigid_base = base  # then the rigid clusters' parts (`newton_packing._rigid_pairs`)
    for g in range(dims[ed.NGROUPS]):
        rigid_base += group(table, g)[ed.G_COUNT] * group(table, g)[ed.G_M] ** 2
    for g in range(dims[ed.NGROUPS]):
        n, m, _, _, _, _, _ = group_deformations(table, g)
        # K_e, C_e (unused: no damping at rest) and two rows, at the start of slot local
        Ke, Ce = local[: m * m], local[m * m: 2 * m * m]
        row, crow = local[2 * m * m: 2 * m * m + m], local[2 * m * m + m: 2 * m * m + 2 * m]
        group_row = group(table, g)
        # gravity's load stiffness (`gravity_stiffness`), its scratch past the rows
        past = scratch_base(table) if has_gravity(table, g) else -1
        for i in range(n):
            t = rigid_element(table, group_row, i) if rigid else -1
            if t >= 0:  # on its z-coordinates (the statics' packing has no damping, so
                if own_tangent(table, t):  # C_z, the second Kv, is not written)
                    element_tangent(table, g, i, sigma, Ke, Ce, row, crow, x, past)
                    touching_tangent(table, t, m, Ke, Ce, Kv, Kv, hmap, rigid_base, work)
                continue
            element_tangent(table, g, i, sigma, Ke, Ce, row, crow, x, past)
            for e in range(m * m):
                s = hmap[base + i * m * m + e]
                if s >= 0:
                    Kv[s] += Ke[e]
        base += n * m * m
    if rigid:
        slave_curvature(table, r_full, lam, Kv, hmap, rigid_base)
    input_load_stiffness(table, Kv)


@kernel(inline="always")  # into its operation's entry, its one caller
def static_step(table, q, rest, out):
    """STATIC_STEP at DOFs q (m, rad): out = [dq; Q] (module docstring); rest (NDOF,) zeros,
    the velocities. A status."""
    status, _ = coordinate_forces(table, q, rest)
    if status != ed.OK:
        return status
    dims = _i(table, slot.DIMS)
    ndof, nf, n_rigid = dims[ed.NDOF], dims[ed.NFREE], dims[ed.NRIGID]
    n_xdof, n_edof = dims[ed.NXDOF], dims[ed.NEDOF]
    na = nf + n_rigid
    rigid = dims[ed.NSLAVES] > 0
    x, xdot, r = _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.FORCE)
    # gravity on the element masses into r, as the augmented evaluation adds it (the mass it
    # assembles into the augmented system's storage is not read)
    inertia_forces(table, x, xdot, False, r, augmented_matrix(table), na)
    dims[ed.REDUCED] = dims[ed.MASS_CURRENT] = 0
    run(table, OP_FORMED_RATES, 0, 0, HESSIANS)  # D2e where the solution formed h without it
    r_full = balance_force(table, _f(table, slot.XDDOT), False)  # r at rest (slot x_trial)
    scratch = _f(table, slot.NEWTON_SCRATCH)
    dof_part, rhs = scratch[:nf], scratch[2 * na: 3 * na]
    if rigid:  # on the reduced coordinates: T^T r
        run(table, OP_RIGID_CONDENSE, r_full.ctypes.data, rhs.ctypes.data, 0.0)
    else:
        free = _i(table, slot.FREE)
        for a in range(nf):
            rhs[a] = r_full[free[a]]
    rhs[nf:na] = 0.0  # the iterate is on the constraints (the engine's kinematics solved it)
    lam, sigma = _f(table, slot.DX), _f(table, slot.EDOT)
    balance_multipliers(table, r_full, lam, sigma)  # lam = J^-T r on J's rows
    for j in range(n_xdof):  # Q = DF^T r = [0; I]^T J^-T r: the DOF rows of lam
        out[ndof + j] = lam[n_rigid + n_edof + j]
    for e in range(n_edof):
        out[ndof + n_xdof + e] = lam[n_rigid + e]
    _, _, Kv = newton_parts(table)
    _coordinate_tangent(table, sigma, r_full, lam, Kv)
    h_ints, h_floats = _i(table, slot.NEWTON_H), _f(table, slot.NEWTON_H_VALUES)
    H = sparse_lu.matrix_values(h_ints, h_floats)
    H[:] = 0.0  # s J_o below and beside K_x
    if rigid:  # the De_z rows too, by the augmented system's sparse map (`newton_packing`:
        add_rigid_rows(table, H, na)  # with clusters it is factored sparse, H's pattern)
    else:
        scatter_de(table, _f(table, slot.DE), _i(table, slot.NEWTON_H_MAP), nf,
                    nf + _f(table, slot.DE).size, H)
    scale = 0.0
    for p in range(Kv.size):
        scale = max(scale, abs(Kv[p]))
    if scale == 0.0:
        scale = 1.0
    for p in range(H.size):
        H[p] = scale * H[p] + Kv[p]
    if not factor_kept(table, h_ints, h_floats):
        return ed.SINGULAR_MASS
    sparse_lu.solve(h_ints, h_floats, rhs, False)
    j_ints, j_floats = _i(table, slot.NEWTON_J), _f(table, slot.NEWTON_J_VALUES)
    J = sparse_lu.matrix_values(j_ints, j_floats)
    constraint_values(table, _i(table, slot.NEWTON_J_MAP), J)  # J's values at q, unfactored
    dof_part[:] = 0.0  # J dx on J's rows: the DOF rows are dq
    pattern_product(j_ints, j_floats, J, rhs, dof_part, nf, 1.0)
    for j in range(n_xdof):
        out[j] = dof_part[n_rigid + n_edof + j]
    for e in range(n_edof):
        out[n_xdof + e] = dof_part[n_rigid + e]
    return ed.OK


@entry(ENTRY)
def static_step_entry(op, user_data, t, a, b, c, s):
    """OP_STATIC_STEP: q (a), qdot (b, zeros), out (c, 2 NDOF)."""
    table = address_of(user_data)
    n = _i(table, slot.DIMS)[ed.NDOF]
    return static_step(table, carray(a, (n,), np.float64), carray(b, (n,), np.float64),
                       carray(c, (2 * n,), np.float64))
