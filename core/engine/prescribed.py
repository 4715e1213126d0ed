"""Prescribed motion in the compiled engine: the first-order form with kinematic inputs.

A kinematic input prescribes one entry k of q (a coordinate or a deformation that is a DOF,
`Model.prescribed_dofs`) as a function of time u(t), with its rate u' and acceleration u''
(m, m/s, m/s^2; rad on an angle). The kinematics need no change (an input's row is a DOF
row); the equations of motion M_bar qddot = Q (`motion`) take the inputs' efforts F (N, N m),
the generalised forces that realise them, on their rows:

    M_bar qddot = Q + E F,   E^T qddot = u''        (E: the inputs' unit columns of q)

With qddot_0 = M_bar^-1 Q the accelerations of the same state without the inputs (the
engine's evaluation as it is), W = M_bar^-1 E and the Schur complement S = E^T W (nki, nki;
positive definite: M_bar is),

    F = S^-1 (u'' - E^T qddot_0),   qddot = qddot_0 + W F,

which is the reduced form M_ff qddot_f = Q_f - M_fk u'' on the free rows, qddot_k = u'' on
the prescribed ones, and F = M_k. qddot - Q_k (the reference in numpy:
`analysis.motion_response`). It needs M_bar's LU (`motion.reduced_mass`) and nki solves with
it per evaluation.

The path of each input is one polynomial piece in slot motion_path: [t_start, t_end, c_0 ..
c_5], u(t) = sum_j c_j s^j with s = t - t_start clipped to [0, t_end - t_start], held (rate
and acceleration zero) outside [t_start, t_end) (a piece that starts moving, a host's step of
`simulation.stepwise_motion`, has its rate and acceleration at t_start itself, the time a
step's first evaluation is at); `quintic_path` writes the scene's rest-to-rest move
(`analysis.motion_paths.increment_path`, the reference for `path_point`) into it.

The integrator's state stays y = [q - q_ref, qdot] on all of q: a prescribed entry of it is
inert (the evaluation reads u(t) and u'(t) at the time it is given, never the state's), its
derivative [qdot_k, u''] keeps it within the integrator's tolerance of the path and the
Jacobian second-order ([[0, I], [A, B]]), with A and B zero in the inputs' rows and columns:

    [A B] = -(I - W S^-1 E^T) M_bar^-1 [K C]

with K, C the tangent (`tangent`) at the constrained qddot. It leaves out the geometric
stiffness of an effort on a deformation input (its row's second derivatives): the Newton
iterations converge on the exact right-hand side regardless (exact for a coordinate input).
"""

import numpy as np

from ..numerics.dense import lu_factor, lu_solve, put
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, carray
from . import data as ed
from . import slots as slot
from .layout import PATH_WIDTH  # a path's record: t_start, t_end (s), c_0 .. c_5
from .operations import ENTRY, OP_ACCELERATIONS, OP_MASS, OP_PRESCRIBED_RHS, OP_TANGENT, run
from .slots import float_array as _f
from .slots import int_array as _i

_F8 = np.float64


def quintic_path(starts, values, duration, t0=0.0):
    """The records of slot motion_path (PATH_WIDTH nki,) for the rest-to-rest quintic from
    each input's start to its value over `duration` s from t0 s (module docstring):
    c_0 = u0, c_3 = 10 d / T^3, c_4 = -15 d / T^4, c_5 = 6 d / T^5 with d = u1 - u0."""
    starts, values = np.asarray(starts, float), np.asarray(values, float)
    path = np.zeros((starts.size, PATH_WIDTH))
    increment, T = values - starts, float(duration)
    path[:, 0], path[:, 1], path[:, 2] = t0, t0 + T, starts
    path[:, 5], path[:, 6], path[:, 7] = (10.0 * increment / T**3, -15.0 * increment / T**4,
                                          6.0 * increment / T**5)
    return path.reshape(-1)


@kernel
def path_point(path, i, t):
    """(u, u', u'') of input i at time t (s) from its record in `path` (module docstring)."""
    base = PATH_WIDTH * i
    t_start, t_end = path[base], path[base + 1]
    inside = t_start <= t < t_end
    s = min(max(t, t_start), t_end) - t_start
    value, rate, acceleration = 0.0, 0.0, 0.0
    for j in range(5, -1, -1):  # Horner, from the highest power
        c = path[base + 2 + j]
        acceleration = acceleration * s + 2.0 * rate
        rate = rate * s + value
        value = value * s + c
    if not inside:
        return value, 0.0, 0.0
    return value, rate, acceleration


@kernel(inline="always")
def prescribed_rhs(table, t, y, ydot):
    """ydot = [qdot, qddot] for the state y = [q - q_ref, qdot] at time t (s) with the inputs
    on their path, the efforts into slot efforts, qddot into slot qddot (module docstring);
    ydot may be empty: the evaluation only. A status code."""
    dims = _i(table, slot.DIMS)
    n, nk = dims[ed.NDOF], dims[ed.NKI]
    for j in range(2 * n):
        if not np.isfinite(y[j]):
            return ed.NONFINITE_STATE
    local = _f(table, slot.LOCAL)
    q = local[local.size - n:]
    scratch = _f(table, slot.PRESCRIBED_SCRATCH)
    qdot, v = scratch[:n], scratch[n:]
    q_ref, path = _f(table, slot.Q_REF), _f(table, slot.MOTION_PATH)
    prescribed = _i(table, slot.PRESCRIBED)
    for j in range(n):
        q[j] = q_ref[j] + y[j]
        qdot[j] = y[n + j]
    for i in range(nk):
        k = prescribed[i]
        q[k], qdot[k], v[i] = path_point(path, i, t)
    status = run(table, OP_ACCELERATIONS, q.ctypes.data, qdot.ctypes.data, 0.0)
    if status == ed.OK:
        status = run(table, OP_MASS, 0, 0, 0.0)  # M_bar's LU: motion.reduced_mass
    if status != ed.OK:
        return status
    mass_lu, pivots = _f(table, slot.MASS_LU), _i(table, slot.MASS_PIVOTS)
    W, S = _f(table, slot.PRESCRIBED_COLUMNS), _f(table, slot.PRESCRIBED_SCHUR)
    column = _f(table, slot.REDUCED_FORCE)
    qddot = _f(table, slot.QDDOT)
    for i in range(nk):  # W = M_bar^-1 E, S = E^T W
        column[:] = 0.0
        column[prescribed[i]] = 1.0
        lu_solve(mass_lu, n, pivots, column)
        for j in range(n):
            W[j * nk + i] = column[j]
    for i in range(nk):
        for j in range(nk):
            S[i * nk + j] = W[prescribed[i] * nk + j]
        v[i] -= qddot[prescribed[i]]  # u'' - E^T qddot_0
    if not lu_factor(S, nk, _i(table, slot.PRESCRIBED_PIVOTS)) > 0.0:
        return ed.SINGULAR_MASS
    lu_solve(S, nk, _i(table, slot.PRESCRIBED_PIVOTS), v)
    efforts = _f(table, slot.EFFORTS)
    for i in range(nk):
        efforts[i] = v[i]
    for j in range(n):
        s = qddot[j]
        for i in range(nk):
            s += W[j * nk + i] * v[i]
        qddot[j] = s
    for i in range(nk):  # exactly the path's, not to round-off
        qddot[prescribed[i]] = path_point(path, i, t)[2]
    for j in range(n):
        if not np.isfinite(qddot[j]):
            return ed.NONFINITE_RESULT
    if ydot.size:
        for j in range(n):
            ydot[j] = y[n + j]
            ydot[n + j] = qddot[j]
    return ed.OK


@kernel(inline="always")
def is_prescribed(prescribed, j):
    """Whether DOF j is a kinematic input's (`prescribed` the slot of their DOFs)."""
    for k in prescribed:
        if k == j:
            return True
    return False


@kernel(inline="always")
def prescribed_jacobian(table, t, y, J, column_major):
    """d ydot / d y (2n, 2n) into J (flat; column-major for SUNDIALS' dense matrix) at time t
    (s): [[0, I], [A, B]] with [A B] = -(I - W S^-1 E^T) M_bar^-1 [K C] on the free columns,
    zero in the inputs' rows and columns (module docstring); a status code."""
    status = run(table, OP_PRESCRIBED_RHS, y.ctypes.data, 0, t)  # the evaluation only
    if status != ed.OK:
        return status
    status = run(table, OP_TANGENT, _f(table, slot.QDDOT).ctypes.data, 0, 0.0)
    if status != ed.OK:
        return status
    dims = _i(table, slot.DIMS)
    n, nk = dims[ed.NDOF], dims[ed.NKI]
    N = 2 * n
    K, C = _f(table, slot.STIFFNESS), _f(table, slot.DAMPING)
    mass_lu, pivots = _f(table, slot.MASS_LU), _i(table, slot.MASS_PIVOTS)
    W, S = _f(table, slot.PRESCRIBED_COLUMNS), _f(table, slot.PRESCRIBED_SCHUR)
    schur_pivots, prescribed = _i(table, slot.PRESCRIBED_PIVOTS), _i(table, slot.PRESCRIBED)
    column = _f(table, slot.REDUCED_FORCE)
    v = _f(table, slot.PRESCRIBED_SCRATCH)[n:]
    J[:] = 0.0
    for j in range(n):
        put(J, N, j, n + j, 1.0, column_major)
    for c in range(N):  # column c of -(I - W S^-1 E^T) M_bar^-1 [K C]
        j = c % n
        if is_prescribed(prescribed, j):  # not in the right-hand side: the path gives them
            continue
        source = K if c < n else C
        for i in range(n):
            column[i] = source[i * n + j]
        lu_solve(mass_lu, n, pivots, column)
        for i in range(nk):
            v[i] = column[prescribed[i]]
        lu_solve(S, nk, schur_pivots, v)
        for r in range(n):
            s = column[r]
            for i in range(nk):
                s -= W[r * nk + i] * v[i]
            column[r] = s
        for i in range(nk):
            column[prescribed[i]] = 0.0
        for r in range(n):
            put(J, N, n + r, c, -column[r], column_major)
    return ed.OK


@entry(ENTRY)
def prescribed_rhs_entry(op, user_data, t, a, b, c, s):
    """OP_PRESCRIBED_RHS: y (a), ydot (b; null: the evaluation only); s = the time t (s)."""
    table = address_of(user_data)
    n = 2 * _i(table, slot.DIMS)[ed.NDOF]
    return prescribed_rhs(table, s, carray(a, (n,), _F8),
                          carray(b, (n if address_of(b) else 0,), _F8))


@entry(ENTRY)
def prescribed_jacobian_entry(op, user_data, t, a, b, c, s):
    """OP_PRESCRIBED_JACOBIAN: y (a), J (b); t the time (s); s = 1 for column-major."""
    table = address_of(user_data)
    n = 2 * _i(table, slot.DIMS)[ed.NDOF]
    return prescribed_jacobian(table, t, carray(a, (n,), _F8), carray(b, (n * n,), _F8),
                               s != 0.0)


__all__ = ["PATH_WIDTH", "path_point", "prescribed_jacobian_entry", "prescribed_rhs_entry",
           "quintic_path"]
