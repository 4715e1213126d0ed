"""The model packed slot by slot: one function per concern, each returning its slots by name.

`EngineData` builds a `Context` (the element groups packed, the rigid clusters, the free
coordinates and rows, the factors' plan, the model's counts), then calls each function of
`PACKERS`; every one returns {slot name: array} for the slots that `layout.SLOTS` says it
packs, and `packing_check.check` holds the result against the table (every slot packed once, by its
own function, with its dtype and size) before the arrays are put in the table's order.
Records (`dims`, a row of `groups`, `counters`, `settings`) are filled by field name
(`layout.record`). Units: SI, as the model's.
"""

import numpy as np

from ..elements.beam_directional import POINTS_WIDTH
from ..elements.beam_mass import PATTERN as BEAM_PATTERN
from ..elements.beam_mass import blocks_by_construction
from ..mechanics import assembly
from ..mechanics.rigid_bodies import DEPENDENCIES
from ..mechanics.scales import kinematic_tolerances
from ..numerics.banded import storage_size
from . import layout, newton_packing
from .orders import FactorPlan
from .ports import PORT_WIDTH, port_specs
from .rigid import SLAVE_WIDTH, RigidPacking, positions_among

# per input: its kind in slot actuators (with the index of its coil current), and its
# coefficients in slot actuator_data (`engine.actuators`)
FORCE_INPUT, CURRENT_DRIVE, VOLTAGE_DRIVE = range(3)
(A_KM, A_R, A_L, A_GAIN, A_SATURATION, A_WIDTH) = range(6)
# dims[J_FACTORS], dims[A_FACTORS]: which factors of J and of the augmented system are current
NO_FACTORS, BANDED_FACTORS, SPARSE_FACTORS = range(-1, 2)
# dims[A_FACTORS] only: a stage force's state in the slots, the augmented system neither
# assembled nor factored there (`stage_force`; `input_response` has it made)
A_AT_STAGE = 2
RIGID_DATA_WIDTH = 48  # constants per slave node (`mechanics.rigid_bodies.RigidLayout.data`)


class ElementGroups:
    """Every element group packed in the engine's order (the model's, then the node
    inertias'): the rows of slot groups (`layout.GROUP_FIELDS`), the index and data arrays
    they point into, the sizes of De and D2e and the largest element.

    Per group the engine needs the addresses of the element module's compiled entry points
    (`deformations_entry`, `inertia_entry`), the local coordinate and deformation indices,
    the packed reference rows (`pack_reference`) and, for groups with mass, the constant
    mass Mp of the inertia points and gravity on those points: an element module that
    defines these plugs into the engine without the engine naming it.
    """

    def __init__(self, model):
        inertia_groups = assembly.Inertia(model).groups
        self.inertia = {id(group): Mp for group, Mp in inertia_groups}
        self.all = list(model.groups) + [group for group, _ in inertia_groups
                                         if group.kind.type_name == "NODE_INERTIA"]
        self.rows, self.coordinates, self.deformations, self.data, self.patterns = \
            [], [], [], [], []
        self.de_groups = []  # (group, offset of its De)
        self.de_size = self.d2e_size = 0
        self.max_m = self.max_k = self.max_p = 1
        self._offsets = {"coord": 0, "def": 0, "data": 0, "pattern": 0, "element": 0,
                         "points": 0}
        self.points_size = 0  # floats of slot beam_points
        for group in self.all:
            self._add(group, model.gravity)

    def _add(self, group, gravity):
        kind, offsets = group.kind, self._offsets
        n, m = group.coordinate_index.shape
        k = group.deformation_index.shape[1]
        packed = kind.pack_reference(group.reference)
        Mp = self.inertia.get(id(group))
        P = 0 if Mp is None else Mp.shape[1]
        fields = {"count": n, "m": m, "k": k, "p": P, "ref_width": packed.shape[1],
                  "coord_offset": offsets["coord"], "def_offset": offsets["def"],
                  "data_offset": offsets["data"], "element_offset": offsets["element"],
                  "mass_offset": -1, "gravity_offset": -1, "de_offset": self.de_size,
                  "d2e_offset": self.d2e_size,
                  "deformations_entry": kind.deformations_entry.address if k else 0,
                  "inertia_entry": kind.inertia_entry.address if P else 0,
                  "points_offset": -1}
        pieces = [packed.ravel()]
        if Mp is not None:
            fields["mass_offset"] = offsets["data"] + packed.size
            fields["gravity_offset"] = offsets["data"] + packed.size + Mp.size
            pieces += [np.ascontiguousarray(Mp, float).ravel(),
                       assembly.point_gravity(group, gravity).astype(float)]
            # the entries of Mp that any element of the group fills (flat p P + q): the
            # element masses are sparse (a BEAM's: 72 of 24 x 24), and the engine's loops
            # over them visit these alone
            pattern = np.flatnonzero(np.any(np.asarray(Mp) != 0.0, axis=0).ravel())
            fields.update(pattern_offset=offsets["pattern"], pattern_count=pattern.size)
            # the BEAM's closed-form product then needs no check of Dp element by element
            fields["point_blocks"] = int(blocks_by_construction(kind)
                                         and np.array_equal(pattern, BEAM_PATTERN))
            if fields["point_blocks"]:  # its rates keep its points (`formed_rates`)
                fields["points_offset"] = offsets["points"]
                offsets["points"] += n * POINTS_WIDTH
            # a node inertia's closed form (`node_inertia_product`) reads Mp's diagonal
            fields["node_inertia"] = int(getattr(kind, "type_name", "") == "NODE_INERTIA"
                                         and np.array_equal(pattern, 10 * np.arange(9)))
            self.patterns.append(pattern.astype(np.int64))
            offsets["pattern"] += pattern.size
        self.de_groups.append((group, self.de_size))
        self.de_size += n * k * m
        self.d2e_size += n * k * m * m
        self.rows.append(layout.record("groups", **fields))
        self.coordinates.append(group.coordinate_index.astype(np.int64).ravel())
        self.deformations.append(group.deformation_index.astype(np.int64).ravel())
        self.data.extend(pieces)
        offsets["coord"] += n * m
        offsets["def"] += n * k
        offsets["data"] += sum(piece.size for piece in pieces)
        offsets["element"] += n
        self.points_size = offsets["points"]
        self.max_m, self.max_k = max(self.max_m, m), max(self.max_k, k)
        self.max_p = max(self.max_p, P)

    def cost_shapes(self):
        """(element count, coordinates m, inertia points P) per group (`evaluation_cost`)."""
        count, m, P = (layout.field_index("groups", name) for name in ("count", "m", "p"))
        return [(row[count], row[m], row[P]) for row in self.rows]


class Topology:
    """The free coordinates and the rows of g, with the rigid clusters' slaves and rows out
    (`rigid`), and their inverse maps: per deformation its row or -1, per coordinate its
    column of J or -1."""

    def __init__(self, model, rigid):
        self.free, self.rows = rigid.free, rigid.rows
        self.n_rigid = rigid.rigid_rows.size
        self.row_of_def = np.full(len(model.deformation_names), -1, dtype=np.int64)
        self.row_of_def[self.rows] = np.arange(self.rows.size)
        self.col_of_coord = np.full(model.nx, -1, dtype=np.int64)
        self.col_of_coord[self.free] = np.arange(self.free.size)


class Context:
    """What every packing function reads: the model, its element groups, rigid clusters,
    topology, factor plan, stiffness on the stressed deformations, the settings and the
    counts the layout's sizes are written in (`counts`).

    Parameters
    ----------
    model : Model
    tolerance, singular_ratio : float
    augmented, sparse : bool or None
    rigid : bool
        As `EngineData`'s.
    """

    def __init__(self, model, *, tolerance, singular_ratio, augmented, sparse, rigid):
        self.model = model
        self.tolerance, self.singular_ratio = tolerance, singular_ratio
        self.groups = ElementGroups(model)
        self.rigid = RigidPacking(model, self.groups.all, self.groups.inertia, enabled=rigid)
        self.topology = Topology(model, self.rigid)
        self.plan = FactorPlan(model, self.groups, self.topology, self.rigid,
                               augmented=augmented, sparse=sparse)
        self.stressed = model.stressed_deformations
        self.S, self.D = stressed_stiffness_and_damping(model, self.stressed)
        self.counts = counts(self)
        self.newton = newton_packing.NewtonPacking.analyse(self)  # or None: the dense one


def stressed_stiffness_and_damping(model, stressed):
    """S and D (ns, ns) on the stressed deformations, N/m and N s/m: the rows and columns
    `stressed` of `assembly.stiffness_and_damping`'s (NE, NE) ones, without forming those."""
    position = np.full(len(model.deformation_names), -1, dtype=np.int64)
    position[stressed] = np.arange(stressed.size)
    S, D = np.zeros((stressed.size, stressed.size)), np.zeros((stressed.size, stressed.size))
    for group in model.groups:
        at = position[group.deformation_index]
        rows = np.broadcast_to(at[:, :, None], at.shape + at.shape[1:])
        cols = np.broadcast_to(at[:, None, :], rows.shape)
        inside = (rows >= 0) & (cols >= 0)
        for matrix, block in ((S, group.kind.stiffness(group.reference, group.properties)),
                              (D, group.kind.damping(group.reference, group.properties))):
            matrix[rows[inside], cols[inside]] = np.broadcast_to(block, rows.shape)[inside]
    return S, D


def counts(c):
    """{name: int}: the counts the layout's slot sizes are written in, and dims' counts."""
    model, groups, topology = c.model, c.groups, c.topology
    ndof, nin = model.declared_dof_count, len(model.inputs)
    nel = len(model.coil_actuators)
    nsc = c.rigid.layout.slave_coordinates.size
    max_m, max_k, max_p = max(groups.max_m, c.rigid.max_mz), groups.max_k, groups.max_p
    nx, ne = model.nx, len(model.deformation_names)
    nfree, naug = topology.free.size, topology.free.size + topology.n_rigid
    j_kl, j_ku, a_kl, a_ku = c.plan.bands
    return {
        "nx": nx, "ne": ne, "ndof": ndof, "nfree": nfree, "nrigid": topology.n_rigid,
        "naug": naug, "j_band": storage_size(nfree, j_kl, j_ku),
        "a_band": storage_size(naug, a_kl, a_ku),
        "nrows": topology.rows.size, "nxdof": model.dof_coordinates.size,
        "nedof": model.dof_deformations.size, "nin": nin, "ns": c.stressed.size,
        "ngroups": len(groups.rows), "nel": nel, "nstate": 2 * ndof + nel,
        "nki": len(model.kinematic_inputs), "path_width": layout.PATH_WIDTH,
        "nslaves": c.rigid.slaves.shape[0], "nsc": nsc, "max_m": max_m, "max_k": max_k,
        "max_p": max_p, "de_size": groups.de_size, "d2e_size": groups.d2e_size,
        "has_actuators": int(bool(model.actuators)),
        # the element-local buffers the engine's functions lay out one after the other
        # (slots.inertia_scratch, tangent), plus the absolute DOFs at the end
        "scratch": (2 * ndof + 2 * max_m * max_m + max_m * ndof + 2 * max_m + 3 * max_p
                    + 2 * max_p * max_m + 2 * max_p * ndof + max_k + ndof
                    + max(nx, ne, 2 * ndof)),
        # the widths of the records and of the per-input and per-slave rows
        "dims_size": len(layout.DIMS_FIELDS), "g_width": len(layout.GROUP_FIELDS),
        "counters_size": len(layout.COUNTER_FIELDS),
        "settings_size": len(layout.SETTINGS_FIELDS), "port_width": PORT_WIDTH,
        "a_width": A_WIDTH, "slave_width": SLAVE_WIDTH, "dependencies": DEPENDENCIES,
        "rigid_data_width": RIGID_DATA_WIDTH,
    }


# -- the packing functions, one per concern (the `packer` column of layout.SLOTS) -----------
def dimensions(c):
    """dims (its fields by name) and settings."""
    n, plan = c.counts, c.plan
    counted = {f.name: n[f.name] for f in layout.DIMS_FIELDS if f.name in n}
    dims = layout.record(
        "dims", **counted, has_damping=int(np.any(c.D)), chord_iterations=6, max_newton=30,
        augmented=int(plan.augmented), j_kl=plan.bands[0], j_ku=plan.bands[1],
        a_kl=plan.bands[2], a_ku=plan.bands[3], j_sparse=int(plan.j_sparse),
        a_sparse=int(plan.a_sparse), a_factors=NO_FACTORS,
        newton_sparse=int(c.newton is not None),
        # where the touching elements' entries begin in the augmented map (`sparse_packing`)
        a_rigid=-1 if plan.factors is None else plan.factors.rigid_start)
    # dims.engine, the address of the engine's table of entries for callers, is set by the
    # integrators that make such callbacks (`engine.connect`): the engine imports this
    # module, not the other way round
    return {"dims": dims,
            "settings": layout.record("settings", singular_ratio=c.singular_ratio)}


def kinematics(c):
    """The free coordinates and rows of g, the kinematics' tolerances and its state."""
    model, t, n = c.model, c.topology, c.counts
    # the kinematics' Newton: per row of g and per free coordinate, in its own unit
    row_tolerance, step_tolerance = kinematic_tolerances(model, c.tolerance, rows=t.rows,
                                                         free=t.free)
    x0 = model.initial_coordinates.astype(float)
    return {
        "free": t.free.astype(np.int64), "constraint_rows": t.rows.astype(np.int64),
        "dof_coordinates": model.dof_coordinates.astype(np.int64),
        "dof_deformations": model.dof_deformations.astype(np.int64),
        "dof_positions": positions_among(t.free, model.dof_coordinates),
        "row_of_deformation": t.row_of_def, "column_of_coordinate": t.col_of_coord,
        "row_tolerance": row_tolerance, "step_tolerance": step_tolerance,
        "x": x0.copy(), "x_start": x0.copy(), "q": np.zeros(n["ndof"]),
        "q_ref": np.zeros(n["ndof"]), "e": np.zeros(n["ne"]), "De": np.zeros(n["de_size"]),
        "D2e": np.zeros(n["d2e_size"]), "DF": np.zeros(n["nx"] * n["ndof"]),
        "x_trial": np.zeros(n["nx"]), "g": np.zeros(n["nfree"]), "dx": np.zeros(n["nfree"]),
    }


def groups(c):
    """The rows of slot groups and the index and data arrays they point into."""
    g, empty = c.groups, np.zeros(0, dtype=np.int64)
    return {
        "groups": np.concatenate(g.rows) if g.rows else empty,
        "coordinate_index": np.concatenate([*g.coordinates, empty]),
        "deformation_index": np.concatenate([*g.deformations, empty]),
        "mass_pattern": np.concatenate(g.patterns) if g.patterns else empty,
        "group_data": np.concatenate(g.data) if g.data else np.zeros(0),
        "beam_points": np.zeros(g.points_size),
    }


def stiffness(c):
    """S and D on the stressed deformations, row by row on the entries either has
    (compressed rows: an element's stiffness couples its own deformations only)."""
    rows, columns = np.nonzero((c.S != 0.0) | (c.D != 0.0))  # row by row
    pointers = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=c.stressed.size))])
    position = np.full(c.counts["ne"], -1, dtype=np.int64)
    position[c.stressed] = np.arange(c.stressed.size)
    return {"stressed": c.stressed.astype(np.int64), "stressed_position": position,
            "stress_pointers": pointers.astype(np.int64),
            "stress_columns": columns.astype(np.int64),
            "S": c.S[rows, columns], "D": c.D[rows, columns]}


def inertia(c):
    """The lumped masses and the constant forces (loads, gravity on the lumped masses)."""
    model = c.model
    lumped = model.lumped_mass.astype(float)
    constant_force = model.loads.astype(float).copy()
    if np.any(model.gravity):
        per_coordinate = assembly.Inertia(model)._translation_gravity(model.gravity)
        constant_force += lumped * per_coordinate
    return {"lumped": lumped, "constant_force": constant_force}


def ports(c):
    """The inputs' ports (`ports.port_specs`) and the inputs' values."""
    nin = c.counts["nin"]
    return {"input_ports": port_specs(c.model.inputs).ravel().astype(np.int64),
            "inputs": np.zeros(nin),
            "port_values": np.zeros(nin if c.model.actuators else 0),
            "evaluated_inputs": np.zeros(2 * nin)}


def actuators(c):
    """Per input its kind and coil current's index or -1 (actuators) and its coefficients
    Km N/A, R ohm, L H, G, saturation V or A (actuator_data); the coil currents."""
    model = c.model
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
    return {"actuators": kinds, "actuator_data": data, "currents": np.zeros(c.counts["nel"])}


def motion(c):
    """The state and scratch of the equations of motion and of their tangent."""
    n = c.counts
    ndof, nx, ne = n["ndof"], n["nx"], n["ne"]
    return {
        "mass_pivots": np.zeros(ndof, np.int64),
        "counters": layout.record("counters"),
        "point_columns": np.zeros(n["max_p"] * (n["max_m"] + 1) + n["max_m"], np.int64),
        "tangent_ranges": np.zeros(5 * nx, np.int64),
        "xdot": np.zeros(nx), "edot": np.zeros(ne), "sigma": np.zeros(ne),
        "force": np.zeros(nx), "conv": np.zeros(nx), "xddot": np.zeros(nx),
        "mass": np.zeros(ndof * ndof), "mass_lu": np.zeros(ndof * ndof),
        "reduced_force": np.zeros(ndof), "qddot": np.zeros(ndof),
        "tangent_rows": np.zeros(nx * ndof), "stiffness": np.zeros(ndof * ndof),
        "damping": np.zeros(ndof * ndof),
        "jacobian_cache": np.zeros(n["nstate"] * n["nstate"]),
        "local": np.zeros(n["scratch"]),
    }


def prescribed(c):
    """The kinematic inputs' positions in q, their path (held at the scene's `start` until
    the simulator writes one: `prescribed.quintic_path`) and the efforts' workspace."""
    n, model = c.counts, c.model
    nki, ndof = n["nki"], n["ndof"]
    path = np.zeros(layout.PATH_WIDTH * nki)
    for i, start in enumerate(model.motion_starts if nki else ()):
        path[layout.PATH_WIDTH * i + 2] = start
    return {
        "prescribed": np.asarray(model.prescribed_dofs if nki else (), dtype=np.int64),
        "prescribed_pivots": np.zeros(nki, np.int64), "motion_path": path,
        "efforts": np.zeros(nki), "prescribed_columns": np.zeros(ndof * nki),
        "prescribed_schur": np.zeros(nki * nki), "prescribed_scratch": np.zeros(ndof + nki),
    }


def factors(c):
    """J's and the augmented system's banded orders and LUs, and their sparse LUs'
    patterns, scatter maps and values at the initial configuration (a copy per packing:
    factoring changes them; empty when banded)."""
    plan, n, empty = c.plan, c.counts, np.zeros(0, dtype=np.int64)
    nfree, naug = n["nfree"], n["naug"]
    j_lu, a_lu = plan.j_lu, plan.a_lu
    return {
        "pivots": np.zeros(nfree, np.int64), "augmented_pivots": np.zeros(naug, np.int64),
        "j_row_position": plan.j_rows, "j_column_position": plan.j_columns,
        "augmented_position": plan.aug_position,
        "j_sparse": empty if j_lu is None else j_lu.ints.copy(),
        "j_map": empty if j_lu is None else plan.factors.kinematic_map,
        "aug_sparse": empty if a_lu is None else a_lu.ints.copy(),
        "aug_map": empty if a_lu is None else plan.factors.augmented_map,
        "lu": np.zeros(n["j_band"]), "augmented": np.zeros(n["a_band"]),
        "augmented_rhs": np.zeros(naug), "band_scratch": np.zeros(naug),
        "refinement": np.zeros(2 * n["nx"] + 3 * naug),
        "j_sparse_values": np.zeros(0) if j_lu is None else j_lu.floats.copy(),
        "aug_sparse_values": np.zeros(0) if a_lu is None else a_lu.floats.copy(),
    }


def rigid(c):
    """The rigid clusters' tables and workspace (`rigid.RigidPacking`)."""
    return {**c.rigid.ints(),
            **c.rigid.floats(c.model.nx, c.counts["nfree"], c.counts["max_p"])}


PACKERS = {"dimensions": dimensions, "kinematics": kinematics, "groups": groups,
           "stiffness": stiffness, "inertia": inertia, "ports": ports,
           "actuators": actuators, "motion": motion, "prescribed": prescribed,
           "factors": factors, "rigid": rigid, "newton": newton_packing.pack}


def pack(c):
    """{packing function's name: {slot name: array}} of every packing function."""
    return {name: function(c) for name, function in PACKERS.items()}
