"""A model packed for compiled code: two tuples of flat arrays, and their address table.

The compiled evaluation engine (`flexure.core.engine.engine`) and the SUNDIALS callbacks
(`flexure.core.simulation.sundials`) take no Python objects: everything they read or write is
one of the flat arrays ("slots") built here, float64 arrays in `floats` and int64 arrays in
`ints`, in the order of the layout table (`layout.SLOTS`: per slot its name, dtype, size,
role, unit and meaning). The same arrays reach a C callback through one address: `table`
lists (address, length) of every array, and `slots.int_array` / `float_array` find an array
from it. Python reads a slot by its name (`EngineData.float_array("x")`), compiled code by
its index constant (`slots.X`), both from the same table.

`packing` fills the slots, one function per concern (kinematics, element groups, stiffness,
inertia, ports, actuators, motion, factors, rigid clusters), each returning its slots by
name; `packing_check.check` holds them against the table before they are put in its order. The
fields of the records `dims`, a row of `groups`, `counters` and `settings` are named here
(NX, G_COUNT, RHS_COUNT, ...: generated from `layout`, compile-time ints for numba).

Units: SI throughout (m, rad, kg, N, s), as the model's.
"""

from contextlib import contextmanager

import numpy as np

from ..live_models import PerLiveModel
from . import layout, newton_packing, packing, packing_check, sparse_packing
from .packing import (
    A_AT_STAGE,
    A_GAIN,
    A_KM,
    A_L,
    A_R,
    A_SATURATION,
    A_WIDTH,
    BANDED_FACTORS,
    CURRENT_DRIVE,
    FORCE_INPUT,
    NO_FACTORS,
    SPARSE_FACTORS,
    VOLTAGE_DRIVE,
)

INT_SLOTS, FLOAT_SLOTS = layout.INT_SLOTS, layout.FLOAT_SLOTS
_INT_INDEX = {name: i for i, name in enumerate(INT_SLOTS)}
_FLOAT_INDEX = {name: i for i, name in enumerate(FLOAT_SLOTS)}
# the fields of dims (NX, NE, ...), of a row of groups (G_COUNT, ...), counters (RHS_COUNT,
# ...) and settings (SINGULAR_RATIO), and each record's width (DIMS_SIZE, G_WIDTH,
# COUNTERS_SIZE, SETTINGS_SIZE): module-level ints generated from the layout's tables
_FIELDS = layout.field_indices()
globals().update(_FIELDS)
# model and packing options -> (the rigid packing, the costs, the packed arrays as packed:
# copies of those not all zero, and (shape, dtype) of the others), kept while the model lives.
# Why: every Simulator packs its model twice (its integrator's and its outputs'), 0.03 s each
# on manipulator_reduced, most of it the analyses of the rigid clusters and the Newton matrix;
# a packing is a function of the model, the options and the two choices it reads from modules
# (`packing_key`) alone (docs/benchmarks.md, session 41, loopcost)
_PACKED = PerLiveModel()
# status codes returned by the engine's functions (their words: status.status_message)
(OK, NOT_CONVERGED, SINGULAR_CONSTRAINTS, SINGULAR_MASS, NONFINITE_STATE, NONFINITE_RESULT,
 NOT_CONNECTED, NOT_AVAILABLE) = range(8)


class EngineData:
    """The flat arrays of one model for the compiled engine; one instance per integrator.

    Parameters
    ----------
    model : Model
        The model; its inputs are forces (N, N m) on their coordinates or moments (N m)
        about a global axis of a 3-D rotational node (`ports`), or the drive signals (V) of
        the voice-coil actuators that act on them (`actuators`).
    tolerance : float
        Kinematic tolerance relative to each row's and unknown's unit (`mechanics.scales`:
        m through the length scale, Euler parameters and rad through 1; default 1e-14: near
        round-off, so the kinematic error stays below the tightest integrator tolerance).
    singular_ratio : float
        Smallest ratio of the constraint Jacobian's LU pivots before a configuration counts
        as singular (a well-posed stage: 1e-2 to 1).
    augmented : bool, optional
        How `engine.evaluate` solves for the accelerations: the augmented system on the free
        coordinates (True) or the reduced M_bar qddot = DF^T r (False); default: whichever
        needs fewer multiplications for this model (`orders.evaluation_cost`).
    sparse : bool, optional
        How J and the augmented system are factored: the static-pivot sparse LU
        (`numerics.sparse_lu`, `sparse_packing`) for both (True), the banded LU for both
        (False); default: per matrix, whichever needs fewer (weighted) multiplications, the
        sparse LU analysed only for models whose banded LUs cost at least
        `sparse_packing.SPARSE_FROM`.
    rigid : bool
        Whether the rigid clusters' slaves leave the kinematics and the augmented system
        (`rigid`; default True); False solves for every free coordinate, as for a model
        without clusters.

    Raises
    ------
    ValueError
        The model is not exactly counted (free coordinates against constraints and DOFs).
    SimulationError
        The model has kinematic inputs (prescribed motion: `prescribed`) and actuators,
        whose coils the prescribed form does not take (docs/analyses.md).
    layout.LayoutError
        The packing does not match the layout table (a bug of the engine's packing).
    """

    def __init__(self, model, *, tolerance=1e-15, singular_ratio=1e-6, augmented=None,
                 sparse=None, rigid=True):
        self.model = model
        if model.kinematic_inputs and model.actuators:
            from ..errors import SimulationError

            names = ", ".join(port.name for port in model.kinematic_inputs)
            raise SimulationError(
                f"{model.source}: model {model.name!r} has kinematic inputs ({names}) and "
                "actuators: a time simulation with prescribed motion takes force and moment "
                "inputs only, not actuators' coils (docs/analyses.md)")
        _check_counted(model)
        options = (tolerance, singular_ratio, augmented, sparse, rigid)
        key = packing_key(options)
        known = _PACKED.get(model, key)
        if known is None:
            known = _PACKED.put(model, _packed(model, options), key)
        self.rigid, self.costs, pristine = known
        # every array a copy of its own: no two packings share one
        arrays = tuple(np.zeros(*value) if isinstance(value, tuple) else value.copy()
                       for value in pristine)
        self.ints, self.floats = arrays[: len(INT_SLOTS)], arrays[len(INT_SLOTS):]
        self.table = np.array([value for a in arrays for value in (a.ctypes.data, a.size)],
                              dtype=np.int64)
        self._address = self.table.ctypes.data  # the table never moves: read it once

    def float_array(self, name):
        """The float64 array of slot `name` (a view: writing to it changes the engine's)."""
        return self.floats[_index(_FLOAT_INDEX, name, "float64")]

    def int_array(self, name):
        """The int64 array of slot `name` (a view)."""
        return self.ints[_index(_INT_INDEX, name, "int64")]

    def restart_kinematics(self, x):
        """The next kinematic solution starts with full Newton from the coordinates x (NX,:
        m, rad, Euler parameters) rather than from the last solution and its factors (slot
        x_start, dims.warm = 0), as `access.restart_kinematics` does in compiled code."""
        self.float_array("x_start")[:] = x
        self.int_array("dims")[_FIELDS["WARM"]] = 0

    @contextmanager
    def evaluating(self, *, damping=None, static=None, convective=None):
        """Within the block, an evaluation forms the damping forces and matrix if `damping`
        (dims.has_damping), leaves out M_bar and its LU if `static` (dims.static: a balance
        needs DF^T r only) and forms slot conv at once if `convective` (dims.conv_wanted:
        for a reader of slot conv outside the compiled code, `convective`); a switch given
        as None is left as it is. After the block each setting is what it was, whatever
        happened inside."""
        dims = self.int_array("dims")
        given = ((_FIELDS["HAS_DAMPING"], damping), (_FIELDS["STATIC"], static),
                 (_FIELDS["CONV_WANTED"], convective))
        before = [(field, dims[field]) for field, value in given if value is not None]
        for field, value in given:
            if value is not None:
                dims[field] = int(value)
        try:
            yield self
        finally:
            for field, value in before:
                dims[field] = value

    def slots(self, role=None):
        """{name: array (a view)} of every slot of `role` (layout.CONFIG, STATE, SCRATCH or
        MIXED; default all), in the table's order."""
        return {s.name: (self.int_array if s.dtype == layout.INT else self.float_array)(s.name)
                for s in layout.SLOTS if role in (None, s.role)}

    @property
    def address(self):
        """The address of the table (for a C callback's user data)."""
        return self._address


def _index(indices, name, dtype):
    try:
        return indices[name]
    except KeyError:
        raise ValueError(f"expected the name of a {dtype} slot of the layout "
                         f"({', '.join(indices)}), got {name!r}") from None


def packing_key(options):
    """What a kept packing is kept under besides its model: the options (`EngineData`'s) and
    what the packing reads from modules, the sparse Newton matrix's size threshold
    (`newton_packing.SPARSE_NEWTON_FROM`, "read at packing") and the cost rule that picks the
    forms (`evaluation_cost`, the function itself: kept in the key, it cannot be collected and
    its id reused). Why: a test (or a study of the paths) that changes either and packs the
    same model again must get the packing they choose, not the one kept before."""
    return (*options, newton_packing.SPARSE_NEWTON_FROM, evaluation_cost)


def _packed(model, options):
    """(the rigid packing, the costs, the arrays in the table's order: copies of those not all
    zero, (shape, dtype) of the others) of `model` packed with `options` (tolerance,
    singular_ratio, augmented, sparse, rigid: `EngineData`'s)."""
    tolerance, singular_ratio, augmented, sparse, rigid = options
    context = packing.Context(model, tolerance=tolerance, singular_ratio=singular_ratio,
                              augmented=augmented, sparse=sparse, rigid=rigid)
    packed = packing.pack(context)
    problems = packing_check.check(packed, context.counts)
    if problems:
        raise layout.LayoutError(f"model {model.name!r}: the packing does not match the "
                                 "layout: " + "; ".join(problems))
    arrays = {name: array for slots in packed.values() for name, array in slots.items()}
    arrays = (*(np.ascontiguousarray(arrays[name]) for name in INT_SLOTS),
              *(np.ascontiguousarray(arrays[name], dtype=float) for name in FLOAT_SLOTS))
    return context.rigid, context.plan.costs, tuple(
        a.copy() if np.any(a) else (a.shape, a.dtype) for a in arrays)


def _check_counted(model):
    """ValueError unless the model's free coordinates are as many as its constraints and
    DOFs."""
    free = model.free_coordinates
    constraints = model.rigid_deformations.size + model.dof_deformations.size
    if free.size != constraints + model.dof_coordinates.size:
        raise ValueError(f"model {model.name!r} is not exactly counted: {free.size} free "
                         f"coordinates, {constraints + model.dof_coordinates.size} "
                         "constraints and DOFs")


def banded_multiplications(n, kl, ku):
    """Multiplications of the banded LU with partial pivoting of an (n, n) matrix with kl
    sub- and ku super-diagonals, and of one solve with it."""
    kl, ku = min(kl, n), min(ku, n)
    return n * kl * (kl + ku) + 2 * n * (kl + ku)


def evaluation_cost(n_free, n_rigid, ndof, groups, bands=None, sparse=None):
    """Multiplications of one evaluation's linear algebra by each way to the accelerations
    (zeros counted):
    {"reduced": DF (NDOF solves), M_bar = DF^T M DF element by element and its LU;
    "augmented": the LU of the augmented system (n_free + n_rigid) and the free-coordinate
    mass blocks}; both factor J. groups: (element count, coordinates m, inertia points P) per
    element group; bands: (kl, ku) of J and of the augmented system (default: dense);
    sparse: the multiplications of the static-pivot sparse LUs {"j_factor", "j_solve",
    "a_factor", "a_solve"} (`sparse_packing.SparseFactors.multiplications`), weighed at
    `sparse_packing.SPARSE_WEIGHT` banded ones each, or None. The reduced form wins on few
    DOFs (a 1-DOF stage: M_bar is 1 x 1), the augmented one on many (M_bar costs NDOF^2 per
    element). Also says which LU each matrix takes: {"constraint_lu", "augmented_lu"}, "banded"
    or "sparse", whichever costs less."""
    na = n_free + n_rigid
    j_kl, j_ku, a_kl, a_ku = bands if bands is not None else (n_free, n_free, na, na)
    j_solve = 2 * n_free * (min(j_kl, n_free) + min(j_ku, n_free))
    j_lu = banded_multiplications(n_free, j_kl, j_ku)
    a_lu = banded_multiplications(na, a_kl, a_ku)
    lu_kinds = {"constraint_lu": "banded", "augmented_lu": "banded"}
    if sparse is not None:
        weight = sparse_packing.SPARSE_WEIGHT
        sparse_j = weight * (sparse["j_factor"] + sparse["j_solve"])
        sparse_a = weight * (sparse["a_factor"] + sparse["a_solve"])
        if sparse_j < j_lu:
            j_lu, j_solve = sparse_j, weight * sparse["j_solve"]
            lu_kinds["constraint_lu"] = "sparse"
        if sparse_a < a_lu:
            a_lu = sparse_a
            lu_kinds["augmented_lu"] = "sparse"
    reduced = j_lu + ndof * j_solve + ndof ** 3 / 3 + sum(
        n * (P * m * ndof + P * P * ndof + P * ndof * ndof) for n, m, P in groups)
    augmented = j_lu + a_lu + sum(n * (P * P * m + P * m * m) for n, m, P in groups)
    return {"reduced": reduced, "augmented": augmented, **lu_kinds}


__all__ = ["A_AT_STAGE", "A_GAIN", "A_KM", "A_L", "A_R", "A_SATURATION", "A_WIDTH",
           "BANDED_FACTORS",
           "CURRENT_DRIVE", "FLOAT_SLOTS", "FORCE_INPUT", "INT_SLOTS", "NO_FACTORS",
           "SPARSE_FACTORS", "VOLTAGE_DRIVE", "EngineData", "banded_multiplications",
           "evaluation_cost"]
