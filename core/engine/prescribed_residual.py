"""Prescribed motion in the compiled engine: the implicit form (IDA's) with kinematic inputs.

The twin of `prescribed` for the residual form res(t, y, yp) = 0 that IDA integrates, on the
same state y = [q - q_ref, qdot] (the prescribed entries inert: every evaluation reads the
path's u(t), u'(t) at the time it is given, `prescribed.prescribed_rhs`). With q*, qdot* the
state's DOFs with the inputs' entries replaced by u, u', and a* = yp[n:] with them replaced
by u'' (m, m/s, m/s^2; rad on an angle):

    res[i]      = yp[i] - y[n + i]                    every DOF i (the state's qdot: as CVODE's
                                                      ydot = [qdot, ...] keeps the prescribed
                                                      entries within tolerance of the path)
    res[n + f]  = (M_bar a* - Q)_f                    each free DOF f (N, N m)
    res[n + k]  = yp[n + k] - u''_k                   each input k (m/s^2, rad/s^2)

The free rows need no efforts: E F has no free rows. The evaluation's constrained
accelerations qddot (slot qddot, M_bar qddot = Q + E F with qddot_k = u'') give them as
(M_bar (a* - qddot))_f, the columns k dropping out (a*_k = qddot_k). At the solution
yp[n + f] = qddot_f and yp[n + k] = u'': the ODE that CVODE integrates with the first-order
form, and the efforts are those of that form (`prescribed`).

The Jacobian d res / d y + cj d res / d yp (column-major, as SUNDIALS' dense matrix):

    [[cj I, -I], [K_p, C_p + cj M_p]],   K_p, C_p, M_p: K, C, M_bar with the inputs' rows and
                                         columns zero, 1 on the inputs' diagonal of M_p

with K, C the tangent (`tangent`) at q*, qdot* and the accelerations a*. As the first-order
form's (`prescribed` docstring), it leaves out the geometric stiffness of an effort on a
deformation input: IDA's Newton iterations converge on the exact residual regardless.
"""

import numpy as np

from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, carray
from . import data as ed
from . import slots as slot
from .operations import ENTRY, OP_PRESCRIBED_RHS, OP_TANGENT, run
from .prescribed import is_prescribed
from .slots import float_array as _f
from .slots import int_array as _i

_F8 = np.float64


@kernel(inline="always")
def prescribed_residual(table, t, y, yp, res):
    """IDA's residual (module docstring) at time t (s) for y, yp (2 NDOF,) into res; the
    efforts into slot efforts as the first-order form's evaluation. A status code."""
    status = run(table, OP_PRESCRIBED_RHS, y.ctypes.data, 0, t)  # the evaluation only
    if status != ed.OK:
        return status
    n = _i(table, slot.DIMS)[ed.NDOF]
    prescribed = _i(table, slot.PRESCRIBED)
    mass, qddot = _f(table, slot.MASS), _f(table, slot.QDDOT)
    for i in range(n):
        res[i] = yp[i] - y[n + i]
    for i in range(n):
        if is_prescribed(prescribed, i):
            res[n + i] = yp[n + i] - qddot[i]  # qddot_k is the path's u'' exactly
            continue
        s = 0.0
        for j in range(n):
            if not is_prescribed(prescribed, j):  # a*_k - qddot_k = 0 on an input's column
                s += mass[i * n + j] * (yp[n + j] - qddot[j])
        res[n + i] = s
    return ed.OK


@kernel(inline="always")
def prescribed_residual_jacobian(table, t, y, yp, cj, J):
    """IDA's d res / d y + cj d res / d yp (2 NDOF, 2 NDOF) column-major into J at time t
    (s) (module docstring); a status code."""
    status = run(table, OP_PRESCRIBED_RHS, y.ctypes.data, 0, t)  # the evaluation only
    if status != ed.OK:
        return status
    n = _i(table, slot.DIMS)[ed.NDOF]
    N = 2 * n
    prescribed = _i(table, slot.PRESCRIBED)
    # a* into slot qddot, where the evaluation left the inputs' u'': the accelerations the
    # tangent's dynamic balance is taken at (the residual's, not the evaluation's qddot)
    qddot = _f(table, slot.QDDOT)
    for j in range(n):
        if not is_prescribed(prescribed, j):
            qddot[j] = yp[n + j]
    status = run(table, OP_TANGENT, qddot.ctypes.data, 0, 0.0)
    if status != ed.OK:
        return status
    K, C, mass = _f(table, slot.STIFFNESS), _f(table, slot.DAMPING), _f(table, slot.MASS)
    J[:] = 0.0
    for i in range(n):
        J[i * N + i] = cj
        J[(n + i) * N + i] = -1.0
    for i in range(n):
        if is_prescribed(prescribed, i):
            J[(n + i) * N + n + i] = cj
            continue
        for j in range(n):
            if not is_prescribed(prescribed, j):
                J[j * N + n + i] = K[i * n + j]
                J[(n + j) * N + n + i] = C[i * n + j] + cj * mass[i * n + j]
    return ed.OK


@entry(ENTRY)
def prescribed_residual_entry(op, user_data, t, a, b, c, s):
    """OP_PRESCRIBED_RESIDUAL: y (a), yp (b), res (c); t the time (s)."""
    table = address_of(user_data)
    n = 2 * _i(table, slot.DIMS)[ed.NDOF]
    return prescribed_residual(table, t, carray(a, (n,), _F8), carray(b, (n,), _F8),
                               carray(c, (n,), _F8))


@entry(ENTRY)
def prescribed_residual_jacobian_entry(op, user_data, t, a, b, c, s):
    """OP_PRESCRIBED_RESIDUAL_JACOBIAN: y (a), yp (b), J (c); t the time (s); s = cj."""
    table = address_of(user_data)
    n = 2 * _i(table, slot.DIMS)[ed.NDOF]
    return prescribed_residual_jacobian(table, t, carray(a, (n,), _F8), carray(b, (n,), _F8),
                                        s, carray(c, (n * n,), _F8))


__all__ = ["prescribed_residual_entry", "prescribed_residual_jacobian_entry"]
