"""The packed model's layout, described once: every slot, `dims` field and group field.

`EngineData` packs a model into flat int64 and float64 arrays ("slots"), and compiled code
finds each through its index in the address table (`slots.int_array`, `slots.float_array`).
This module is the one description of them: a table with, per slot, its name (the key of
`EngineData.int_array` / `float_array`), dtype, the index constant that compiled code names
it by, its size, its role, the packing function that fills it (`packing`), its unit and its
meaning. From the table come the slot order (`INT_SLOTS`, `FLOAT_SLOTS`), the index
constants (`slots.X` is the index of slot "x"; generated, module-level ints, which numba
freezes into the compiled code as literals) and the check that the packing filled every
slot by its name with the declared dtype and size (`packing_check.check`). The fields of
slot `dims` and of a row of slot `groups` are tables of their own (`DIMS_FIELDS`,
`GROUP_FIELDS`), as are the small records `counters` and `settings` (`layout_records`).

Roles. CONFIG: the model, written once by the packing and only read by an evaluation.
STATE: written by evaluations (or by the integrators between them) and meaningful after one:
the configuration reached, its factors, the accelerations, the held inputs. SCRATCH: written
and read within one evaluation, meaningless between evaluations. `dims` is of both kinds: its
fields carry their own roles.

Sizes are expressions over the model's counts (`packing.counts`: nx coordinates, ne
deformations, ndof DOFs, nfree free coordinates after the rigid clusters' slaves leave,
naug = nfree + nrigid the augmented system, j_band and a_band the entries of J's and the
augmented system's band storage, ...); "-" where the packing computes it
from what it packs (the slot's meaning says how), and `check` then checks only the dtype.
"""

from dataclasses import dataclass

import numpy as np

from .layout_records import (
    CONFIG,
    COUNTER_FIELDS,
    DIMS_FIELDS,
    GROUP_FIELDS,
    MIXED,
    SCRATCH,
    SETTINGS_FIELDS,
    STATE,
)

# the width of a kinematic input's path record in slot motion_path: t_start, t_end (s), then
# the coefficients c_0 .. c_5 of its quintic (`prescribed`)
PATH_WIDTH = 8
INT, FLOAT = "int64", "float64"


class LayoutError(ValueError):
    """The packing and the layout table disagree (a slot missing, unknown, or of another
    dtype or size than declared): a bug in the engine's packing, not in the model."""


@dataclass(frozen=True)
class Slot:
    """One packed array: `name` (its key), `dtype` (INT or FLOAT), `constant` (the name of
    its index constant in `slots`), `size` (an expression over `packing.counts`, or "-"),
    `role` (CONFIG, STATE, SCRATCH, MIXED), `packer` (the `packing` function that fills
    it), `unit` and `meaning`."""

    name: str
    dtype: str
    constant: str
    size: str
    role: str
    packer: str
    unit: str
    meaning: str


def _slots(dtype, packer, rows):
    return tuple(Slot(name, dtype, constant, size, role, packer, unit, meaning)
                 for name, constant, size, role, unit, meaning in rows)


# fmt: off
# -- the slots, by the packing function that fills them (`packing`) --------------------------
SLOTS = (
    *_slots(INT, "dimensions", (
        ("dims", "DIMS", "dims_size", MIXED, "-", "the model's counts and the engine's switches "
         "(DIMS_FIELDS)"),
    )),
    *_slots(FLOAT, "dimensions", (
        ("settings", "SETTINGS", "settings_size", CONFIG, "-", "numerical settings "
         "(SETTINGS_FIELDS)"),
    )),
    *_slots(INT, "kinematics", (
        ("free", "FREE", "nfree", CONFIG, "-", "the free coordinates, the slaves' out (model "
         "indices, ascending)"),
        ("constraint_rows", "ROWS", "nrows", CONFIG, "-", "the deformations that are rows of "
         "g: the rigid ones a cluster keeps, then the DOF deformations"),
        ("dof_coordinates", "DOF_COORDS", "nxdof", CONFIG, "-", "the coordinates that are "
         "DOFs"),
        ("dof_deformations", "DOF_DEFS", "nedof", CONFIG, "-", "the deformations that are "
         "DOFs"),
        ("dof_positions", "DOF_POS", "nxdof", CONFIG, "-", "each DOF coordinate's position "
         "among the free ones (-1: a slave's)"),
        ("row_of_deformation", "ROW_OF_DEF", "ne", CONFIG, "-", "per deformation: its row of "
         "g, or -1"),
        ("column_of_coordinate", "COL_OF_COORD", "nx", CONFIG, "-", "per coordinate: its "
         "column of J (its position in free), or -1"),
    )),
    *_slots(FLOAT, "kinematics", (
        ("row_tolerance", "ROW_TOLERANCE", "nfree", CONFIG, "m, 1", "the kinematics' Newton "
         "tolerance per row of g, in the row's unit (`mechanics.scales`)"),
        ("step_tolerance", "STEP_TOLERANCE", "nfree", CONFIG, "m, 1", "the Newton's tolerance "
         "per free coordinate, in its unit"),
        ("x", "X", "nx", STATE, "m, 1", "the coordinates of the last evaluation"),
        ("x_start", "X_START", "nx", STATE, "m, 1", "where the next kinematics starts when "
         "dims.warm is 0 (the initial coordinates, or a restart's)"),
        ("q", "Q", "ndof", STATE, "m, rad", "the absolute DOFs of the last evaluation"),
        ("q_ref", "Q_REF", "ndof", STATE, "m, rad", "the reference DOFs: the state holds "
         "q - q_ref (set by the integrator)"),
        ("e", "E", "ne", STATE, "m, rad", "the deformations of the last evaluation"),
        ("De", "DE", "de_size", STATE, "1, m", "De = de/dx of every element, group by group "
         "(n k m each), flat"),
        ("D2e", "D2E", "d2e_size", STATE, "1/m, 1", "the second derivatives (n k m m per "
         "group), flat"),
        ("DF", "DF", "nx * ndof", STATE, "1, m", "DF = dx/dq (nx, ndof), row-major"),
        ("x_trial", "X_TRIAL", "nx", SCRATCH, "m, 1", "a Newton trial point; the input "
         "response's and the tangent's force vector"),
        ("g", "G", "nfree", SCRATCH, "m, 1", "the kinematic residual; the quadratic velocity "
         "terms of the motion"),
        ("dx", "DX", "nfree", SCRATCH, "m, 1", "the Newton step; a solve's vector"),
    )),
    *_slots(INT, "groups", (
        ("groups", "GROUPS", "g_width * ngroups", CONFIG, "-", "per element group a row of "
         "GROUP_FIELDS: the model's groups, then the node inertias'"),
        ("coordinate_index", "COORD_INDEX", "-", CONFIG, "-", "the groups' coordinates "
         "(model indices, n m per group, element by element)"),
        ("deformation_index", "DEF_INDEX", "-", CONFIG, "-", "the groups' deformations "
         "(n k per group)"),
        ("mass_pattern", "MASS_PATTERN", "-", CONFIG, "-", "per group with inertia points: "
         "the flat entries p P + q of Mp any element fills, ascending"),
    )),
    *_slots(FLOAT, "groups", (
        ("group_data", "GROUP_DATA", "-", CONFIG, "m, kg, N", "per group: its packed "
         "reference rows, then (with inertia points) Mp (n P P) and gravity on the points (P)"),
        ("beam_points", "BEAM_POINTS", "-", STATE, "1, m, 1/s^2, m/s^2", "per BEAM of a "
         "group with point_blocks: its Dp's blocks and (D2p v) v at the last evaluation's x "
         "and xdot, kept by its rates (`formed_rates`) for the element passes while dims "
         "points_current is 1 (`beam_directional.points_kernel`'s layout)"),
    )),
    *_slots(INT, "stiffness", (
        ("stressed", "STRESSED", "ns", CONFIG, "-", "the stressed deformations"),
        ("stress_pointers", "STRESS_POINTERS", "ns + 1", CONFIG, "-", "S and D by compressed "
         "rows on the stressed deformations: each row's first entry"),
        ("stress_columns", "STRESS_COLUMNS", "-", CONFIG, "-", "the column of each entry of "
         "S and D (the entries either has)"),
        ("stressed_position", "STRESSED_POSITION", "ne", CONFIG, "-", "each deformation's "
         "row of S and D (its index in stressed), or -1"),
    )),
    *_slots(FLOAT, "stiffness", (
        ("S", "S", "-", CONFIG, "N/m, N m/rad", "the stiffness on those entries"),
        ("D", "D", "-", CONFIG, "N s/m, N m s/rad", "the damping on those entries"),
    )),
    *_slots(FLOAT, "inertia", (
        ("lumped", "LUMPED", "nx", CONFIG, "kg", "the lumped mass per coordinate"),
        ("constant_force", "CONST_FORCE", "nx", CONFIG, "N, N m", "the constant loads and "
         "gravity on the lumped masses"),
    )),
    *_slots(INT, "ports", (
        ("input_ports", "INPUT_PORTS", "port_width * nin", CONFIG, "-", "per input its port "
         "(`ports.port_specs`)"),
    )),
    *_slots(FLOAT, "ports", (
        ("inputs", "INPUTS", "nin", STATE, "N, N m, V", "the held inputs (set by the "
         "integrator)"),
        ("port_values", "PORT_VALUES", "nin if has_actuators else 0", STATE, "N, N m", "the "
         "value each input put on its port in the last evaluation (with actuators only)"),
        ("evaluated_inputs", "EVALUATED_INPUTS", "2 * nin", STATE, "N, N m, V", "the inputs "
         "of the last evaluation, then scratch for their change (`input_response`)"),
    )),
    *_slots(INT, "actuators", (
        ("actuators", "ACTUATORS", "2 * nin", CONFIG, "-", "per input: its kind "
         "(FORCE_INPUT, CURRENT_DRIVE, VOLTAGE_DRIVE) and its coil current's index or -1"),
    )),
    *_slots(FLOAT, "actuators", (
        ("actuator_data", "ACTUATOR_DATA", "a_width * nin", CONFIG, "N/A, ohm, H, 1, V",
         "per input: Km, R, L, the amplifier's gain and saturation"),
        ("currents", "CURRENTS", "nel", STATE, "A", "the coil currents of the last "
         "evaluation"),
    )),
    *_slots(INT, "motion", (
        ("mass_pivots", "MASS_PIVOTS", "ndof", STATE, "-", "the pivots of M_bar's LU"),
        ("counters", "COUNTERS", "counters_size", STATE, "-", "what the engine counted "
         "(COUNTER_FIELDS)"),
        ("point_columns", "POINT_COLUMNS", "max_p * (max_m + 1) + max_m", SCRATCH, "-",
         "an element's Dp columns that are not zero per row, their counts, its coordinates' "
         "positions in the augmented system"),
        ("tangent_ranges", "TANGENT_RANGES", "5 * nx", SCRATCH, "-", "the rows tangent_rows "
         "has, then per row the columns [first, end) of DF's and of its entries"),
    )),
    *_slots(FLOAT, "motion", (
        ("xdot", "XDOT", "nx", STATE, "m/s, 1/s", "the coordinates' velocities"),
        ("edot", "EDOT", "ne", STATE, "m/s, rad/s", "the deformation rates (the full "
         "stress resultants after `tangent.balance_multipliers`)"),
        ("sigma", "SIGMA", "ne", STATE, "N, N m", "the stress resultants S e + D edot"),
        ("force", "FORCE", "nx", STATE, "N, N m", "the forces on the coordinates"),
        ("conv", "CONV", "nx", STATE, "m/s^2, 1/s^2", "the convective accelerations "
         "(D2F qdot) qdot on the coordinates (while dims conv_pending: J's right-hand side "
         "of them, `convective`)"),
        ("xddot", "XDDOT", "nx", STATE, "m/s^2, 1/s^2", "the coordinates' accelerations"),
        ("mass", "MASS", "ndof * ndof", STATE, "kg, kg m^2", "M_bar = DF^T M DF"),
        ("mass_lu", "MASS_LU", "ndof * ndof", STATE, "kg, kg m^2", "M_bar's LU"),
        ("reduced_force", "REDUCED_FORCE", "ndof", STATE, "N, N m", "DF^T r; a DOF column's "
         "scratch"),
        ("qddot", "QDDOT", "ndof", STATE, "m/s^2, rad/s^2", "the accelerations"),
        ("tangent_rows", "TANGENT_ROWS", "nx * ndof", SCRATCH, "N/m, N m/rad", "K_x DF or "
         "C_x DF (nx, ndof) on the coordinates, for the tangent (`tangent`)"),
        ("stiffness", "STIFFNESS", "ndof * ndof", STATE, "N/m, N m/rad", "K = K0 + G0"),
        ("damping", "DAMPING", "ndof * ndof", STATE, "N s/m, N m s/rad", "C0"),
        ("jacobian_cache", "JAC_CACHE", "nstate * nstate", STATE, "1/s, 1/s^2", "the "
         "integrator's last Jacobian, kept for a restart (`sundials`)"),
        ("local", "LOCAL", "scratch", SCRATCH, "-", "the element-local buffers of one "
         "evaluation (`slots.inertia_scratch`, `tangent`), then the absolute DOFs"),
    )),
    *_slots(INT, "factors", (
        ("pivots", "PIVOTS", "nfree", STATE, "-", "the pivots of J's banded LU"),
        ("augmented_pivots", "AUG_PIVOTS", "naug", STATE, "-", "the augmented system's"),
        ("j_row_position", "J_ROW_POS", "nfree", CONFIG, "-", "J's rows in its banded order"),
        ("j_column_position", "J_COL_POS", "nfree", CONFIG, "-", "J's columns in it"),
        ("augmented_position", "AUG_POS", "naug", CONFIG, "-", "the augmented system's "
         "unknowns in its banded order"),
        ("j_sparse", "J_SPARSE", "-", STATE, "-", "J's sparse LU, that of J^T: pattern "
         "and pivots (`numerics.sparse_lu`, `sparse_factors`; empty when banded)"),
        ("j_map", "J_MAP", "-", CONFIG, "-", "where each De entry lands in it "
         "(`sparse_packing`)"),
        ("aug_sparse", "AUG_SPARSE", "-", STATE, "-", "the augmented system's sparse LU"),
        ("aug_map", "AUG_MAP", "-", CONFIG, "-", "where each mass and De entry lands in it"),
    )),
    *_slots(FLOAT, "factors", (
        ("lu", "LU", "j_band", STATE, "1, m", "J's banded LU in its band storage "
         "(`numerics.banded.layout`; also the sparse one's fallback)"),
        ("augmented", "AUG", "a_band", STATE, "kg, 1", "the augmented system's banded LU "
         "in its band storage"),
        ("augmented_rhs", "AUG_RHS", "naug", STATE, "N, m/s^2", "its right-hand side and "
         "solution"),
        ("band_scratch", "BAND_SCRATCH", "naug", SCRATCH, "-", "a banded solve's vector; "
         "the pivot ratios"),
        ("refinement", "REFINEMENT", "2 * nx + 3 * naug", SCRATCH, "-", "the augmented "
         "solve refined with kept factors (`refinement`): its right-hand side, iterate and "
         "correction, then the accelerations and force on x of a mass product"),
        ("j_sparse_values", "J_SPARSE_VALUES", "-", STATE, "1, m", "J's sparse LU's values"),
        ("aug_sparse_values", "AUG_SPARSE_VALUES", "-", STATE, "kg, 1", "the augmented "
         "system's sparse LU's values"),
    )),
    *_slots(INT, "prescribed", (
        ("prescribed", "PRESCRIBED", "nki", CONFIG, "-", "each kinematic input's position in "
         "q (`Model.prescribed_dofs`)"),
        ("prescribed_pivots", "PRESCRIBED_PIVOTS", "nki", STATE, "-", "the pivots of the "
         "efforts' matrix's LU"),
    )),
    *_slots(FLOAT, "prescribed", (
        ("motion_path", "MOTION_PATH", "path_width * nki", STATE, "s, m, rad", "per kinematic "
         "input its path: start and end time, then the coefficients of a quintic in t - start "
         "(`prescribed`; written by the simulator)"),
        ("efforts", "EFFORTS", "nki", STATE, "N, N m", "the efforts of the last evaluation"),
        ("prescribed_columns", "PRESCRIBED_COLUMNS", "ndof * nki", STATE, "1/kg", "M_bar^-1 E "
         "(ndof, nki), E the inputs' unit columns"),
        ("prescribed_schur", "PRESCRIBED_SCHUR", "nki * nki", STATE, "1/kg", "the LU of "
         "E^T M_bar^-1 E"),
        ("prescribed_scratch", "PRESCRIBED_SCRATCH", "ndof + nki", SCRATCH, "-", "the "
         "velocities with the inputs' rates; a vector on the inputs"),
    )),
    *_slots(INT, "rigid", (
        ("rigid_slaves", "RIGID_SLAVES", "slave_width * nslaves", CONFIG, "-", "per slave "
         "node: kind, own, master translation and rotation coordinates (`rigid`)"),
        ("slave_index", "SLAVE_INDEX", "nx", CONFIG, "-", "per coordinate: its row among the "
         "slave coordinates, or -1"),
        ("rigid_dependencies", "RIGID_DEPS", "dependencies * nsc", CONFIG, "-", "per slave "
         "coordinate: its master coordinates"),
        ("rigid_element_of", "RIGID_ELEMENT_OF", "-", CONFIG, "-", "per packed element: its "
         "touching index, or -1"),
        ("rigid_elements", "RIGID_ELEMENTS", "-", CONFIG, "-", "per touching element its "
         "row (`rigid.ELEMENT_WIDTH`)"),
        ("rigid_z", "RIGID_Z", "-", CONFIG, "-", "the touching elements' z-coordinates"),
        ("rigid_terms", "RIGID_TERMS", "-", CONFIG, "-", "T_e's terms per touching element"),
        ("rigid_units", "RIGID_UNITS", "nxdof", CONFIG, "-", "per DOF coordinate: its slave "
         "coordinate row, or -1"),
        ("rigid_coordinates", "RIGID_COORDS", "nsc", CONFIG, "-", "the slave coordinates"),
        ("touching_rows", "TOUCHING_ROWS", "-", CONFIG, "-", "the touching elements' rows "
         "of J: (row, touching index, deformation), flat"),
        ("rigid_bodies", "RIGID_BODIES", "-", CONFIG, "-", "per folded spatial cluster: its "
         "master's coordinates, its carrier element and the places in its z "
         "(`rigid_inertia`)"),
    )),
    *_slots(FLOAT, "rigid", (
        ("rigid_data", "RIGID_DATA", "rigid_data_width * nslaves", CONFIG, "m, 1", "per "
         "slave node its constants (`RigidLayout.data`)"),
        ("rigid_body_tensors", "RIGID_BODY_TENSORS", "-", CONFIG, "kg, kg m, kg m^2, N",
         "per folded spatial cluster its mass tensors and gravity (`rigid_inertia`)"),
        ("rigid_weights", "RIGID_WEIGHTS", "dependencies * nsc", STATE, "1, m", "T's "
         "weights at the last configuration"),
        ("rigid_de", "RIGID_DE", "-", STATE, "1, m", "the touching elements' De T_e"),
        ("rigid_c", "RIGID_C", "nx if nsc else 0", STATE, "m/s^2", "the slaves' convective "
         "accelerations c(zdot)"),
        ("rigid_h", "RIGID_H", "nfree if nsc else 0", SCRATCH, "-", "a vector on z"),
        ("rigid_force", "RIGID_FORCE", "nx if nsc else 0", SCRATCH, "N", "r - M c"),
        ("rigid_local", "RIGID_LOCAL", "-", SCRATCH, "-", "a touching element's Dp_z, "
         "Mp Dp_z, Me_z and T_e"),
    )),
    *_slots(INT, "newton", (
        ("newton_j", "NEWTON_J", "-", STATE, "-", "the sparse Newton matrix's own sparse LU "
         "of J (`newton`; empty on the dense path)"),
        ("newton_j_map", "NEWTON_J_MAP", "-", CONFIG, "-", "where each De entry and unit row "
         "lands in it"),
        ("newton_h", "NEWTON_H", "-", STATE, "-", "the sparse LU of [H J_o^T; J_o 0]"),
        ("newton_h_map", "NEWTON_H_MAP", "-", CONFIG, "-", "where each free coordinate's "
         "diagonal, rigid-row De entry (below, beside) and element pair lands in it"),
        ("newton_stress_row", "NEWTON_STRESS_ROW", "-", CONFIG, "-", "per deformation its row "
         "among the stressed ones, or -1"),
        ("newton_port_map", "NEWTON_PORT_MAP", "-", CONFIG, "-", "per input the slots of its "
         "Euler parameters' 4 x 4 pairs, or -1"),
    )),
    *_slots(FLOAT, "newton", (
        ("newton_j_values", "NEWTON_J_VALUES", "-", STATE, "1, m", "its J's values and LU at "
         "the Newton matrix's state"),
        ("newton_h_values", "NEWTON_H_VALUES", "-", STATE, "kg, 1", "H's values and LU"),
        ("newton_parts", "NEWTON_PARTS", "-", STATE, "kg, N s/m, N/m", "M (with J_o), C_x, "
         "K_x on H's pattern, one after the other"),
        ("newton_scratch", "NEWTON_SCRATCH", "-", SCRATCH, "-", "three vectors on the "
         "augmented system's unknowns, then a touching element's T_e, K_e T_e, C_e T_e"),
    )),
)

# fmt: on

INT_SLOTS = tuple(s.name for s in SLOTS if s.dtype == INT)
FLOAT_SLOTS = tuple(s.name for s in SLOTS if s.dtype == FLOAT)
BY_NAME = {s.name: s for s in SLOTS}
PACKERS = tuple(dict.fromkeys(s.packer for s in SLOTS))
RECORDS = {"dims": DIMS_FIELDS, "groups": GROUP_FIELDS, "counters": COUNTER_FIELDS,
           "settings": SETTINGS_FIELDS}


def table_problems():
    """The problems of the tables themselves, as messages (empty: none): a name or an index
    constant used twice (two slots would share an index), an unknown dtype or role."""
    problems = []
    for what, entries in (("slot", SLOTS), *((f"{name} field", fields)
                                             for name, fields in RECORDS.items())):
        for column in ("name", "constant"):
            values = [getattr(entry, column) for entry in entries]
            twice = sorted({v for v in values if values.count(v) > 1})
            problems += [f"{what} {column} {v!r} used twice" for v in twice]
    constants = [f.constant for fields in RECORDS.values() for f in fields]
    problems += [f"field constant {c!r} used twice" for c in sorted(
        {c for c in constants if constants.count(c) > 1})]
    problems += [f"slot {s.name!r}: unknown dtype {s.dtype!r}" for s in SLOTS
                 if s.dtype not in (INT, FLOAT)]
    problems += [f"{e.name!r}: unknown role {e.role!r}" for e in SLOTS + sum(
        RECORDS.values(), ()) if e.role not in (CONFIG, STATE, SCRATCH, MIXED)]
    return problems


def slot_indices():
    """{index constant: the slot's index among the slots of its dtype}: the constants that
    `slots` defines (compile-time ints for numba)."""
    out = {}
    for names in (INT_SLOTS, FLOAT_SLOTS):
        out.update({BY_NAME[name].constant: i for i, name in enumerate(names)})
    return out


def field_indices():
    """{index constant: the field's index in its record}, for every record, with each
    record's width (DIMS_SIZE, G_WIDTH, COUNTERS_SIZE, SETTINGS_SIZE): what `data` defines."""
    out = {"DIMS_SIZE": len(DIMS_FIELDS), "G_WIDTH": len(GROUP_FIELDS),
           "COUNTERS_SIZE": len(COUNTER_FIELDS), "SETTINGS_SIZE": len(SETTINGS_FIELDS)}
    for fields in RECORDS.values():
        out.update({f.constant: i for i, f in enumerate(fields)})
    return out


def field_index(record_name, name):
    """The index of field `name` in record `record_name` ("dims", "groups", ...)."""
    return [f.name for f in RECORDS[record_name]].index(name)


def names(role, dtype=None):
    """The names of the slots of `role` (CONFIG, STATE, SCRATCH, MIXED), of one dtype or
    both, in table order."""
    return tuple(s.name for s in SLOTS if s.role == role and dtype in (None, s.dtype))


def record(record_name, **values):
    """An int64 record of `record_name` ("dims", "groups", "counters") filled by field name;
    fields not given are 0. LayoutError for a name that is not one of its fields."""
    fields = RECORDS[record_name]
    position = {f.name: i for i, f in enumerate(fields)}
    unknown = sorted(set(values) - set(position))
    if unknown:
        raise LayoutError(f"{record_name}: expected fields of {[f.name for f in fields]}, "
                          f"got {unknown}")
    out = np.zeros(len(fields), dtype=np.float64 if record_name == "settings" else np.int64)
    for name, value in values.items():
        out[position[name]] = value
    return out


def markdown():
    """The slot table as Markdown (`python -m flexure.core.engine.layout`)."""
    lines = ["| slot | dtype | constant | size | role | packed by | unit | meaning |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {s.name} | {s.dtype} | {s.constant} | {s.size} | {s.role} | {s.packer} | "
              f"{s.unit} | {s.meaning} |" for s in SLOTS]
    for record_name, fields in RECORDS.items():
        lines += ["", f"| {record_name} field | constant | role | meaning |", "|---|---|---|---|"]
        lines += [f"| {f.name} | {f.constant} | {f.role} | {f.meaning} |" for f in fields]
    return "\n".join(lines)


if table_problems():  # never generate constants from a table that gives two slots one index
    raise LayoutError("the layout tables: " + "; ".join(table_problems()))


if __name__ == "__main__":
    print(markdown())
