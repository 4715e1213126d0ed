"""The convective accelerations conv = (D2F qdot) qdot (m/s^2, and the rotation parameters'
second derivatives; slot conv) of an evaluation, formed where they are read.

conv = -J^-1 [h on the constraint rows] (h_i = xdot^T D2e_i xdot; with rigid clusters h of
the reduced coordinates z with the slaves' own, and conv filled on the slaves' rows as
T conv_z + c). The reduced form reads conv in its own evaluation (r -= M conv); the augmented
form does not: there only the tangent and the stress resultants (`tangent.
coordinate_accelerations`) and the Python readers of slot conv read them, so its evaluation
keeps J's right-hand side in slot conv (`keep_convective`: dims[CONV_PENDING] = 1) and the J
solve and T z wait for `convective_accelerations` (one J solve and one expansion fewer an
rhs). dims[CONV_WANTED] = 1 has every evaluation form them (for a reader outside the compiled
code, which reads slot conv directly).
"""

from ..numerics.jit import kernel
from . import data as ed
from . import slots as slot
from .factors import j_solve
from .operations import OP_RIGID_EXPAND, run
from .slots import float_array as _f
from .slots import int_array as _i


@kernel(inline="always")  # into `motion.evaluate`, its one caller
def keep_convective(table, moving, rigid, pending):
    """Slot conv at the evaluation whose element rates (h in slot g; with `rigid` the slaves'
    h in slot rigid_h) were just formed, `moving`: zero when not; else J's right-hand side
    [h (+ the slaves' h)] on its first n_free entries (`pending`, dims[CONV_PENDING] = 1)
    or solved at once (`convective_accelerations`)."""
    dims = _i(table, slot.DIMS)
    conv = _f(table, slot.CONV)
    conv[:] = 0.0
    dims[ed.CONV_PENDING] = 0
    if not moving:
        return
    nf = dims[ed.NFREE]
    quad = _f(table, slot.G)
    if rigid:
        rigid_h = _f(table, slot.RIGID_H)
        for a in range(nf):
            conv[a] = quad[a] + rigid_h[a]
    else:
        for a in range(nf):
            conv[a] = quad[a]
    dims[ed.CONV_PENDING] = 1
    if not pending or dims[ed.CONV_WANTED] == 1:
        convective_accelerations(table)


@kernel
def convective_accelerations(table):
    """conv (slot conv, NX) of the last evaluation, solved with J's factors of its state from
    the right-hand side `keep_convective` left there, if still pending (slot dx is scratch)."""
    dims = _i(table, slot.DIMS)
    if dims[ed.CONV_PENDING] == 0:
        return
    nf = dims[ed.NFREE]
    conv, dx, free = _f(table, slot.CONV), _f(table, slot.DX), _i(table, slot.FREE)
    for a in range(nf):
        dx[a] = conv[a]
    conv[:] = 0.0
    j_solve(table, dx, False)
    for a in range(nf):
        conv[free[a]] = -dx[a]
    if dims[ed.NSLAVES] > 0:
        run(table, OP_RIGID_EXPAND, conv.ctypes.data, 0, 1.0)
    dims[ed.CONV_PENDING] = 0
