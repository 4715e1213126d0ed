"""A model packed for compiled code: two tuples of flat arrays, and their address table.

The compiled evaluation engine (`flexure.core.engine.engine`) and the SUNDIALS callbacks
(`flexure.core.simulation.sundials`) take no Python objects: everything they read or write is
one of the flat arrays built here, float64 arrays in `floats` and int64 arrays in `ints`, in the
fixed order of the slot names below. The same arrays reach a C callback through one address:
`table` lists (address, length) of every array, and `slots.int_array` / `float_array`
find an array from it.

Per element group (all elements of one type) the engine needs the addresses of the element
module's compiled entry points (`deformations_entry`, `inertia_entry`), the local coordinate
and deformation indices, the packed reference rows (`pack_reference`) and, for groups with
mass, the constant mass Mp of the inertia points and gravity on those points. J and the
augmented system are factored banded or, for models whose band stays wide, sparse
(`sparse_packing`, chosen by `evaluation_cost`). An element module that defines these plugs
into the engine without the engine naming it. Workspace arrays (warm start of the
kinematics, the last evaluation, scratch) live here too: no allocation in an evaluation.

Units: SI throughout (m, rad, kg, N, s), as the model's.
"""

import weakref

import numpy as np

from ..mechanics import assembly
from ..mechanics.scales import kinematic_tolerances
from . import sparse_packing
from .ports import port_specs
from .rigid import RigidPacking, positions_among

# the banded orders of a model's J and augmented system, computed once per live model (read
# only): {id(model): (weak reference to the model, orders)}
_ORDERS = {}

# int64 slots (`ints`)
INT_SLOTS = ("dims", "free", "constraint_rows", "dof_coordinates", "dof_deformations",
             "dof_positions", "stressed", "input_ports", "groups", "coordinate_index",
             "deformation_index", "row_of_deformation", "column_of_coordinate", "pivots",
             "mass_pivots", "counters", "augmented_pivots", "j_row_position",
             "j_column_position", "augmented_position", "mass_pattern", "point_columns",
             "j_sparse", "j_map", "aug_sparse", "aug_map", "stress_pointers", "stress_columns",
             "actuators", "rigid_slaves", "slave_index", "rigid_dependencies",
             "rigid_element_of", "rigid_elements", "rigid_z", "rigid_terms", "rigid_units",
             "rigid_coordinates", "touching_rows")
# float64 slots (`floats`)
FLOAT_SLOTS = ("settings", "S", "D", "lumped", "constant_force", "group_data", "inputs", "q_ref",
               "x", "q", "DF", "lu", "e", "De", "D2e", "x_trial", "g", "dx", "xdot", "edot",
               "sigma", "force", "mass", "mass_lu", "reduced_force", "qddot", "conv", "local",
               "DeF", "stiffness", "damping", "jacobian_cache", "x_start", "xddot", "augmented",
               "augmented_rhs", "band_scratch", "j_sparse_values", "aug_sparse_values",
               "actuator_data", "currents", "port_values", "rigid_data", "rigid_weights",
               "rigid_de", "rigid_c", "rigid_h", "rigid_force", "rigid_local", "evaluated_inputs",
               "row_tolerance", "step_tolerance")

# dims entries
(NX, NE, NDOF, NFREE, NRIGID, NXDOF, NEDOF, NIN, NS, NGROUPS, HAS_DAMPING, MAX_M, MAX_K,
 MAX_P, CHORD_ITERATIONS, MAX_NEWTON, STATUS, WARM, JACOBIAN_REUSE, ENGINE, AUGMENTED, REDUCED,
 MASS_CURRENT, J_KL, J_KU, A_KL, A_KU, J_SPARSE, A_SPARSE, J_FACTORS, NEL, NSLAVES, A_RIGID,
 A_FACTORS, DIMS_SIZE) = range(35)
# per-group row of `groups`
(G_UNUSED, G_COUNT, G_M, G_K, G_P, G_REF_WIDTH, G_COORD_OFFSET, G_DEF_OFFSET, G_DATA_OFFSET,
 G_MASS_OFFSET, G_GRAVITY_OFFSET, G_DE_OFFSET, G_D2E_OFFSET, G_DEFORMATIONS_ENTRY,
 G_INERTIA_ENTRY, G_PATTERN_OFFSET, G_PATTERN_COUNT, G_ELEMENT_OFFSET, G_WIDTH) = range(19)
# per input: its kind in slot actuators (with the index of its coil current), and its
# coefficients in slot actuator_data (`engine.actuators`)
FORCE_INPUT, CURRENT_DRIVE, VOLTAGE_DRIVE = range(3)
(A_KM, A_R, A_L, A_GAIN, A_SATURATION, A_WIDTH) = range(6)
# settings entries
SINGULAR_RATIO, SETTINGS_SIZE = range(2)
# counters entries (SPARSE_PIVOTING: sparse LUs that pivoted afresh because a kept pivot failed
# its test; SPARSE_FALLBACKS: those that could not, and were banded; numerics.sparse_lu)
RHS_COUNT, JACOBIAN_COUNT, FAILED_STATUS, SPARSE_PIVOTING, SPARSE_FALLBACKS, EVALUATIONS, \
    COUNTERS_SIZE = range(7)
# dims[J_FACTORS], dims[A_FACTORS]: which factors of J and of the augmented system are current
NO_FACTORS, BANDED_FACTORS, SPARSE_FACTORS = range(-1, 2)
# status codes returned by the engine's functions (messages: sundials.STATUS_MESSAGES)
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
        needs fewer multiplications for this model (`evaluation_cost`).
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
    """

    def __init__(self, model, *, tolerance=1e-15, singular_ratio=1e-6, augmented=None,
                 sparse=None, rigid=True):
        self.model = model
        nx, ne = model.nx, len(model.deformation_names)
        ndof = model.declared_dof_count
        free = model.free_coordinates
        rows = np.concatenate([model.rigid_deformations, model.dof_deformations])
        if free.size != rows.size + model.dof_coordinates.size:
            raise ValueError(f"model {model.name!r} is not exactly counted: {free.size} free "
                             f"coordinates, {rows.size + model.dof_coordinates.size} "
                             "constraints and DOFs")
        stressed = model.stressed_deformations
        mech_S, mech_D = assembly.stiffness_and_damping(model)
        S = mech_S[np.ix_(stressed, stressed)]
        D = mech_D[np.ix_(stressed, stressed)]
        stress_rows, stress_columns = np.nonzero((S != 0.0) | (D != 0.0))  # row by row
        groups, coord_index, def_index, data, patterns = [], [], [], [], []
        de_size = d2e_size = 0
        de_groups = []  # (group, offset of its De)
        inertia_groups = assembly.Inertia(model).groups
        inertia = {id(group): Mp for group, Mp in inertia_groups}
        all_groups = list(model.groups) + [group for group, _ in inertia_groups
                                           if group.kind.type_name == "NODE_INERTIA"]
        offsets = {"coord": 0, "def": 0, "data": 0, "pattern": 0, "element": 0}
        max_m = max_k = max_p = 1
        for group in all_groups:
            kind = group.kind
            n, m = group.coordinate_index.shape
            k = group.deformation_index.shape[1]
            packed = kind.pack_reference(group.reference)
            Mp = inertia.get(id(group))
            P = 0 if Mp is None else Mp.shape[1]
            row = np.zeros(G_WIDTH, dtype=np.int64)
            row[[G_COUNT, G_M, G_K, G_P, G_REF_WIDTH]] = n, m, k, P, packed.shape[1]
            if k:
                row[G_DEFORMATIONS_ENTRY] = kind.deformations_entry.address
            if P:
                row[G_INERTIA_ENTRY] = kind.inertia_entry.address
            row[G_COORD_OFFSET] = offsets["coord"]
            row[G_DEF_OFFSET] = offsets["def"]
            row[G_DATA_OFFSET] = offsets["data"]
            row[G_ELEMENT_OFFSET] = offsets["element"]
            offsets["element"] += n
            pieces = [packed.ravel()]
            size = packed.size
            row[G_MASS_OFFSET] = row[G_GRAVITY_OFFSET] = -1
            if Mp is not None:
                row[G_MASS_OFFSET] = offsets["data"] + size
                pieces.append(np.ascontiguousarray(Mp, float).ravel())
                size += Mp.size
                row[G_GRAVITY_OFFSET] = offsets["data"] + size
                pieces.append(assembly.point_gravity(group, model.gravity).astype(float))
                size += P
                # the entries of Mp that any element of the group fills (flat p P + q): the
                # element masses are sparse (a BEAM's: 72 of 24 x 24), and the engine's
                # loops over them visit these alone
                pattern = np.flatnonzero(np.any(np.asarray(Mp) != 0.0, axis=0).ravel())
                row[G_PATTERN_OFFSET], row[G_PATTERN_COUNT] = offsets["pattern"], pattern.size
                patterns.append(pattern.astype(np.int64))
                offsets["pattern"] += pattern.size
            row[G_DE_OFFSET], row[G_D2E_OFFSET] = de_size, d2e_size
            de_groups.append((group, de_size))
            de_size += n * k * m
            d2e_size += n * k * m * m
            groups.append(row)
            coord_index.append(group.coordinate_index.astype(np.int64).ravel())
            def_index.append(group.deformation_index.astype(np.int64).ravel())
            data.extend(pieces)
            offsets["coord"] += n * m
            offsets["def"] += n * k
            offsets["data"] += size
            max_m, max_k, max_p = max(max_m, m), max(max_k, k), max(max_p, P)
        # the rigid clusters: their slaves leave the free coordinates, their rows the rows
        packing = RigidPacking(model, all_groups, inertia, enabled=rigid)
        self.rigid = packing
        free, rows = packing.free, packing.rows
        n_rigid = packing.rigid_rows.size
        max_m = max(max_m, packing.max_mz)
        row_of_def = np.full(ne, -1, dtype=np.int64)
        row_of_def[rows] = np.arange(rows.size)
        col_of_coord = np.full(nx, -1, dtype=np.int64)
        col_of_coord[free] = np.arange(free.size)
        input_ports = port_specs(model.inputs).ravel()  # ports.PORT_WIDTH per input
        lumped = model.lumped_mass.astype(float)
        constant_force = model.loads.astype(float).copy()
        if np.any(model.gravity):
            per_coordinate = assembly.Inertia(model)._translation_gravity(model.gravity)
            constant_force += lumped * per_coordinate
        dims = np.zeros(DIMS_SIZE, dtype=np.int64)
        dims[[NX, NE, NDOF, NFREE, NRIGID, NXDOF, NEDOF, NIN, NS, NGROUPS]] = (
            nx, ne, ndof, free.size, n_rigid, model.dof_coordinates.size,
            model.dof_deformations.size, len(model.inputs), stressed.size, len(groups))
        dims[NEL] = len(model.coil_actuators)  # the electrical states after [q - q_ref, qdot]
        nstate = 2 * ndof + dims[NEL]
        dims[HAS_DAMPING] = int(np.any(D))
        dims[[MAX_M, MAX_K, MAX_P]] = max_m, max_k, max_p
        dims[CHORD_ITERATIONS], dims[MAX_NEWTON], dims[A_FACTORS] = 6, 30, NO_FACTORS
        # banded orders of J and of the augmented system (core/numerics/banded.py), and
        # their sparse LUs where those pay (sparse_packing), found once per model
        known = _ORDERS.get((id(model), rigid))  # a Simulator packs its model twice
        if known is not None and known[0]() is model:
            found = known[1]
        else:
            found = {"orders": (
                _constraint_order(model, free, rows, row_of_def, col_of_coord, packing),
                _augmented_order(model, free.size, n_rigid, row_of_def, col_of_coord,
                                 all_groups, inertia, packing))}
            key = (id(model), rigid)
            _ORDERS[key] = (weakref.ref(model, lambda _, key=key: _ORDERS.pop(key, None)),
                            found)
        (j_rows, j_cols, dims[J_KL], dims[J_KU]), (aug_position, dims[A_KL], dims[A_KU]) = \
            found["orders"]
        bands = (int(dims[J_KL]), int(dims[J_KU]), int(dims[A_KL]), int(dims[A_KU]))
        if sparse is not False and "sparse" not in found:
            banded_lu = (banded_multiplications(free.size, *bands[:2]) + banded_multiplications(
                free.size + n_rigid, *bands[2:]))
            found["sparse"] = sparse_packing.analyse(
                model, de_groups, [group for group in all_groups if id(group) in inertia],
                free, rows, row_of_def, col_of_coord, de_size,
                np.inf if sparse else banded_lu, packing)
        factors = found.get("sparse") if sparse is not False else None
        costs = evaluation_cost(free.size, n_rigid, ndof,
                                [(row[G_COUNT], row[G_M], row[G_P]) for row in groups], bands,
                                None if factors is None else factors.multiplications())
        if sparse and factors is not None:  # forced: both matrices sparse
            costs["constraint_lu"] = costs["augmented_lu"] = "sparse"
        self.costs = costs
        # the form with fewer multiplications (measured, one evaluation, both forms
        # alternating: reduced / augmented 6.6 / 7.4 us on stage_planar_1dof, 47 / 41 us on
        # stage_spatial_19dof, 21 / 14 us on the refined stage with 4 PLBEAMs per spring,
        # 244 / 50 us with 16; the counts order all of them the same way)
        dims[AUGMENTED] = int(costs["augmented"] < costs["reduced"] if augmented is None
                              else bool(augmented))
        dims[J_SPARSE] = int(costs["constraint_lu"] == "sparse")
        dims[A_SPARSE] = int(costs["augmented_lu"] == "sparse")
        empty = np.zeros(0, dtype=np.int64)
        j_lu = factors.constraints if dims[J_SPARSE] else None
        a_lu = factors.augmented if dims[A_SPARSE] else None
        # dims[ENGINE], the address of the engine's table of entries for callers, is set
        # by the integrators that make such callbacks (`engine.connect`): the engine imports
        # this module, not the other way round
        settings = np.zeros(SETTINGS_SIZE)
        settings[SINGULAR_RATIO] = singular_ratio
        # the kinematics' Newton: per row of g and per free coordinate, in its own unit
        tolerances = kinematic_tolerances(model, tolerance, rows=rows, free=free)
        # scratch of one evaluation: the largest of the element-local buffers the engine's
        # functions lay out one after the other (slots.inertia_scratch, tangent),
        # plus the absolute DOFs at the end
        scratch = (2 * ndof + 2 * max_m * max_m + max_m * ndof + 2 * max_m + 3 * max_p
                   + 2 * max_p * max_m + 2 * max_p * ndof + max_k + ndof
                   + max(nx, ne, 2 * ndof))
        # the augmented system of the accelerations: free coordinates and the multipliers of
        # the rigid constraint rows (engine.evaluate)
        augmented = free.size + n_rigid
        dims[NSLAVES] = packing.slaves.shape[0]
        # where the touching elements' entries begin in the augmented map (`sparse_packing`)
        dims[A_RIGID] = -1 if factors is None else factors.rigid_start
        actuator_kinds, actuator_data = _actuator_arrays(model)
        ints = {
            "dims": dims, "free": free.astype(np.int64), "constraint_rows": rows.astype(np.int64),
            "dof_coordinates": model.dof_coordinates.astype(np.int64),
            "dof_deformations": model.dof_deformations.astype(np.int64),
            "dof_positions": positions_among(free, model.dof_coordinates),
            "stressed": stressed.astype(np.int64), "input_ports": input_ports,
            "groups": np.concatenate(groups) if groups else np.zeros(0, np.int64),
            "coordinate_index": np.concatenate([*coord_index, empty]),
            "deformation_index": np.concatenate([*def_index, empty]),
            "row_of_deformation": row_of_def, "column_of_coordinate": col_of_coord,
            "pivots": np.zeros(free.size, np.int64), "mass_pivots": np.zeros(ndof, np.int64),
            "counters": np.zeros(COUNTERS_SIZE, np.int64),
            "augmented_pivots": np.zeros(augmented, np.int64),
            "j_row_position": j_rows, "j_column_position": j_cols,
            "augmented_position": aug_position,
            "mass_pattern": np.concatenate(patterns) if patterns else np.zeros(0, np.int64),
            # scratch: the columns of each row of an element's Dp that are not zero (max_p
            # rows of max_m columns), the count of each row, the element's coordinates'
            # positions in the augmented system
            "point_columns": np.zeros(max_p * (max_m + 1) + max_m, np.int64),
            # the sparse LUs' patterns and scatter maps (sparse_packing), empty when banded
            "j_sparse": empty if j_lu is None else j_lu.ints.copy(),
            "j_map": empty if j_lu is None else factors.constraint_map,
            "aug_sparse": empty if a_lu is None else a_lu.ints.copy(),
            "aug_map": empty if a_lu is None else factors.augmented_map,
            # S and D on the stressed deformations, row by row on the entries either has
            # (compressed rows: an element's stiffness couples its own deformations only)
            "stress_pointers": np.concatenate([[0], np.cumsum(np.bincount(
                stress_rows, minlength=stressed.size))]).astype(np.int64),
            "stress_columns": stress_columns.astype(np.int64),
            "actuators": actuator_kinds,
            **packing.ints(),
        }
        floats = {
            "settings": settings, "S": S[stress_rows, stress_columns],
            "D": D[stress_rows, stress_columns], "lumped": lumped,
            "constant_force": constant_force,
            "group_data": np.concatenate(data) if data else np.zeros(0),
            "inputs": np.zeros(len(model.inputs)), "q_ref": np.zeros(ndof),
            "x": model.initial_coordinates.astype(float).copy(), "q": np.zeros(ndof),
            "DF": np.zeros(nx * ndof), "lu": np.zeros(free.size * free.size),
            "e": np.zeros(ne), "De": np.zeros(de_size), "D2e": np.zeros(d2e_size),
            "x_trial": np.zeros(nx), "g": np.zeros(free.size), "dx": np.zeros(free.size),
            "xdot": np.zeros(nx), "edot": np.zeros(ne), "sigma": np.zeros(ne),
            "force": np.zeros(nx), "mass": np.zeros(ndof * ndof),
            "mass_lu": np.zeros(ndof * ndof), "reduced_force": np.zeros(ndof),
            "qddot": np.zeros(ndof), "conv": np.zeros(nx), "local": np.zeros(scratch),
            "DeF": np.zeros(ne * ndof), "stiffness": np.zeros(ndof * ndof),
            "damping": np.zeros(ndof * ndof), "jacobian_cache": np.zeros(nstate * nstate),
            "x_start": model.initial_coordinates.astype(float).copy(),
            "xddot": np.zeros(nx), "augmented": np.zeros(augmented * augmented),
            "augmented_rhs": np.zeros(augmented), "band_scratch": np.zeros(augmented),
            # the factors at the initial configuration, a copy per packing (factoring
            # changes them)
            "j_sparse_values": np.zeros(0) if j_lu is None else j_lu.floats.copy(),
            "aug_sparse_values": np.zeros(0) if a_lu is None else a_lu.floats.copy(),
            "actuator_data": actuator_data, "currents": np.zeros(dims[NEL]),
            # the value each input puts on its port in the last evaluation (N, N m; only
            # with actuators: without, the inputs themselves; `actuators.port_values`)
            "port_values": np.zeros(len(model.inputs) if model.actuators else 0),
            # the inputs of the last evaluation, scratch for their change (`input_response`)
            "evaluated_inputs": np.zeros(2 * len(model.inputs)),
            "row_tolerance": tolerances[0], "step_tolerance": tolerances[1],
            **packing.floats(nx, free.size, max_p),
        }
        self.ints = tuple(np.ascontiguousarray(ints[name]) for name in INT_SLOTS)
        self.floats = tuple(np.ascontiguousarray(floats[name], dtype=float)
                            for name in FLOAT_SLOTS)
        arrays = self.ints + self.floats
        self.table = np.array([value for a in arrays for value in (a.ctypes.data, a.size)],
                              dtype=np.int64)
        self._address = self.table.ctypes.data  # the table never moves: read it once

    def float_array(self, name):
        """The float64 array of slot `name` (a view: writing to it changes the engine's)."""
        return self.floats[FLOAT_SLOTS.index(name)]

    def int_array(self, name):
        """The int64 array of slot `name` (a view)."""
        return self.ints[INT_SLOTS.index(name)]

    @property
    def address(self):
        """The address of the table (for a C callback's user data)."""
        return self._address


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


def _constraint_order(model, free, rows, row_of_def, col_of_coord, packing):
    """Positions of J's rows and columns in its banded order, and its (kl, ku): each row
    matched to a column (a structurally nonsingular J has a perfect matching), then reverse
    Cuthill-McKee on the matched pattern (core/numerics/banded.py). The identity order, dense, when
    there is no perfect matching."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import maximum_bipartite_matching

    from ..numerics.banded import bandwidth_order

    nf = free.size
    entries = []
    for gp, group in enumerate(model.groups):
        for coords, defs in zip(packing.pattern_coordinates(gp, group),
                                group.deformation_index, strict=True):
            cols = [col_of_coord[c] for c in coords if col_of_coord[c] >= 0]
            for d in defs:
                if row_of_def[d] >= 0:
                    entries.extend((row_of_def[d], c) for c in cols)
    n_def = rows.size
    for j, c in enumerate(model.dof_coordinates):
        s = packing.units[j]
        sources = [c] if s < 0 else packing.layout.dependencies[s]
        entries.extend((n_def + j, col_of_coord[d]) for d in sources
                       if d >= 0 and col_of_coord[d] >= 0)
    identity = np.arange(nf, dtype=np.int64)
    if nf == 0 or not entries:
        return identity, identity.copy(), max(nf - 1, 0), max(nf - 1, 0)
    r, c = np.array(entries, dtype=np.int64).T
    pattern = csr_matrix((np.ones(r.size), (r, c)), shape=(nf, nf))
    column_of_row = maximum_bipartite_matching(pattern, perm_type="column")
    if np.any(column_of_row < 0):
        return identity, identity.copy(), nf - 1, nf - 1
    row_of_column = np.empty(nf, dtype=np.int64)
    row_of_column[column_of_row] = np.arange(nf)
    order, _, _ = bandwidth_order(pattern[row_of_column])  # rows renamed by their column
    column_position = np.empty(nf, dtype=np.int64)
    column_position[order] = np.arange(nf)
    row_position = column_position[column_of_row]
    offsets = row_position[r] - column_position[c]
    return (row_position, column_position, int(max(0, offsets.max())),
            int(max(0, -offsets.min())))


def _augmented_order(model, nf, n_rigid, row_of_def, col_of_coord, groups, inertia, packing):
    """Positions of the augmented system's unknowns (the free coordinates, then the rigid
    rows' multipliers) in its banded order, and its (kl, ku)."""
    from scipy.sparse import csr_matrix

    from ..numerics.banded import bandwidth_order

    na = nf + n_rigid
    entries = [(a, a) for a in range(nf)]
    for gp, group in enumerate(groups):
        if id(group) not in inertia:
            continue
        for coords in packing.pattern_coordinates(gp, group):
            cols = [col_of_coord[c] for c in coords if col_of_coord[c] >= 0]
            entries.extend((a, b) for a in cols for b in cols)
    for gp, group in enumerate(model.groups):
        for coords, defs in zip(packing.pattern_coordinates(gp, group),
                                group.deformation_index, strict=True):
            cols = [col_of_coord[c] for c in coords if col_of_coord[c] >= 0]
            for d in defs:
                o = row_of_def[d]
                if 0 <= o < n_rigid:
                    entries.extend((nf + o, c) for c in cols)
                    entries.extend((c, nf + o) for c in cols)
    if na == 0:
        return np.zeros(0, dtype=np.int64), 0, 0
    r, c = np.array(entries, dtype=np.int64).T
    pattern = csr_matrix((np.ones(r.size), (r, c)), shape=(na, na))
    order, kl, ku = bandwidth_order(pattern)
    position = np.empty(na, dtype=np.int64)
    position[order] = np.arange(na)
    return position, kl, ku


def _actuator_arrays(model):
    """(kinds (2 n_inputs,): per input its kind and the index of its coil current or -1;
    coefficients (A_WIDTH n_inputs,): per input Km N/A, R ohm, L H, G, saturation V or A)."""
    n = len(model.inputs)
    kinds = np.zeros(2 * n, dtype=np.int64)
    kinds[1::2] = -1
    data = np.zeros(A_WIDTH * n)
    for actuator in model.actuators:
        j = actuator.input
        voltage = actuator.drive == "voltage"
        kinds[2 * j] = VOLTAGE_DRIVE if voltage else CURRENT_DRIVE
        if voltage:
            kinds[2 * j + 1] = model.coil_actuators.index(actuator)
        data[A_WIDTH * j: A_WIDTH * (j + 1)] = (
            actuator.force_constant, actuator.resistance, actuator.inductance,
            actuator.amplifier_gain, actuator.saturation)
    return kinds, data


__all__ = ["EngineData"]
