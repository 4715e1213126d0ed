"""The packed model's arrays as compiled code reads them: slot indices and accessors.

`data.EngineData` packs a model into int64 and float64 arrays in the order of the layout
table (`layout.SLOTS`), and lists (address, length) of each in one address table. The
engine's modules take every array they read or write from that table's address, through
`int_array` and `float_array` with the slot indices defined here: one module-level int per
slot, named by the table's `constant` column (`X` is slot "x", `DF` "DF", `AUG`
"augmented", `RIGID_DEPS` "rigid_dependencies"), generated from the table. numba reads a
module's global ints when it compiles a kernel and freezes them into the code as literals,
so an index costs nothing at run time (and a change to the table changes the sources' hash,
which starts a fresh compiled cache: `numerics.jit`). The arrays of one element group come
through `group` and `group_deformations`. Nothing here computes; units are those of the
arrays (SI, as the model's).
"""

from ..numerics.jit import CompiledName, kernel
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


def _slot_array(dtype, first):
    """An intrinsic (table, slot) -> the 1-D C array of `dtype` of entry first + slot of the
    packed model's address table at `table`: (address, length) pairs, ints first.

    An intrinsic, not a kernel: it emits the two loads and the array's fields in its caller.
    As a kernel each of its ~120 callers linked its module and numba compiled it as a unit
    of its own (its fixed cost, about 0.1 s of CPU, twice: `int_array` and `float_array`);
    the machine code is the same (LLVM inlined the kernel everywhere)."""
    from llvmlite import ir
    from numba import types
    from numba.extending import intrinsic

    array_type = types.Array(dtype, 1, "C")

    @intrinsic
    def accessor(typingctx, table, slot):
        if not (isinstance(table, types.Integer) and isinstance(slot, types.Integer)):
            return None
        constant = getattr(slot, "literal_value", None)  # a slot constant: a fixed offset

        def codegen(context, builder, signature, args):
            from numba.np.arrayobj import make_array, populate_array

            i64 = ir.IntType(64)
            entries = builder.inttoptr(args[0], i64.as_pointer())
            if constant is not None:
                k = ir.Constant(i64, 2 * (first + constant))
            else:
                index = context.cast(builder, args[1], signature.args[1], types.int64)
                k = builder.mul(builder.add(index, ir.Constant(i64, first)), ir.Constant(i64, 2))
            address = builder.load(builder.gep(entries, [k]))
            length = builder.load(builder.gep(entries, [builder.add(k, ir.Constant(i64, 1))]))
            item = context.get_data_type(dtype)
            itemsize = ir.Constant(i64, context.get_abi_sizeof(item))
            array = make_array(array_type)(context, builder)
            populate_array(array, data=builder.inttoptr(address, item.as_pointer()),
                           shape=[length], strides=[itemsize], itemsize=itemsize, meminfo=None)
            return array._getvalue()  # no meminfo: the packed model owns the memory

        return array_type(table, slot), codegen

    return accessor


def _accessor(dtype_name, first):
    def make():
        from numba import types

        return _slot_array(getattr(types, dtype_name), first)

    return CompiledName(make, f"{dtype_name}_array")


# intrinsics made when numba first types code that calls them (`jit.CompiledName`)
int_array, float_array = _accessor("int64", 0), _accessor("float64", _N_INT)
int_array.__doc__ = """The int64 array of `slot` (an index of layout.INT_SLOTS) of the packed
model whose table is at the address `table` (int64); for any compiled code that holds that
address (an intrinsic: compiled code only)."""
float_array.__doc__ = """The float64 array of `slot` (an index of layout.FLOAT_SLOTS), as
`int_array`."""


# -- one element group's arrays ------------------------------------------------------------------
@kernel
def group(table, g):
    """The row of element group g in slot groups (ed.G_WIDTH entries: ed.G_COUNT, ...)."""
    groups = int_array(table, _GROUPS)
    return groups[g * ed.G_WIDTH: (g + 1) * ed.G_WIDTH]


@kernel(inline="always")
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
