"""The kinematics' one-pass evaluation where the last prediction held (dims prediction_held,
core/engine/kinematics.py).

A warm kinematics predicts x to first order from the last solution and checks the prediction
on e alone; where the last prediction held it evaluates e with the solution's De at it in
one pass instead. The flag: 0 after a cold start (packing, a restart of the kinematics, the
positions-only solve), 1 after a warm solve whose prediction held (the same state again),
0 after one that needed chord or Newton steps (a jump of 2e-3 on every DOF). The shortcut
changes no result: two packings of the same model take the same sequence of states, one
with the flag as the kinematics leaves it, one with it cleared before every call (the two
passes always), and every rhs, x, e and De agree bit for bit.

Models: manipulator_control (the augmented form, rigid clusters, BEAMs whose solution order
leaves D2e out: the kinematics' AT_SOLUTION) and stage_planar_1dof (the reduced form's
prediction from DF).
"""

import numpy as np
import pytest
from test_engine import random_states

from flexure.core import Mechanics, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData

SCENES = ("manipulator_control", "stage_planar_1dof")
JUMP = 2e-3  # m or rad on every DOF: beyond the first-order prediction's tolerance


def states(model, data, seed=7):
    """y0 (a random moving state about the scene's), y1 a step of 1e-8 on every DOF from it,
    and y_far a jump of JUMP: (q - q_ref, qdot) each; the inputs u."""
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    (q, qdot, u), = random_states(model, q0, seed=seed, count=1)
    y0 = np.concatenate([q - data.float_array("q_ref"), qdot])
    n = q.size
    step = np.concatenate([np.ones(n), np.zeros(n)])
    return y0, y0 + 1e-8 * step, y0 + JUMP * step, u


def rhs(data, y, u):
    """ydot at y with the inputs u (asserting OK) and the flag after it."""
    data.float_array("inputs")[:] = u
    ydot = np.full_like(y, np.nan)
    assert engine.call(data, engine.OP_RHS, y, ydot) == ed.OK
    return ydot, data.int_array("dims")[ed.PREDICTION_HELD]


def held(data):
    return data.int_array("dims")[ed.PREDICTION_HELD]


@pytest.mark.parametrize("name", SCENES)
def test_the_flag_is_set_where_the_prediction_held(name):
    model = load_scene(name)
    data = EngineData(model)
    y0, _, y_far, u = states(model, data)
    assert held(data) == 0  # packed: no prediction yet
    assert rhs(data, y0, u)[1] == 0  # cold: from x_start
    assert rhs(data, y0, u)[1] == 1  # the same state: the prediction is the solution
    assert rhs(data, y_far, u)[1] == 0  # a jump: chord or Newton steps
    assert rhs(data, y_far, u)[1] == 1
    data.int_array("dims")[ed.WARM] = 0  # a restart of the kinematics
    assert rhs(data, y_far, u)[1] == 0
    assert rhs(data, y_far, u)[1] == 1
    n = y0.size // 2
    q = y_far[:n] + data.float_array("q_ref")
    assert engine.call(data, engine.OP_POSITIONS, q, np.empty(0)) == ed.OK
    assert held(data) == 0  # the positions alone leave no warm start


@pytest.mark.parametrize("name", SCENES)
def test_the_one_pass_evaluation_changes_no_bit(name):
    model = load_scene(name)
    shortcut, plain = EngineData(model), EngineData(model)
    y0, y1, y_far, u = states(model, shortcut)
    sequence = (y0, y0, y0, y_far, y_far, y1, y1, y1, y0, y0)
    cases = set()  # (one pass taken, the prediction held)
    for y in sequence:
        plain.int_array("dims")[ed.PREDICTION_HELD] = 0  # the two passes, always
        expected, _ = rhs(plain, y, u)
        taken = held(shortcut)
        found, flag = rhs(shortcut, y, u)
        cases.add((int(taken), int(flag)))
        assert np.all(np.isfinite(found))
        assert np.array_equal(found, expected)
        for name_ in ("x", "e", "De"):
            assert np.array_equal(shortcut.float_array(name_), plain.float_array(name_)), name_
    # the one pass taken where the prediction then held, and where it then failed (y_far
    # after y0: its De at the prediction overwritten by the chord iterate's)
    assert {(1, 1), (1, 0)} <= cases
