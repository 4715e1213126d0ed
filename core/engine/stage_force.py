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

Cost: the evaluation's front half (`motion.coordinate_forces`), two solves with J's factors
and r - M xddot_c element by element without forming M (`inertia_product.force_minus_mass`),
in place of A's assembly, factorisation and solve. dims[A_FACTORS] = A_AT_STAGE then says
that A is of no state: `input_response`, asked for the first stage after the inputs changed,
has the operation assemble and factor it at the stage's (FACTOR_A). Only for
models with the sparse Newton matrix (dims[NEWTON_SPARSE] = 1: no coil currents, no
kinematic inputs), whose entry `engine.connect` gives with the Newton matrix's. With rigid
clusters everything is on the reduced coordinates z as in `evaluate`: h on J's rows with the
slaves' c (rigid_h), and the force on z (`force_minus_mass`: T^T, the folded clusters).
"""

import numpy as np

from ..numerics.dense import copy
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, carray
from . import data as ed
from . import slots as slot
from .factors import add_rigid_rows, augmented_factor, augmented_matrix, j_solve
from .inertia_product import force_minus_mass
from .kinematics import dof_rows, dof_values
from .motion import any_nonzero, coordinate_forces, inertia_forces
from .operations import ENTRY, FACTOR_A, OP_RIGID_RATES, REFINED_ACCELERATIONS, run
from .refined_accelerations import refined_accelerations
from .slots import float_array as _f
from .slots import int_array as _i


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
    x, xdot, r = _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.FORCE)
    dims[ed.A_FACTORS] = ed.A_AT_STAGE  # for `input_response`, should it need A (`factor_a`)
    inputs = _f(table, slot.INPUTS)  # the inputs A's force is of, for `input_response`
    copy(_f(table, slot.EVALUATED_INPUTS)[: inputs.size], inputs)
    xddot = _f(table, slot.DX)  # xddot_c = J^-1 ([0; acc] - h) on the free coordinates
    dof_rows(table, acc, xddot)
    if moving:  # h on J's rows; with rigid clusters also the slaves' c (as `evaluate`)
        quad = _f(table, slot.G)
        for a in range(nf):
            xddot[a] -= quad[a]
        if dims[ed.NSLAVES] > 0:
            run(table, OP_RIGID_RATES, 0, 0, 0.0)
            rigid_h = _f(table, slot.RIGID_H)
            for a in range(nf):
                xddot[a] -= rigid_h[a]
    j_solve(table, xddot, False)
    # w = rhs_f - M_ff xddot_c without assembling M (`inertia_product`); slot xddot gets the
    # coordinates' accelerations at acc, slot x_trial the force before T^T
    w = _f(table, slot.AUG_RHS)
    status = force_minus_mass(table, x, xdot, moving, r, xddot[:nf], _f(table, slot.XDDOT),
                              _f(table, slot.X_TRIAL), w[:nf])
    if status != ed.OK:
        return status
    j_solve(table, w[:nf], True)  # J^-T w on J's rows
    dof_values(table, w, out)  # DF^T w
    for j in range(n):
        if not np.isfinite(out[j]):
            return ed.NONFINITE_RESULT
    return ed.OK


@kernel(inline="always")  # into its operation's entry, its one caller
def factor_a(table):
    """The augmented system A assembled and factored at the state the last stage force (or
    refined evaluation, `refined_accelerations`) left in the slots (x, xdot), as `evaluate`
    would have at that state, for `input_response`; a status (SINGULAR_MASS when A is
    singular). The element masses' forces that the assembly adds go to a copy of slot force
    (in slot refinement, free when this is called), which a refined evaluation has already
    completed with them."""
    dims = _i(table, slot.DIMS)
    na, nx = dims[ed.NFREE] + dims[ed.NRIGID], dims[ed.NX]
    x, xdot = _f(table, slot.X), _f(table, slot.XDOT)
    r = _f(table, slot.REFINEMENT)[3 * na: 3 * na + nx]
    copy(r, _f(table, slot.FORCE))
    A = augmented_matrix(table)
    inertia_forces(table, x, xdot, any_nonzero(xdot), r, A, na)
    add_rigid_rows(table, A, na)
    return ed.OK if augmented_factor(table, A, na) else ed.SINGULAR_MASS


@entry(ENTRY)
def stage_force_entry(op, user_data, t, a, b, c, s):
    """OP_STAGE_FORCE: s = FORCE: y (a), the candidate accelerations (b), g (c; may be b);
    s = FACTOR_A: A at the last stage force's state (`factor_a`); s = REFINED_ACCELERATIONS:
    the augmented system's solution (a, (na,)) at the evaluation's state by refinement with
    the kept factors (`refined_accelerations`)."""
    table = address_of(user_data)
    if s == FACTOR_A:
        return factor_a(table)
    if s == REFINED_ACCELERATIONS:
        dims = _i(table, slot.DIMS)
        na = dims[ed.NFREE] + dims[ed.NRIGID]
        return refined_accelerations(table, any_nonzero(_f(table, slot.XDOT)),
                                     carray(a, (na,), np.float64))
    n = _i(table, slot.DIMS)[ed.NDOF]
    return stage_force(table, carray(a, (2 * n,), np.float64), carray(b, (n,), np.float64),
                       carray(c, (n,), np.float64))
