"""The entries of the operations that are parts of others: DF, M_bar and the tangent's
product on large models.

Each is a C function of the engine's signature (`engine.ENGINE_ENTRY`), in the process's table
of operations (`engine.ENTRIES`), which the evaluation's own operations call through `run`.
Why not plain kernels: numba links a kernel's compiled code into every caller and optimises
and emits it again there, once per entry (and per kernel in between) that reaches it. DF
(with J's solves) was so compiled four times, M_bar (through the reduced form's evaluation
and the mass operation) four; as operations they are compiled twice (the kernel, its entry).
A call by address costs a few nanoseconds beside either.
"""

import numpy as np

from ..numerics.dense import add_row_groups
from ..numerics.jit import entry
from ..numerics.native import address_of, carray
from . import data as ed
from . import slots as slot
from .kinematics import compute_DF
from .motion import reduced_mass_of
from .operations import ENTRY
from .slots import float_array as _f
from .slots import int_array as _i


@entry(ENTRY)
def df_entry(op, user_data, t, a, b, c, s):
    """OP_DF: DF into slot DF (`kinematics.compute_DF`)."""
    compute_DF(address_of(user_data))
    return ed.OK


@entry(ENTRY)
def mass_of_entry(op, user_data, t, a, b, c, s):
    """OP_MASS_OF: s = 0 M_bar only, 1 with the element masses' forces, 2 also moving, -1
    the forces at rest without M_bar (the statics); on slots x, xdot, conv and force
    (`motion.reduced_mass_of`)."""
    table = address_of(user_data)
    reduced_mass_of(table, _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.CONV),
                    s > 1.0, _f(table, slot.FORCE), s != 0.0, s >= 0.0)
    return ed.OK


@entry(ENTRY)
def row_products_entry(op, user_data, t, a, b, c, s):
    """OP_ROW_PRODUCTS: C (a, (NDOF, NDOF)) += DF^T W over the first s rows of slot
    tangent_ranges (`dense.add_row_groups`, symmetric; `tangent.coordinate_rows` made W)."""
    table = address_of(user_data)
    dims = _i(table, slot.DIMS)
    ndof, nx = dims[ed.NDOF], dims[ed.NX]
    ranges = _i(table, slot.TANGENT_RANGES)
    add_row_groups(_f(table, slot.DF), _f(table, slot.TANGENT_ROWS), ndof, ranges[:nx], int(s),
                   ranges, True, carray(a, (ndof * ndof,), np.float64))
    return ed.OK
