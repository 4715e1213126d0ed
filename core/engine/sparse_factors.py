"""The sparse factorisations of J and the augmented system, compiled only for models that use
them.

A model whose J or augmented system is factored with the static-pivot sparse LU
(`numerics.sparse_lu`; chosen at packing, dims J_SPARSE and A_SPARSE, `factors`) reaches it
through two operations of the engine, `factor` and `solve`, each the body of its C entry
(`engine.ENTRIES`); `factors` calls them through their addresses (`run`), so a model that
factors banded, as the stages do, never compiles the sparse LU. `engine.connect` adds them for
the models that need them. Which factors: SPARSE_J, SPARSE_J_TRANSPOSED (solves only) and
SPARSE_AUGMENTED (`operations`).

J's LU is that of J^T (`sparse_packing.SparseFactors.kinematic`), and a solve with J is the
transposed solve with it: on manipulator_reduced (order 952) the LU of J^T takes 20316
multiplications against J's 33194, its refactor 33 to 35 us against 53 to 57 and a solve 10.2
to 10.5 against 14.0 to 14.6 (docs/benchmarks.md, session 41). The left-looking LU spends its
time per entry of U, each a pass over a column of L: J's U holds 2.8 times its L's entries
(short columns of L, many passes), J^T's the reverse.
"""

from ..mechanics.rigid_bodies import DEPENDENCIES
from ..numerics import banded, sparse_lu
from ..numerics.jit import kernel
from ..numerics.sparse_lu import unsigned_index as _u
from . import data as ed
from . import slots as slot
from .factors import scatter_de
from .operations import SPARSE_AUGMENTED, SPARSE_J_TRANSPOSED
from .rigid_kernels import row_de_z
from .slots import float_array as _f
from .slots import int_array as _i


@kernel(inline="always")  # into its operation's entry, its one caller
def factor(table, which, out):
    """Factor the sparse LU of J (which = SPARSE_J, from the elements' De: the LU of J^T) or of
    the augmented system (SPARSE_AUGMENTED, assembled by `motion`): out[0] = the pivot ratio,
    negative when the sparse LU cannot serve, and then the values are in the band storage
    (slot lu, slot augmented) for the banded LU."""
    dims = _i(table, slot.DIMS)
    if which == SPARSE_AUGMENTED:
        ints, floats = _i(table, slot.AUG_SPARSE), _f(table, slot.AUG_SPARSE_VALUES)
        band, rows = _f(table, slot.AUG), _i(table, slot.AUG_POS)
        columns = rows
        n, kl, ku = dims[ed.NFREE] + dims[ed.NRIGID], dims[ed.A_KL], dims[ed.A_KU]
    else:
        ints, floats = _i(table, slot.J_SPARSE), _f(table, slot.J_SPARSE_VALUES)
        constraint_values(table, _i(table, slot.J_MAP), sparse_lu.matrix_values(ints, floats))
        band, rows = _f(table, slot.LU), _i(table, slot.J_ROW_POS)
        columns = _i(table, slot.J_COL_POS)
        n, kl, ku = dims[ed.NFREE], dims[ed.J_KL], dims[ed.J_KU]
    out[0] = _factor(table, ints, floats)
    if out[0] < 0.0:  # the values into the banded LU's storage (`banded.layout`)
        band[:] = 0.0
        step, shift = banded.layout(band.size, n, kl, ku)
        # J's LU is J^T's: its values scattered as J's entries
        sparse_lu.scatter_rows(ints, floats, band, rows, columns, step, shift,
                               which != SPARSE_AUGMENTED)


@kernel(inline="always")  # into its operation's entry, its one caller
def solve(table, which, b):
    """b <- A^-1 b in place with the sparse factors of the last `factor` of A: J (which =
    SPARSE_J; b (n_free,) on J's rows in, on the free coordinates out), J^T
    (SPARSE_J_TRANSPOSED) or the augmented system (SPARSE_AUGMENTED; b (n_free + n_rigid,))."""
    if which == SPARSE_AUGMENTED:
        sparse_lu.solve(_i(table, slot.AUG_SPARSE), _f(table, slot.AUG_SPARSE_VALUES), b, False)
    else:  # with the LU of J^T: J's solve is its transposed one
        sparse_lu.solve(_i(table, slot.J_SPARSE), _f(table, slot.J_SPARSE_VALUES), b,
                        which != SPARSE_J_TRANSPOSED)


@kernel
def _factor(table, ints, floats):
    """The sparse LU with the kept pivots, else pivoting afresh (counted); the pivot ratio, or
    negative when the sparse LU cannot serve (counted: the caller factors banded)."""
    ratio = sparse_lu.refactor(ints, floats, sparse_lu.THRESHOLD)
    if ratio >= 0.0:
        return ratio
    counters = _i(table, slot.COUNTERS)
    counters[ed.SPARSE_PIVOTING] += 1
    ratio = sparse_lu.factor(ints, floats, sparse_lu.THRESHOLD)
    if ratio < 0.0:
        counters[ed.SPARSE_FALLBACKS] += 1
    return ratio


@kernel
def constraint_values(table, jmap, values):
    """J's sparse values from the elements' De in slot de (with rigid clusters: the touching
    elements' De_z in slot rigid_de and T's rows on the DOF coordinates of slaves) through
    jmap, a J map (`sparse_packing.SparseFactors.constraint_map`: slot j_map, or the Newton
    matrix's copy). Of rigid_de it visits the rows of J (slot touching_rows), the only rows
    `rigid_kernels.rigid_de` forms and a J map points into (on manipulator_control 630 of
    its 4788 entries)."""
    De = _f(table, slot.DE)
    dims = _i(table, slot.DIMS)
    values[:] = 0.0
    n_de, n_xdof = De.size, dims[ed.NXDOF]
    scatter_de(table, De, jmap, 0, -1, values)
    for j in range(n_xdof):
        s = jmap[n_de + j]
        if s >= 0:
            values[s] = 1.0
    if dims[ed.NSLAVES] == 0:
        return
    rde, base = _f(table, slot.RIGID_DE), n_de + n_xdof
    rows, elements = _i(table, slot.TOUCHING_ROWS), _i(table, slot.RIGID_ELEMENTS)
    for j in range(rows.size // 3):  # each row's mz entries
        _, _, mz, at = row_de_z(rows, elements, j)
        for c in range(at, at + mz):  # unsigned indices: no test for one from the end
            s = jmap[_u(base + c)]
            if s >= 0:
                values[_u(s)] += rde[_u(c)]
    base += rde.size
    units, W = _i(table, slot.RIGID_UNITS), _f(table, slot.RIGID_WEIGHTS)
    for j in range(n_xdof):
        if units[j] < 0:
            continue
        for d in range(DEPENDENCIES):
            s = jmap[base + DEPENDENCIES * j + d]
            if s >= 0:
                values[s] += W[units[j] * DEPENDENCIES + d]
