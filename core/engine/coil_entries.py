"""The coil currents' part of the first-order and implicit forms as one operation, OP_COILS,
compiled only for a model with voltage-driven actuators.

The state of a model whose actuators are driven by a voltage carries their coil currents i
(A) after q - q_ref and qdot (`actuators`): the forms set them from y, append di/dt to ydot,
their rows to IDA's residual and their blocks to both Jacobians. Called directly from the
forms, those kernels were compiled into the RHS's, the Jacobian's and IDA's entries of every
engine, a model without coils (the demo stage's) included; as one operation reached through
the table of entries (`run`), they are compiled the first time a model with coils is
connected (`engine.connect`). A call by address costs a few nanoseconds per evaluation.

OP_COILS takes the part in s (the COILS_... codes below), the state-sized array in a (y,
ydot or yp; N = 2 NDOF + NEL), the residual in b (COILS_RESIDUAL), the Jacobian (N, N, flat)
in a for the blocks, and IDA's cj (1/s) in t (COILS_IMPLICIT_BLOCKS).
"""

import numpy as np

from ..numerics.jit import entry
from ..numerics.native import address_of, carray
from . import data as ed
from . import slots as slot
from .actuators import (
    current_rates,
    current_residual,
    first_order_blocks,
    implicit_blocks,
    set_currents,
)
from .operations import ENTRY
from .slots import int_array as _i

# the parts (s): the currents from y; di/dt into ydot; the rows of IDA's residual; the
# first-order Jacobian's blocks, row-major or column-major; the implicit Jacobian's. Floats:
# the operations' number argument is a float64
(COILS_SET, COILS_RATES, COILS_RESIDUAL, COILS_ROWS_BLOCKS, COILS_COLUMNS_BLOCKS,
 COILS_IMPLICIT_BLOCKS) = (float(part) for part in range(6))
_F8 = np.float64


@entry(ENTRY)
def coils_entry(op, user_data, t, a, b, c, s):
    """OP_COILS: the part s (COILS_...) on a (and b; t = cj for COILS_IMPLICIT_BLOCKS)."""
    table = address_of(user_data)
    dims = _i(table, slot.DIMS)
    n = dims[ed.NDOF]
    N = 2 * n + dims[ed.NEL]
    part = s
    if part == COILS_SET:
        set_currents(table, carray(a, (N,), _F8), n)
    elif part == COILS_RATES:
        current_rates(table, carray(a, (N,), _F8), n)
    elif part == COILS_RESIDUAL:
        current_residual(table, carray(a, (N,), _F8), carray(b, (N,), _F8), n)
    elif part == COILS_IMPLICIT_BLOCKS:
        implicit_blocks(table, carray(a, (N * N,), _F8), N, n, t)
    else:
        first_order_blocks(table, carray(a, (N * N,), _F8), N, n,
                           part == COILS_COLUMNS_BLOCKS)
    return ed.OK
