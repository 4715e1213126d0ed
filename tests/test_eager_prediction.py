"""The kinematics' prediction evaluated with De at once (dims field predicted,
`kinematics.solve_kinematics`) against the e-only check it replaces.

After a kinematic solution that was its first-order prediction itself, the next prediction is
evaluated for e and De in one pass; where it is accepted, that pass is the solution's, where
it is not, the chord steps follow as before. On manipulator_control packed as the
simulations pack it, along states a Newton correction apart (the prediction accepted) and a
step apart (refused), the rhs with the field set equals the rhs with it cleared before every
call (the e-only path) within 1e-13 of max |qddot|, and so do the coordinates within 1e-15
of max |x| (measured: the same bits; the two paths evaluate e at the same x, the accepted
one's De and the residual's e in the one pass).
"""

import numpy as np
from test_refined_accelerations import packed

from flexure.core.engine import data as ed
from flexure.core.engine import engine


def along(data, ys, eager):
    """[(qddot, x)] of OP_RHS at each state of ys in turn, with the field predicted as left by
    the last call (eager) or cleared before each; and the fields it was called with."""
    out, fields = [], []
    dims = data.int_array("dims")
    for y in ys:
        if not eager:
            dims[ed.PREDICTED] = 0
        fields.append(int(dims[ed.PREDICTED]))
        ydot = np.full_like(y, np.nan)
        assert engine.call(data, engine.OP_RHS, y, ydot) == ed.OK
        out.append((ydot[y.size // 2:].copy(), data.float_array("x").copy()))
    return out, fields


def test_the_eager_prediction_gives_the_e_only_paths_solution():
    data, y0, y1, u0 = packed("manipulator_control")
    step = y1 - y0
    # a correction apart (1e-6 of the step: the prediction holds), then a step apart, then
    # corrections again
    ys = [y0, y0 + 1e-6 * step, y0 + 2e-6 * step, y1, y1 + 1e-6 * step, y1 + 1e-6 * step]
    data.float_array("inputs")[:] = u0
    eager, fields = along(data, ys, True)
    data_plain, *_ = packed("manipulator_control")
    data_plain.float_array("inputs")[:] = u0
    plain, _ = along(data_plain, ys, False)
    assert fields[2] == 1 and fields[5] == 1  # the eager pass was taken
    assert fields[4] == 0  # after the step apart's chord steps: e alone
    for (qddot, x), (qddot_ref, x_ref) in zip(eager, plain, strict=True):
        assert np.max(np.abs(qddot - qddot_ref)) <= 1e-13 * np.max(np.abs(qddot_ref))
        assert np.max(np.abs(x - x_ref)) <= 1e-15 * np.max(np.abs(x_ref))
