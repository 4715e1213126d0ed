"""The packed model's slots by name, for compiled code outside the engine.

The integrators' compiled callbacks (`simulation.sundials`, `simulation.esdirk`) and the
sampled loop (`simulation.sampled_loop`) hold a packed model by its table's address. They
take the slots they read and write through these kernels, one per slot, named as the slot
(`layout.SLOTS`), never through a slot's index (`slots`): the layout may change under them.
Each is the engine's own accessor with the index constant filled in (numba freezes it into
the caller), so a call costs what `slots.float_array` costs. The fields of the records
(`dims`, `counters`) are named by `data`'s constants (`data.NDOF`, `data.RHS_COUNT`).
"""

from ..numerics.dense import copy
from ..numerics.jit import kernel
from . import data as ed
from . import slots as slot
from .slots import float_array, int_array


@kernel(inline="always")
def dims(table):
    """Slot dims (int64, `layout.DIMS_FIELDS`) of the packed model at the address table."""
    return int_array(table, slot.DIMS)


@kernel(inline="always")
def counters(table):
    """Slot counters (int64, `layout.COUNTER_FIELDS`)."""
    return int_array(table, slot.COUNTERS)


@kernel(inline="always")
def inputs(table):
    """Slot inputs (NIN,): the held inputs (N, N m, V)."""
    return float_array(table, slot.INPUTS)


@kernel(inline="always")
def coordinates(table):
    """Slot x (NX,): the coordinates of the last evaluation (m, and rotation parameters)."""
    return float_array(table, slot.X)


@kernel(inline="always")
def reference_dofs(table):
    """Slot q_ref (NDOF,): the DOFs the integrator's state is relative to (m, rad)."""
    return float_array(table, slot.Q_REF)


@kernel(inline="always")
def jacobian_cache(table):
    """Slot jacobian_cache (N N, N the state size): the integrator's kept Jacobian."""
    return float_array(table, slot.JAC_CACHE)


@kernel(inline="always")
def restart_kinematics(table, x):
    """The next kinematics starts from the coordinates x (NX,) instead of the last
    solution and its factors (slot x_start = x, dims.warm = 0)."""
    copy(float_array(table, slot.X_START), x)
    int_array(table, slot.DIMS)[ed.WARM] = 0
