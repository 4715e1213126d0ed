"""The entries of the kinematic operations: the configuration x = F(q), DF, the positions
alone, and the deformations of given coordinates.

Each is a C function of the engine's signature (`operations.ENTRY`), in the process's table
of operations (`engine.ENTRIES`); `kinematics` holds what they compute.
"""

import numpy as np

from ..numerics.jit import entry
from ..numerics.native import address_of, carray
from . import data as ed
from . import slots as slot
from .kinematics import deformations, solve_kinematics, solve_positions
from .operations import ENTRY, OP_CONFIGURATION, OP_DF, run
from .slots import int_array as _i

_F8 = np.float64


@entry(ENTRY)
def kinematics_entry(op, user_data, t, a, b, c, s):
    """OP_KINEMATICS: q (a); x = F(q) and DF."""
    table = address_of(user_data)
    status = run(table, OP_CONFIGURATION, address_of(a), 0, 0.0)
    if status == ed.OK:
        status = run(table, OP_DF, 0, 0, 0.0)
    return status


@entry(ENTRY)
def deformations_entry(op, user_data, t, a, b, c, s):
    """OP_DEFORMATIONS: x (a); s = the order of the derivatives."""
    table = address_of(user_data)
    deformations(table, carray(a, (_i(table, slot.DIMS)[ed.NX],), _F8), int(s), False)
    return ed.OK


@entry(ENTRY)
def positions_entry(op, user_data, t, a, b, c, s):
    """OP_POSITIONS: q (a)."""
    table = address_of(user_data)
    return solve_positions(table, carray(a, (_i(table, slot.DIMS)[ed.NDOF],), _F8))


@entry(ENTRY)
def configuration_entry(op, user_data, t, a, b, c, s):
    """OP_CONFIGURATION: q (a)."""
    table = address_of(user_data)
    return solve_kinematics(table, carray(a, (_i(table, slot.DIMS)[ed.NDOF],), _F8))
