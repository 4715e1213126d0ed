"""The ports' operations: the load stiffness of moment inputs, OP_INPUT_STIFFNESS, and the
ports' rows on the DOFs, OP_PORT_ROWS.

A moment input u about a global axis k acts on a node's Euler parameters lambda as the force
2 u E_k(lambda)^T, which depends on the coordinates: the tangent subtracts its stiffness,
DF^T (2 u P_k) DF (`ports.subtract_input_stiffness`). Only a model with a moment input
(an input port on a rotation: spatial nodes) ever runs it, so it is an operation reached
through the table of operations (`run`) and compiled the first time such a model connects
(`engine.connect`); linked into the tangent's entry it was compiled for every engine, a
planar model's too. A call by address costs a few nanoseconds per tangent.

OP_PORT_ROWS gives the linearisation (`analysis.linear_engine`) the state space's input
columns and output rows at the packed model's last evaluation (slots x and DF): an input's
b_j^T DF (NDOF,), the generalised force on the DOFs of a unit input (N per N, N m per N m) and
the velocity of its port per DOF velocity, which a voice coil's back-EMF row is too; and an
output's d y / d q, the rotation vector's gradient for an angle (`ports.angle_row`) and
2 E_k DF_l for an angular rate (`ports.port_row`). The outputs are not packed (no other
operation reads them): the caller gives their packed rows (`ports.port_specs`) and orders.
Exact as the numpy ports' `input_columns` and `output_rows` up to round-off.
"""

import numpy as np

from ..numerics.jit import entry
from ..numerics.native import address_of, carray, float_address, int_address
from . import data as ed
from . import slots as slot
from .actuators import evaluated_port_values
from .operations import ENTRY, OP_PORT_ROWS
from .ports import PORT_WIDTH, angle_row, port_row, port_specs, subtract_input_stiffness
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


@entry(ENTRY)
def port_rows_entry(op, user_data, t, a, b, c, s):
    """OP_PORT_ROWS: b (nin + s, NDOF) float64 = the inputs' rows b_j^T DF, then the rows
    d y / d q of the s outputs whose packed rows are a (s PORT_WIDTH, int64) and orders c (s,
    int64: 0 a position, else a rate), at slots x and DF of the last evaluation."""
    table = address_of(user_data)
    ndof = _i(table, slot.DIMS)[ed.NDOF]
    inputs = _i(table, slot.INPUT_PORTS)
    nin, nout = inputs.size // PORT_WIDTH, int(s)
    outputs = carray(a, (nout * PORT_WIDTH,), np.int64)
    orders = carray(c, (nout,), np.int64)
    rows = carray(b, ((nin + nout) * ndof,), np.float64)
    x, DF = _f(table, slot.X), _f(table, slot.DF)
    for j in range(nin):
        port_row(inputs, j, x, DF, ndof, rows[j * ndof: (j + 1) * ndof])
    for j in range(nout):
        row = rows[(nin + j) * ndof: (nin + j + 1) * ndof]
        if orders[j] == 0:
            angle_row(outputs, j, x, DF, ndof, row)
        else:  # a rate of the port: its velocity's row, linear in the rates
            port_row(outputs, j, x, DF, ndof, row)
    return ed.OK


def port_rows(data, outputs, orders):
    """The inputs' rows (nin, NDOF) and the outputs' (len(outputs), NDOF) on the DOFs at the
    last evaluation of the packed model `data` (an `EngineData`), through OP_PORT_ROWS: b_j^T
    DF per input (N per unit input on each DOF, the port's velocity per DOF velocity), and
    d y / d q per output (`outputs` its ports, `orders` 0 for a position, else a rate).
    Raises RuntimeError when the operation fails (a status other than OK)."""
    from .engine import ENTRIES, connect  # the engine imports this module's entries

    ndof = int(data.int_array("dims")[ed.NDOF])
    nin = data.int_array("input_ports").size // PORT_WIDTH
    specs = np.ascontiguousarray(port_specs(outputs).ravel())
    kinds = np.ascontiguousarray(orders, dtype=np.int64)
    rows = np.zeros((nin + len(outputs), ndof))
    connect(data, OP_PORT_ROWS)
    status = ENTRIES[OP_PORT_ROWS].ctypes(
        OP_PORT_ROWS, data.address, 0.0, int_address(specs) if specs.size else None,
        float_address(rows), int_address(kinds) if kinds.size else None, float(len(outputs)))
    if status != ed.OK:
        raise RuntimeError(f"the engine's port rows failed (status {status})")
    return rows[:nin], rows[nin:]
