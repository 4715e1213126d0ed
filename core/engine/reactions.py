"""The stress resultants of the full dynamic balance at the engine's last evaluation: the
constitutive ones and the reactions of the rigid deformations (OP_STRESS_RESULTANTS).

At the state of the last evaluation (slots x, sigma, force, conv and J's factors) and
accelerations qddot (NDOF,), m/s^2 or rad/s^2,

    sigma = sigma_c + J^-T (r - M xddot) on J's rows,   xddot = DF qddot (+ conv),

(N, N m; sigma_c = S e + D edot, slot sigma; r the forces of the evaluation, slot force,
which in the reduced form hold - M conv already), the same multipliers `tangent` weighs the
Hessians with, and `mechanics.Mechanics.stress_resultants` of the numpy reference: on a rigid
deformation the reaction its constraint carries, on a DOF deformation's row the residual
of the balance (zero at the accelerations of the equations of motion), on a kinematic
input's the effort.

A model packed with rigid clusters (`rigid`) gets the constitutive ones only, NaN on the
rigid and prescribed deformations: a cluster eliminates its rigid beams' rows (and its
slaves' Euler normalisations), whose reactions are then nowhere. The multipliers of the rows
it keeps, J_z^-T T^T r_full on the reduced coordinates z (what `tangent` weighs the Hessians
with), are the numpy reference's on every row but the masters' Euler normalisations. The
slaves' coordinates x_s = S(z) are homogeneous quadratic in the master's Euler parameters
lambda_m (`mechanics.rigid_bodies`): off |lambda_m| = 1 the cluster is scaled by
|lambda_m|^2 and its eliminated rows do not vanish, so J_int T = alpha J_norm T (J_norm the
master's normalisation row, a kept one; alpha one number per eliminated row), not 0. With
the full balance T^T r_full = (J_kept T)^T lam_kept + (J_int T)^T lam_int, the clustered
packing's J_z = J_kept T (square, regular) gives

    lam_kept' = lam_kept + J_z^-T (J_int T)^T lam_int,

which differs from lam_kept on the masters' normalisation rows alone: they absorb the
eliminated rows' reactions (measured 0.08 N on manipulator_control at qdot = 0, qddot = 0
in its initial configuration under 1 N on each input, where numpy has 1e-17; the other kept
rows agree to round-off, 4e-14 N there). A normalisation's multiplier has no physical
meaning, and T^T J^T lam and the tangent (its G0 with OP_RIGID_GEOMETRIC's term) are the
same on both packings (tests/test_cluster_multipliers.py). A caller that needs the rigid rows'
reactions packs its model without clusters (`EngineData(model, rigid=False)`).

DF comes from J's factors (OP_DF) unless the evaluation formed it (the reduced form, or an
OP_MASS since); no M_bar is formed, so a model without mass works. The scratch is the
tangent's (slots x_trial, dx, xddot): nothing an evaluation reads.
"""

import numpy as np

from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, carray
from . import data as ed
from . import slots as slot
from .operations import ENTRY, OP_DF, run
from .slots import float_array as _f
from .slots import int_array as _i
from .tangent import balance_force_at, balance_multipliers


@kernel(inline="always")  # into its operation's entry, its one caller
def stress_resultants(table, qddot, out):
    """sigma (NE,) of every deformation into out at the last evaluation's state and the
    accelerations qddot (module docstring); a status (NONFINITE_RESULT: a multiplier is not
    finite)."""
    dims = _i(table, slot.DIMS)
    sigma = _f(table, slot.SIGMA)
    for d in range(out.size):  # the rigid and prescribed deformations' come below
        out[d] = np.nan
    for d in _i(table, slot.STRESSED):
        out[d] = sigma[d]
    if dims[ed.NSLAVES] > 0:  # with rigid clusters: the constitutive ones only (docstring)
        return ed.OK
    if dims[ed.MASS_CURRENT] != 1:  # DF is there when M_bar is
        run(table, OP_DF, 0, 0, 0.0)
    full = _f(table, slot.EDOT)  # reused: the full stress resultants
    balance_multipliers(table, balance_force_at(table, qddot), _f(table, slot.DX), full)
    rows = _i(table, slot.ROWS)
    for j in range(rows.size):  # the rigid rows, then the DOF deformations'
        d = rows[j]
        out[d] = full[d]
        if not np.isfinite(out[d]):  # J singular at the state
            return ed.NONFINITE_RESULT
    return ed.OK


@entry(ENTRY)
def stress_resultants_entry(op, user_data, t, a, b, c, s):
    """OP_STRESS_RESULTANTS: qddot (a, (NDOF,)), out (b, (NE,))."""
    table = address_of(user_data)
    dims = _i(table, slot.DIMS)
    return stress_resultants(table, carray(a, (dims[ed.NDOF],), np.float64),
                             carray(b, (dims[ed.NE],), np.float64))
