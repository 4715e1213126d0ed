"""The ESDIRK's stage residual in mass form: a force on the DOFs, with no factorisation of A.

A stage of the ESDIRK (`simulation.esdirk_kernels`) solves z = base + hg f(z) for z = (q, v)
by simplified Newton. The velocity half of its residual, r2 = base_v + hg a(z) - v, needs the
accelerations a(z), and `motion.evaluate` gets them by assembling and factoring the augmented
system A = [M_ff J_o^T; J_o 0] at every iterate. The sparse Newton matrix (`newton`) only
ever uses r2 lifted to a force, M a with a = J^-1 [0; r2], that is M_bar r2 on the DOFs. That
force can be had without A's factors: for the candidate acceleration a_c = (v - base_v) / hg
of the iterate,

    g = DF^T (r - M xddot_c),   xddot_c = J^-1 ([0; a_c] - h)       (N, N m on the DOFs)

with r the coordinate force of the evaluation (f + B u - De^T sigma_c, gravity and -g_conv
of the element masses), h the quadratic forms xdot^T D2e xdot on J's rows (so that xddot_c
is the coordinates' acceleration for qddot = a_c, as `motion.qddot_of_solution` relates
them) and DF^T w = [0 I] J^-T w. Since M_bar a(z) = DF^T (r - M conv), g = M_bar (a(z) - a_c)
exactly, and hg g = M_bar r2: the stage equation's root is the same, the iterates differ
from the accelerations' form by (M_bar(z) - M_bar_J) r2 only (M_bar_J the Newton matrix's).

Cost: the evaluation's front half (`motion.coordinate_forces`), the element masses into A
(the same calls as `evaluate`: A stays assembled, dims[A_FACTORS] = A_ASSEMBLED, so that
`input_response` can factor it if it is asked for), two solves with J's factors and one
product with M_ff (`force_minus_mass`) in place of A's factorisation and solve. Only for
models with the sparse Newton matrix (dims[NEWTON_SPARSE] = 1: no rigid clusters, no coil
currents, no kinematic inputs), whose entry `engine.connect` gives with the Newton
matrix's.
"""

import numpy as np

from ..numerics import banded
from ..numerics.dense import copy
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, carray
from . import data as ed
from . import slots as slot
from .factors import add_rigid_rows, augmented_matrix, j_solve
from .kinematics import dof_rows
from .motion import coordinate_forces, inertia_forces
from .operations import ENTRY
from .slots import float_array as _f
from .slots import int_array as _i
from .sparse_products import pattern_product

# dims[A_FACTORS] after a stage force: A assembled at its state, not factored (the packing's
# NO_FACTORS, BANDED_FACTORS, SPARSE_FACTORS are -1, 0, 1)
A_ASSEMBLED = 2


@kernel
def force_minus_mass(table, A, na, xddot_f, out):
    """out (n_free,) -= M_ff xddot_f: on entry the coordinate force on the free coordinates
    (N, N m, what `evaluate` puts on the augmented system's first n_free rows), xddot_f (n_free,)
    accelerations of the free coordinates (m/s^2, 1/s^2); M_ff the free coordinates' block of
    the assembled A (na rows; its sparse values or its band storage, as the model was packed,
    before any factorisation). The one place the stage force multiplies by the mass."""
    dims = _i(table, slot.DIMS)
    nf = dims[ed.NFREE]
    if dims[ed.A_SPARSE] == 1:  # the pattern's rows and columns below nf: M_ff
        pattern_product(_i(table, slot.AUG_SPARSE), _f(table, slot.AUG_SPARSE_VALUES), A,
                        xddot_f, out, nf, -1.0)
        return
    kl, ku = dims[ed.A_KL], dims[ed.A_KU]
    step, shift = banded.layout(A.size, na, kl, ku)
    apos, t = _i(table, slot.AUG_POS), _f(table, slot.BAND_SCRATCH)
    t[:na] = 0.0  # xddot at the banded positions, zero on the rigid rows' (J_o^T drops out)
    for c in range(nf):
        t[apos[c]] = xddot_f[c]
    for c in range(nf):
        i = apos[c]
        s = 0.0
        for j in range(max(0, i - kl), min(na - 1, i + ku) + 1):
            s += A[i * step + shift + j] * t[j]
        out[c] -= s


@kernel(inline="always")  # into its operation's entry, its one caller
def stage_force(table, y, acc, out):
    """out (NDOF,) = g = DF^T (r - M xddot_c) (N, N m) at the state y = [q - q_ref, qdot] for
    the candidate accelerations acc (NDOF,; m/s^2, rad/s^2): M_bar (qddot(y) - acc), the
    stage residual in mass form (the module's docstring). out may be acc itself. Counted in
    counters[EVALUATIONS] (`coordinate_forces`); a status (NONFINITE_STATE, NONFINITE_RESULT,
    or the kinematics')."""
    dims = _i(table, slot.DIMS)
    n, nf = dims[ed.NDOF], dims[ed.NFREE]
    for j in range(2 * n):
        if not np.isfinite(y[j]):
            return ed.NONFINITE_STATE
    for j in range(n):
        if not np.isfinite(acc[j]):
            return ed.NONFINITE_STATE
    local = _f(table, slot.LOCAL)
    q_abs = local[local.size - n:]  # as `engine.first_order_rhs`: no evaluation uses it
    q_ref = _f(table, slot.Q_REF)
    for j in range(n):
        q_abs[j] = q_ref[j] + y[j]
    status, moving = coordinate_forces(table, q_abs, y[n: 2 * n])
    if status != ed.OK:
        return status
    dims[ed.REDUCED] = dims[ed.MASS_CURRENT] = 0
    na = nf + dims[ed.NRIGID]
    x, xdot, r = _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.FORCE)
    A = augmented_matrix(table)
    inertia_forces(table, x, xdot, moving, r, A, na)
    add_rigid_rows(table, A, na)  # only for `input_response`, should it factor A
    dims[ed.A_FACTORS] = A_ASSEMBLED
    inputs = _f(table, slot.INPUTS)  # the inputs A's force is of, for `input_response`
    copy(_f(table, slot.EVALUATED_INPUTS)[: inputs.size], inputs)
    xddot = _f(table, slot.DX)  # xddot_c = J^-1 ([0; acc] - h) on the free coordinates
    dof_rows(table, acc, xddot)
    if moving:
        quad = _f(table, slot.G)
        for a in range(nf):
            xddot[a] -= quad[a]
    j_solve(table, xddot, False)
    w, free = _f(table, slot.AUG_RHS), _i(table, slot.FREE)
    for a in range(nf):
        w[a] = r[free[a]]
    force_minus_mass(table, A, na, xddot, w)
    j_solve(table, w[:nf], True)  # J^-T w on J's rows: its DOF rows are DF^T w
    n_rigid, n_xdof, n_edof = dims[ed.NRIGID], dims[ed.NXDOF], dims[ed.NEDOF]
    for j in range(n_xdof):
        out[j] = w[n_rigid + n_edof + j]
    for e in range(n_edof):
        out[n_xdof + e] = w[n_rigid + e]
    for j in range(n):
        if not np.isfinite(out[j]):
            return ed.NONFINITE_RESULT
    return ed.OK


@entry(ENTRY)
def stage_force_entry(op, user_data, t, a, b, c, s):
    """OP_STAGE_FORCE: y (a), the candidate accelerations (b), g (c; may be b)."""
    table = address_of(user_data)
    n = _i(table, slot.DIMS)[ed.NDOF]
    return stage_force(table, carray(a, (2 * n,), np.float64), carray(b, (n,), np.float64),
                       carray(c, (n,), np.float64))
