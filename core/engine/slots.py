"""The packed model's arrays as compiled code reads them: slot indices and accessors.

`data.EngineData` packs a model into int64 and float64 arrays in the order of the layout
table (`layout.SLOTS`), and lists (address, length) of each in one address table. The
engine's modules take every array they read or write from that table's address, through
`int_array` and `float_array` with the slot indices defined here: one module-level int per
slot, named by the table's `constant` column (`X` is slot "x", `DF` "DF", `DEF` "DeF", `AUG`
"augmented", `RIGID_DEPS` "rigid_dependencies"), generated from the table. numba reads a
module's global ints when it compiles a kernel and freezes them into the code as literals,
so an index costs nothing at run time (and a change to the table changes the sources' hash,
which starts a fresh compiled cache: `numerics.jit`). The arrays of one element group come
through `group` and `group_deformations`. Nothing here computes; units are those of the
arrays (SI, as the model's).
"""

from numba import carray

from ..numerics.jit import kernel
from ..numerics.native import as_float_pointer, as_int_pointer
from . import data as ed
from . import layout

# slot indices as compile-time constants: DIMS, FREE, ..., X, X_START, ... (layout.SLOTS)
globals().update(layout.slot_indices())
_INDEX = layout.slot_indices()
_DIMS, _GROUPS, _COORD_INDEX, _DEF_INDEX, _RIGID_ELEMENT_OF, _MASS_PATTERN = (
    _INDEX[c] for c in ("DIMS", "GROUPS", "COORD_INDEX", "DEF_INDEX", "RIGID_ELEMENT_OF",
                        "MASS_PATTERN"))
_DE, _D2E, _GROUP_DATA, _LOCAL = (_INDEX[c] for c in ("DE", "D2E", "GROUP_DATA", "LOCAL"))
_N_INT, _N_FLOAT = len(layout.INT_SLOTS), len(layout.FLOAT_SLOTS)


# -- the packed model's arrays, from the address of its table ------------------------------------
# Every function takes the table's address (`table`, int64) and takes from it the arrays it
# uses: passing the arrays themselves from call to call made each call copy hundreds of
# values, and the compiled code ten times larger.
_TABLE_SIZE = 2 * (_N_INT + _N_FLOAT)


@kernel
def int_array(table, slot):
    """The int64 array of `slot` (an index of layout.INT_SLOTS) of the packed model whose
    table is at the address `table` (int64); for any compiled code that holds that address."""
    entries = carray(as_int_pointer(table), (_TABLE_SIZE,))
    return carray(as_int_pointer(entries[2 * slot]), (entries[2 * slot + 1],))


@kernel
def float_array(table, slot):
    """The float64 array of `slot` (an index of layout.FLOAT_SLOTS), as `int_array`."""
    entries = carray(as_int_pointer(table), (_TABLE_SIZE,))
    k = 2 * (_N_INT + slot)
    return carray(as_float_pointer(entries[k]), (entries[k + 1],))


# -- one element group's arrays ------------------------------------------------------------------
@kernel
def group(table, g):
    """The row of element group g in slot groups (ed.G_WIDTH entries: ed.G_COUNT, ...)."""
    groups = int_array(table, _GROUPS)
    return groups[g * ed.G_WIDTH: (g + 1) * ed.G_WIDTH]


@kernel
def group_coordinates(table, row):
    """The model indices of the coordinates of the group with the row `row` (`group`), flat,
    element by element (n m entries)."""
    start = row[ed.G_COORD_OFFSET]
    return int_array(table, _COORD_INDEX)[start: start + row[ed.G_COUNT] * row[ed.G_M]]


@kernel
def group_deformations(table, g):
    """(n, m, k, coords, defs, De, D2e) of element group g: its element count, coordinates and
    deformations per element, their model indices (flat, element by element) and the elements'
    De and D2e of the last evaluation (flat)."""
    row = group(table, g)
    n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
    coords = group_coordinates(table, row)
    defs = int_array(table, _DEF_INDEX)[row[ed.G_DEF_OFFSET]: row[ed.G_DEF_OFFSET] + n * k]
    De = float_array(table, _DE)[row[ed.G_DE_OFFSET]: row[ed.G_DE_OFFSET] + n * k * m]
    D2e = float_array(table, _D2E)[row[ed.G_D2E_OFFSET]: row[ed.G_D2E_OFFSET] + n * k * m * m]
    return n, m, k, coords, defs, De, D2e


@kernel
def rigid_element(table, row, i):
    """The touching index of element i of the group with the row `row` (`rigid`), or -1."""
    return int_array(table, _RIGID_ELEMENT_OF)[row[ed.G_ELEMENT_OFFSET] + i]


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
    data = float_array(table, _GROUP_DATA)
    m, P = row[ed.G_M], row[ed.G_P]
    n = row[ed.G_COUNT] if P > 0 else 0  # no element to visit without inertia points
    masses = data[row[ed.G_MASS_OFFSET]: row[ed.G_MASS_OFFSET] + n * P * P]
    gravity = data[row[ed.G_GRAVITY_OFFSET]: row[ed.G_GRAVITY_OFFSET] + P]
    start = row[ed.G_PATTERN_OFFSET]
    pattern = int_array(table, _MASS_PATTERN)[start: start + row[ed.G_PATTERN_COUNT]]
    return (n, m, P, row[ed.G_REF_WIDTH], row[ed.G_INERTIA_ENTRY], group_coordinates(table, row),
            data.ctypes.data + 8 * row[ed.G_DATA_OFFSET], masses, gravity, pattern)


@kernel
def inertia_scratch(table, base, P, m):
    """The element-local buffers of an inertia evaluation in slot local from entry `base`:
    (x, v (max_m each), the point values, acc, w (max_p each), Dp (P, m) in room for max_p
    max_m, and the first entry after that room)."""
    dims = int_array(table, _DIMS)
    local = float_array(table, _LOCAL)
    max_m, max_p = dims[ed.MAX_M], dims[ed.MAX_P]
    o = base + 2 * max_m
    Dp = local[o + 3 * max_p: o + 3 * max_p + P * m].reshape((P, m))
    return (local[base: base + max_m], local[base + max_m: o], local[o: o + max_p],
            local[o + max_p: o + 2 * max_p], local[o + 2 * max_p: o + 3 * max_p], Dp,
            o + 3 * max_p + max_p * max_m)
