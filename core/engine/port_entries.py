"""The load stiffness of moment inputs as an operation of its own, OP_INPUT_STIFFNESS.

A moment input u about a global axis k acts on a node's Euler parameters lambda as the force
2 u E_k(lambda)^T, which depends on the coordinates: the tangent subtracts its stiffness,
DF^T (2 u P_k) DF (`ports.subtract_input_stiffness`). Only a model with a moment input
(an input port on a rotation: spatial nodes) ever runs it, so it is an operation reached
through the table of operations (`run`) and compiled the first time such a model connects
(`engine.connect`); linked into the tangent's entry it was compiled for every engine, a
planar model's too. A call by address costs a few nanoseconds per tangent.
"""

from ..numerics.jit import entry
from ..numerics.native import address_of
from . import data as ed
from . import slots as slot
from .actuators import evaluated_port_values
from .operations import ENTRY
from .ports import subtract_input_stiffness
from .slots import float_array as _f
from .slots import int_array as _i


@entry(ENTRY)
def input_stiffness_entry(op, user_data, t, a, b, c, s):
    """OP_INPUT_STIFFNESS: slot stiffness (NDOF, NDOF; N/m, N m/rad) -= the load stiffness
    of the moments of the last evaluation (an input's, or an actuator's), with slot DF of
    the tangent's state."""
    table = address_of(user_data)
    subtract_input_stiffness(_i(table, slot.INPUT_PORTS), evaluated_port_values(table),
                             _f(table, slot.DF), _i(table, slot.DIMS)[ed.NDOF],
                             _f(table, slot.STIFFNESS))
    return ed.OK
