"""The packed model's arrays as compiled code reads them: slot indices and accessors.

`data.EngineData` packs a model into int64 and float64 arrays in the fixed order of
`INT_SLOTS` and `FLOAT_SLOTS`, and lists (address, length) of each in one address table. The
engine's modules take every array they read or write from that table's address, through
`int_array` and `float_array` with the slot indices below (compile-time constants, named as
the slots they index: `DIMS` is "dims", `DF` is "DF", `AUG` is "augmented", `RIGID_DEPS`
"rigid_dependencies", `RIGID_COORDS` "rigid_coordinates"), and the arrays
of one element group through `group` and `group_deformations`. Nothing here computes; units
are those of the arrays (SI, as the model's).
"""

from numba import carray

from ..numerics.jit import kernel
from ..numerics.native import as_float_pointer, as_int_pointer
from . import data as ed

# slot indices as compile-time constants
(DIMS, FREE, ROWS, DOF_COORDS, DOF_DEFS, DOF_POS, STRESSED, INPUT_PORTS, GROUPS,
 COORD_INDEX, DEF_INDEX, ROW_OF_DEF, COL_OF_COORD, PIVOTS, MASS_PIVOTS,
 COUNTERS, AUG_PIVOTS, J_ROW_POS, J_COL_POS, AUG_POS, MASS_PATTERN,
 POINT_COLUMNS, J_SPARSE, J_MAP, AUG_SPARSE, AUG_MAP, STRESS_POINTERS,
 STRESS_COLUMNS, ACTUATORS, RIGID_SLAVES, SLAVE_INDEX, RIGID_DEPS, RIGID_ELEMENT_OF,
 RIGID_ELEMENTS, RIGID_Z, RIGID_TERMS, RIGID_UNITS, RIGID_COORDS,
 TOUCHING_ROWS) = range(len(ed.INT_SLOTS))
(SETTINGS, S, D, LUMPED, CONST_FORCE, GROUP_DATA, INPUTS, Q_REF, X, Q, DF, LU,
 E, DE, D2E, X_TRIAL, G, DX, XDOT, EDOT, SIGMA, FORCE, MASS, MASS_LU,
 REDUCED_FORCE, QDDOT, CONV, LOCAL, DEF, STIFFNESS, DAMPING, JAC_CACHE,
 X_START, XDDOT, AUG, AUG_RHS, BAND_SCRATCH, J_SPARSE_VALUES,
 AUG_SPARSE_VALUES, ACTUATOR_DATA, CURRENTS, PORT_VALUES, RIGID_DATA, RIGID_WEIGHTS,
 RIGID_DE, RIGID_C, RIGID_H, RIGID_FORCE, RIGID_LOCAL, EVALUATED_INPUTS, ROW_TOLERANCE,
 STEP_TOLERANCE) = range(
    len(ed.FLOAT_SLOTS))
_N_INT, _N_FLOAT = len(ed.INT_SLOTS), len(ed.FLOAT_SLOTS)


# -- the packed model's arrays, from the address of its table ------------------------------------
# Every function takes the table's address (`table`, int64) and takes from it the arrays it
# uses: passing the arrays themselves from call to call made each call copy hundreds of
# values, and the compiled code ten times larger.
_TABLE_SIZE = 2 * (_N_INT + _N_FLOAT)


@kernel
def int_array(table, slot):
    """The int64 array of `slot` (an index of data.INT_SLOTS) of the packed model whose
    table is at the address `table` (int64); for any compiled code that holds that address."""
    entries = carray(as_int_pointer(table), (_TABLE_SIZE,))
    return carray(as_int_pointer(entries[2 * slot]), (entries[2 * slot + 1],))


@kernel
def float_array(table, slot):
    """The float64 array of `slot` (an index of data.FLOAT_SLOTS), as `int_array`."""
    entries = carray(as_int_pointer(table), (_TABLE_SIZE,))
    k = 2 * (_N_INT + slot)
    return carray(as_float_pointer(entries[k]), (entries[k + 1],))


# -- one element group's arrays ------------------------------------------------------------------
@kernel
def group(table, g):
    """The row of element group g in slot groups (ed.G_WIDTH entries: ed.G_COUNT, ...)."""
    groups = int_array(table, GROUPS)
    return groups[g * ed.G_WIDTH: (g + 1) * ed.G_WIDTH]


@kernel
def group_coordinates(table, row):
    """The model indices of the coordinates of the group with the row `row` (`group`), flat,
    element by element (n m entries)."""
    start = row[ed.G_COORD_OFFSET]
    return int_array(table, COORD_INDEX)[start: start + row[ed.G_COUNT] * row[ed.G_M]]


@kernel
def group_deformations(table, g):
    """(n, m, k, coords, defs, De, D2e) of element group g: its element count, coordinates and
    deformations per element, their model indices (flat, element by element) and the elements'
    De and D2e of the last evaluation (flat)."""
    row = group(table, g)
    n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
    coords = group_coordinates(table, row)
    defs = int_array(table, DEF_INDEX)[row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
    De = float_array(table, DE)[row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
    D2e = float_array(table, D2E)[row[ed.G_D2E_OFFSET]: row[ed.G_D2E_OFFSET] + n * k * m * m]
    return n, m, k, coords, defs, De, D2e


@kernel
def rigid_element(table, row, i):
    """The touching index of element i of the group with the row `row` (`rigid`), or -1."""
    return int_array(table, RIGID_ELEMENT_OF)[row[ed.G_ELEMENT_OFFSET] + i]


@kernel
def group_inertia(table, g):
    """(n, m, P, width, entry, coords, refs, masses, gravity, pattern) of element group g: n
    the count of its elements to visit for inertia (all of them, or 0 when they have no
    inertia points, P = 0; not an offset into the group's other arrays), its coordinates per
    element, inertia points per element, reference width, inertia entry point, coordinate
    indices (`group_coordinates`), the address of its packed reference rows, the elements'
    Mp (n P P, flat, element by element), gravity on the points (P,) and the flat indices
    p P + q of the entries of Mp that the group's elements fill, ascending (all three empty
    when P = 0)."""
    row = group(table, g)
    data = float_array(table, GROUP_DATA)
    m, P = row[ed.G_M], row[ed.G_P]
    n = row[ed.G_COUNT] if P > 0 else 0  # no element to visit without inertia points
    masses = data[row[ed.G_MASS_OFFSET]: row[ed.G_MASS_OFFSET] + n * P * P]
    gravity = data[row[ed.G_GRAVITY_OFFSET]: row[ed.G_GRAVITY_OFFSET] + P]
    start = row[ed.G_PATTERN_OFFSET]
    pattern = int_array(table, MASS_PATTERN)[start: start + row[ed.G_PATTERN_COUNT]]
    return (n, m, P, row[ed.G_REF_WIDTH], row[ed.G_INERTIA_ENTRY], group_coordinates(table, row),
            data.ctypes.data + 8 * row[ed.G_DATA_OFFSET], masses, gravity, pattern)


@kernel
def inertia_scratch(table, base, P, m):
    """The element-local buffers of an inertia evaluation in slot local from entry `base`:
    (x, v (max_m each), the point values, acc, w (max_p each), Dp (P, m) in room for max_p
    max_m, and the first entry after that room)."""
    dims = int_array(table, DIMS)
    local = float_array(table, LOCAL)
    max_m, max_p = dims[ed.MAX_M], dims[ed.MAX_P]
    o = base + 2 * max_m
    Dp = local[o + 3 * max_p: o + 3 * max_p + P * m].reshape((P, m))
    return (local[base: base + max_m], local[base + max_m: o], local[o: o + max_p],
            local[o + max_p: o + 2 * max_p], local[o + 2 * max_p: o + 3 * max_p], Dp,
            o + 3 * max_p + max_p * max_m)
