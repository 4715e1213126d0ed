"""The engine's two factorisations: the constraint Jacobian J and the augmented system.

J (n_free, n_free: the rows of the rigid and DOF deformations, then the unit rows of the DOF
coordinates) and the augmented system of the accelerations [M_ff J_o^T; J_o 0] (n_free +
n_rigid) are each factored one of two ways, chosen per model at packing
(`data.evaluation_cost`, dims J_SPARSE and A_SPARSE):

- banded (`numerics.banded`): the matrix assembled in the band storage of `banded.layout`
  (compact rows of 2 kl + ku + 1, or dense (n, n) where the band is wider than a third of n)
  in the bandwidth-reducing order (slots j_row_position, j_column_position,
  augmented_position) and factored with partial pivoting in the band: the small models (the
  stages, the tutorials), the cantilevers' augmented system;
- sparse (`numerics.sparse_lu`): the elements' entries scattered straight into the sparse
  values through the maps of `sparse_packing` and refactored with the kept pivots; no dense
  band storage is touched. When a kept pivot fails its threshold test the sparse LU
  pivots afresh (counted in counters[SPARSE_PIVOTING]) and keeps the new pivots; when that
  fails too (a singular matrix, or more fill than the room packed for it) the values go into
  the band storage and that one factorisation is banded (counters[SPARSE_FALLBACKS]).
  dims[J_FACTORS] says which factors of J are current.

Both solve in the model's order: `j_solve` takes vectors on J's rows (or, transposed, on the
free coordinates), `augmented_solve` on the free coordinates then the rigid rows.

The augmented system's factors outlive its state: dims[A_FACTORS] says whether they are of
the last evaluation's state, dims[A_KEPT] whether the storage holds the factors of some
earlier one (KEPT_SPARSE, KEPT_BANDED), which `refinement` solves the current state's
system with. A new factorisation overwrites them (KEPT_NONE until it succeeds), and so
does a banded assembly, which clears slot augmented; a sparse assembly writes only the
matrix's values, not its LU.
"""

import numpy as np

from ..mechanics.rigid_bodies import DEPENDENCIES
from ..numerics import banded, sparse_lu
from ..numerics.jit import kernel
from . import data as ed
from . import slots as slot
from .operations import (
    OP_RIGID_DE,
    OP_SPARSE_FACTOR,
    OP_SPARSE_SOLVE,
    SPARSE_AUGMENTED,
    SPARSE_J,
    SPARSE_J_TRANSPOSED,
    run,
)
from .rigid_kernels import touching_row
from .slots import float_array as _f
from .slots import group, group_deformations, rigid_element
from .slots import int_array as _i

# dims[A_KEPT]: which factors of the augmented system at some earlier state are held
# (`refinement`); KEPT_NONE is 0, the value packing leaves
KEPT_NONE, KEPT_BANDED, KEPT_SPARSE = range(3)


@kernel
def _sparse_factor(table, which):
    """The sparse LU of J (which = SPARSE_J) or of the augmented system (SPARSE_AUGMENTED)
    through its operation (`sparse_factors.factor`, compiled only for models that use it);
    the pivot ratio, negative when it cannot serve (the values are then in the band
    storage for the banded LU), nan when `engine.connect` did not give its operation (the
    callers stop as on a singular matrix). The ratio comes back in the first entry of slot
    band_scratch, which the banded solves use only after a factorisation."""
    ratio = _f(table, slot.BAND_SCRATCH)
    if run(table, OP_SPARSE_FACTOR, ratio.ctypes.data, 0, float(which)) != ed.OK:
        return np.nan
    return ratio[0]


# -- J ---------------------------------------------------------------------------------------------
@kernel
def _constraint_jacobian(table, J):
    """J (n_free, n_free) into its band storage J (`banded.layout`) from the elements' De in
    slot de, its rows and columns in their banded order (slots j_row_position,
    j_column_position); zero only in its band (`clear_band`)."""
    dims = _i(table, slot.DIMS)
    nf = dims[ed.NFREE]
    clear_band(J, nf, dims[ed.J_KL], dims[ed.J_KU])
    step, shift = banded.layout(J.size, nf, dims[ed.J_KL], dims[ed.J_KU])
    rpos, cpos = _i(table, slot.J_ROW_POS), _i(table, slot.J_COL_POS)
    row_of_def, col_of_coord = _i(table, slot.ROW_OF_DEF), _i(table, slot.COL_OF_COORD)
    rigid = dims[ed.NSLAVES] > 0
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = group_deformations(table, g)
        row = group(table, g)
        for i in range(n):
            if rigid and rigid_element(table, row, i) >= 0:
                continue  # from its De_z below
            for b in range(k):
                r = row_of_def[defs[i * k + b]]
                if r < 0:
                    continue
                for a in range(m):
                    c = col_of_coord[coords[i * m + a]]
                    if c >= 0:
                        J[rpos[r] * step + shift + cpos[c]] = De[(i * k + b) * m + a]
    n_def = dims[ed.NRIGID] + dims[ed.NEDOF]
    positions = _i(table, slot.DOF_POS)
    units, W = _i(table, slot.RIGID_UNITS), _f(table, slot.RIGID_WEIGHTS)
    deps = _i(table, slot.RIGID_DEPS)
    for j in range(dims[ed.NXDOF]):
        if rigid and units[j] >= 0:  # x_s(z) = q: T's row
            for d in range(DEPENDENCIES):
                u = units[j] * DEPENDENCIES + d
                c = col_of_coord[deps[u]] if deps[u] >= 0 else -1
                if c >= 0:
                    J[rpos[n_def + j] * step + shift + cpos[c]] += W[u]
        else:
            J[rpos[n_def + j] * step + shift + cpos[positions[j]]] = 1.0
    if not rigid:
        return
    rde = _f(table, slot.RIGID_DE)
    for j in range(_i(table, slot.TOUCHING_ROWS).size // 3):
        r, coords, de, z, at = touching_row(table, j)
        for a in range(z.size):
            c = col_of_coord[z[a]]
            if c >= 0:
                J[rpos[r] * step + shift + cpos[c]] += rde[at + a]


@kernel
def scatter_de(table, De, emap, shift, mirror, out):
    """out[emap[shift + e]] = De[e] for the entries e of slot de (and, with mirror >= 0, the
    same at emap[mirror + e]: J_o^T beside J_o) where the map has a place (>= 0), skipping
    the elements that touch a rigid cluster: their entries come from their De_z."""
    dims = _i(table, slot.DIMS)
    rigid = dims[ed.NSLAVES] > 0
    for g in range(dims[ed.NGROUPS]):
        row = group(table, g)
        size, first = row[ed.G_K] * row[ed.G_M], row[ed.G_DE_OFFSET]
        for i in range(row[ed.G_COUNT]):
            if rigid and rigid_element(table, row, i) >= 0:
                continue
            for e in range(first + i * size, first + (i + 1) * size):
                s = emap[shift + e]
                if s >= 0:
                    out[s] = De[e]
                    if mirror >= 0:
                        out[emap[mirror + e]] = De[e]


@kernel
def j_factor(table):
    """J at the deformations' De factored (sparse, or banded in slot lu); the ratio of the
    smallest to the largest pivot magnitude."""
    dims = _i(table, slot.DIMS)
    lu, nf = _f(table, slot.LU), dims[ed.NFREE]
    if dims[ed.NSLAVES] > 0:
        run(table, OP_RIGID_DE, 0, 0, 0.0)
    if dims[ed.J_SPARSE] == 1:  # else (or when it cannot serve) in lu, J's band storage
        ratio = _sparse_factor(table, SPARSE_J)
        if not ratio < 0.0:  # its factors, or nan (not connected)
            dims[ed.J_FACTORS] = ed.SPARSE_FACTORS
            return ratio
    else:
        _constraint_jacobian(table, lu)
    dims[ed.J_FACTORS] = ed.BANDED_FACTORS
    return banded.factor(lu, nf, _i(table, slot.PIVOTS), dims[ed.J_KL], dims[ed.J_KU])


@kernel
def j_solve(table, b, transposed):
    """b <- J^-1 b (b on J's rows in, on the free coordinates out), or with transposed
    b <- J^-T b (on the free coordinates in, on J's rows out), both (n_free,), with the
    factors of the last `j_factor`."""
    dims = _i(table, slot.DIMS)
    if dims[ed.J_FACTORS] == ed.SPARSE_FACTORS:
        run(table, OP_SPARSE_SOLVE, b.ctypes.data, 0,
            float(SPARSE_J_TRANSPOSED if transposed else SPARSE_J))
        return
    nf = dims[ed.NFREE]
    rpos, cpos = _i(table, slot.J_ROW_POS), _i(table, slot.J_COL_POS)
    into, out = (cpos, rpos) if transposed else (rpos, cpos)
    t = _f(table, slot.BAND_SCRATCH)
    for r in range(nf):
        t[into[r]] = b[r]
    lu, pivots, kl, ku = _f(table, slot.LU), _i(table, slot.PIVOTS), dims[ed.J_KL], dims[ed.J_KU]
    if transposed:
        banded.solve_transposed(lu, nf, pivots, kl, ku, t)
    else:
        banded.solve(lu, nf, pivots, kl, ku, t)
    for c in range(nf):
        b[c] = t[out[c]]


# -- the augmented system --------------------------------------------------------------------------
@kernel
def augmented_matrix(table):
    """The array the augmented system is assembled into, cleared: its sparse values when it
    is factored sparse, else slot augmented, the band storage of the (na, na) matrix
    (`banded.layout`), in its band (`clear_band`)."""
    dims = _i(table, slot.DIMS)
    dims[ed.A_FACTORS] = ed.NO_FACTORS
    if dims[ed.A_SPARSE] == 1:
        A = sparse_lu.matrix_values(_i(table, slot.AUG_SPARSE), _f(table, slot.AUG_SPARSE_VALUES))
        A[:] = 0.0
        return A
    na = dims[ed.NFREE] + dims[ed.NRIGID]
    A = _f(table, slot.AUG)
    dims[ed.A_KEPT] = KEPT_NONE  # the banded factors are in A
    clear_band(A, na, dims[ed.A_KL], dims[ed.A_KU])
    return A


@kernel
def clear_band(a, n, kl, ku):
    """a (the band storage of an (n, n) matrix, `banded.layout`) = 0 on every entry the
    banded LU reads or fills: row i, columns i - kl to i + kl + ku (`banded.factor`). The
    compact storage holds only those (and a few at its edges never read): one fill. Of the
    dense storage only the band is cleared; the rest is never read, and clearing all of it
    would cost O(n^2) per evaluation."""
    step, shift = banded.layout(a.size, n, kl, ku)
    if step != n:  # compact
        a[:] = 0.0
        return
    for i in range(n):
        for j in range(max(0, i - kl), min(n - 1, i + kl + ku) + 1):
            a[i * n + j] = 0.0


@kernel
def add_lumped(table, A, na):
    """The lumped masses onto the diagonal of the free coordinates' block of A."""
    dims = _i(table, slot.DIMS)
    lumped, col_of_coord = _f(table, slot.LUMPED), _i(table, slot.COL_OF_COORD)
    sparse = dims[ed.A_SPARSE] == 1
    amap, apos = _i(table, slot.AUG_MAP), _i(table, slot.AUG_POS)
    step, shift = banded.layout(A.size, na, dims[ed.A_KL], dims[ed.A_KU])
    for a in range(dims[ed.NX]):
        c = col_of_coord[a]
        if c >= 0:
            if sparse:
                A[amap[c]] += lumped[a]
            else:
                A[apos[c] * step + shift + apos[c]] += lumped[a]


@kernel
def add_element_mass(table, A, na, mass_entry, coords, m, Me, position):
    """One element's mass Me (m * m, row by row) onto the free coordinates' block of A: through
    the augmented map from its entry `mass_entry` on (sparse), else at the banded positions of
    the element's coordinates (A the band storage, `banded.layout`; `position` (m,)
    scratch)."""
    dims = _i(table, slot.DIMS)
    if dims[ed.A_SPARSE] == 1:
        amap = _i(table, slot.AUG_MAP)
        for e in range(m * m):
            s = amap[mass_entry + e]
            if s >= 0:
                A[s] += Me[e]
        return
    col_of_coord, apos = _i(table, slot.COL_OF_COORD), _i(table, slot.AUG_POS)
    step, shift = banded.layout(A.size, na, dims[ed.A_KL], dims[ed.A_KU])
    for a in range(m):
        c = col_of_coord[coords[a]]
        position[a] = apos[c] if c >= 0 else -1
    for a in range(m):
        ca = position[a]
        if ca < 0:
            continue
        for b in range(m):
            cb = position[b]
            if cb >= 0:
                A[ca * step + shift + cb] += Me[a * m + b]


@kernel
def mass_entries_start(table):
    """Where the element mass entries begin in the augmented map (after the diagonal of the
    free coordinates and the two rigid-row parts)."""
    dims = _i(table, slot.DIMS)
    return dims[ed.NFREE] + 2 * _f(table, slot.DE).size


@kernel
def add_rigid_rows(table, A, na):
    """The rigid rows J_o of J (De of the deformations prescribed zero on the free
    coordinates) into A as [., J_o^T; J_o, 0] beside the mass block of the free coordinates."""
    dims = _i(table, slot.DIMS)
    nf = dims[ed.NFREE]
    rigid = dims[ed.NSLAVES] > 0
    rde = _f(table, slot.RIGID_DE)
    if dims[ed.A_SPARSE] == 1:
        De, amap = _f(table, slot.DE), _i(table, slot.AUG_MAP)
        scatter_de(table, De, amap, nf, nf + De.size, A)  # a touching element's below
        if rigid:
            base, n_rde = dims[ed.A_RIGID], rde.size
            for e in range(n_rde):
                s = amap[base + e]
                if s >= 0:
                    A[s] += rde[e]
                    A[amap[base + n_rde + e]] += rde[e]
        return
    row_of_def, col_of_coord = _i(table, slot.ROW_OF_DEF), _i(table, slot.COL_OF_COORD)
    n_rigid = dims[ed.NRIGID]
    apos = _i(table, slot.AUG_POS)
    step, shift = banded.layout(A.size, na, dims[ed.A_KL], dims[ed.A_KU])
    for j in range(_i(table, slot.TOUCHING_ROWS).size // 3):  # empty without clusters
        o, coords, de, z, at = touching_row(table, j)
        if o >= n_rigid:
            continue
        po = apos[nf + o]
        for a in range(z.size):
            c = col_of_coord[z[a]]
            if c >= 0:
                v = rde[at + a]
                A[po * step + shift + apos[c]] += v
                A[apos[c] * step + shift + po] += v
    for g in range(dims[ed.NGROUPS]):
        n, m, k, coords, defs, De, D2e = group_deformations(table, g)
        row = group(table, g)
        for i in range(n):
            if rigid and rigid_element(table, row, i) >= 0:
                continue
            for b in range(k):
                o = row_of_def[defs[i * k + b]]
                if o < 0 or o >= n_rigid:
                    continue
                po = apos[nf + o]
                for a in range(m):
                    c = col_of_coord[coords[i * m + a]]
                    if c >= 0:
                        v = De[(i * k + b) * m + a]
                        A[po * step + shift + apos[c]] = v
                        A[apos[c] * step + shift + po] = v


@kernel
def augmented_factor(table, A, na):
    """Factor the assembled A, sparse or in its band storage as the model was packed
    (dims[A_FACTORS] then says which); False when A is singular."""
    dims = _i(table, slot.DIMS)
    dims[ed.A_KEPT] = KEPT_NONE  # overwritten from here on
    if dims[ed.A_SPARSE] == 1:  # else (or when it cannot serve) in its band storage
        ratio = _sparse_factor(table, SPARSE_AUGMENTED)
        if ratio >= 0.0:
            dims[ed.A_FACTORS] = ed.SPARSE_FACTORS
            dims[ed.A_KEPT] = KEPT_SPARSE
            return True
        if np.isnan(ratio):  # its operation not connected
            return False
    if not banded.factor(_f(table, slot.AUG), na, _i(table, slot.AUG_PIVOTS), dims[ed.A_KL],
                         dims[ed.A_KU]) > 0.0:
        return False
    dims[ed.A_FACTORS] = ed.BANDED_FACTORS
    dims[ed.A_KEPT] = KEPT_BANDED
    return True


@kernel
def augmented_solve(table, A, na, rhs):
    """Factor the assembled A and solve A z = rhs in place (rhs (na,): the free coordinates,
    then the rigid rows); False when A is singular."""
    if not augmented_factor(table, A, na):
        return False
    augmented_resolve(table, na, rhs)
    return True


@kernel
def augmented_resolve(table, na, rhs):
    """Solve A z = rhs in place (rhs (na,) as `augmented_solve`'s) with the factors the last
    successful `augmented_factor` left (dims[A_FACTORS] says which; not NO_FACTORS)."""
    kept_resolve(table, _i(table, slot.DIMS)[ed.A_FACTORS] == ed.SPARSE_FACTORS, na, rhs)


@kernel
def kept_resolve(table, sparse, na, rhs):
    """Solve A z = rhs in place (rhs (na,) as `augmented_solve`'s) with the sparse factors
    in the storage (sparse), else the banded ones, of whatever state they were made at."""
    dims = _i(table, slot.DIMS)
    if sparse:
        run(table, OP_SPARSE_SOLVE, rhs.ctypes.data, 0, float(SPARSE_AUGMENTED))
        return
    apos, t = _i(table, slot.AUG_POS), _f(table, slot.BAND_SCRATCH)
    for u in range(na):
        t[apos[u]] = rhs[u]
    banded.solve(_f(table, slot.AUG), na, _i(table, slot.AUG_PIVOTS), dims[ed.A_KL],
                 dims[ed.A_KU], t)
    for u in range(na):
        rhs[u] = t[apos[u]]
