"""Sparse LU of a matrix with a fixed pattern, refactored with kept pivots, compiled.

The engine's constraint Jacobian J and its augmented system keep their sparsity pattern at
every configuration (an element's deformations depend on its own coordinates only); only
the values change. On a model with closed loops (the six-DOF manipulator: 1582 free
coordinates) the bandwidth that `banded.bandwidth_order` reaches stays large (kl = 165), and
the banded LU costs n kl (kl + ku) = 86 million multiplications where a fill-reducing sparse
LU needs 0.1 million. This module is that sparse LU, after KLU (Davis & Palamadai
Natarajan, ACM TOMS 37, 2010):

- At packing, in Python (`StaticLU`): the column order Q from scipy's SuperLU
  (`scipy.sparse.linalg.splu`, its perm_c) for each ordering in `ORDERINGS`; for each, the
  compiled `factor` on the values at a reference point (the initial configuration) finds
  the row pivots and the patterns of L and U; the ordering with the fewest multiplications
  is kept. The patterns are structural: every stored entry of A counts, zero or not, so a
  refactorisation at other values misses no entry.
- `factor` (compiled, left-looking with partial pivoting, Gilbert & Peierls 1988): column j
  of A Q; the rows it reaches through the pattern of L found by depth-first search (in
  topological order); x = L^-1 A[:, j] on them; the pivot: the row that was pivot j before
  if |x| there is at least KEEP = 0.5 of the largest, else the largest |x_i| (or, packed with
  sparsest_rows, the sparsest row within KEEP: `sparse_lu_pivots`; J's); U[:, j] = x on
  the rows already pivotal, L[:, j] = x / pivot on the others. Sets the row order P.
- `refactor` (compiled, the hot path): the same column loop on the kept P, Q and patterns,
  with no search and no choice: for every k in the pattern of U[:, j] in its stored
  (topological) order x -= L[:, k] x_k. Cost (multiplications, `StaticLU.multiplications`
  from the patterns): sum_k nnz(L[:, k]) nnz(U[k, :] off the diagonal) + nnz(L); a solve
  (`solve`: A x = b or A^T x = b) nnz(L) + nnz(U). Nothing is allocated: the packed
  arrays hold the patterns with room for SLACK times the first fill, and the work arrays.

Threshold. `refactor` checks every kept pivot against its column: |u_jj| >= THRESHOLD
max_{i>j} |x_i| (threshold partial pivoting, Duff, Erisman & Reid, Direct Methods for Sparse
Matrices, 5.4), which bounds every multiplier |l_ij| <= 1 / THRESHOLD = 10, so the growth
of the entries, and the error of the factors, stays within about a digit of partial
pivoting's (UMFPACK's default threshold is the same 0.1). A pivot that fails, or is zero or
not finite, makes `refactor` return REJECTED; the caller then calls `factor`, which pivots
afresh and keeps the new order for the refactorisations after it. Why not keep the pivots
for good: on the manipulator's augmented system, chosen at the initial configuration (Euler
parameters of unrotated nodes, whose normalisation constraint 2 lambda_i vanishes there) they
pivot on masses of 1e-12 kg m^2 that a rotation of 1e-7 rad already dwarfs; a growth of
(2 lambda_i)^2 / m follows. `factor` returns REJECTED on a singular or non-finite column and
CAPACITY when the fill outgrows the room; the caller then factors another way (the engine:
its banded LU, `banded.py`) and the next `refactor` returns REJECTED until a `factor` works.

`tests/test_sparse_lu.py` checks it against numpy on random sparse matrices and on the
manipulator's J and augmented system, the transposed solve, the re-pivoting and the capacity.
"""

import numpy as np

from .jit import kernel
from .pattern_slots import PatternSlots
from .sparse_lu_pivots import row_counts, sparsest_row

THRESHOLD = 0.1  # smallest |pivot| / max |column below it| a kept pivot may have
REJECTED = -1.0  # a kept pivot failed (`refactor`), or the matrix is singular (`factor`)
CAPACITY = -2.0  # `factor`: the fill of L or U outgrew the room packed for it
ORDERINGS = ("COLAMD", "MMD_ATA", "MMD_AT_PLUS_A")  # SuperLU's column orderings tried
SLACK = 3  # room for L and U: SLACK times the first factorisation's fill, plus n
# `factor` keeps a previous pivot row while |x| >= KEEP max |x| in its column, so that a pivot
# it leaves has to lose a factor of KEEP / THRESHOLD = 5 against its column before the next
# rejection (with KEEP = THRESHOLD the 507-DOF manipulator re-pivoted at 10 % of its
# factorisations in a simulation)
KEEP = 0.5

# the head of the packed int64 array: n, nnz of A, room for L (strictly lower) and for U
# (with the diagonal), 1 while the patterns and P hold a factorisation, 1 where a fresh pivot
# is the sparsest row that passes KEEP (`factor`); then Ap (n + 1), Ai, Lp (n + 1), Li,
# Up (n + 1), Ui, prow (n), pinv (n), pcol (n), old (n), stack (2 n: the search and the
# reach in its first n, A's row counts in its last), pstack (n), mark (n)
H_N, H_NNZ_A, H_ROOM_L, H_ROOM_U, H_VALID, H_SPARSEST, H_SIZE = range(7)


class StaticLU:
    """The packed arrays of the sparse LU of one matrix pattern, factored once.

    Parameters
    ----------
    n : int
        The order of the square matrix A.
    rows, columns : array of int (nnz,)
        Every entry of A that can be non-zero (repeats allowed): its structural pattern.
    values : array of float (nnz,)
        A's values on those entries at the reference point (repeats are summed), at which the
        pivots are chosen.
    orderings : sequence of str
        SuperLU column orderings (`permc_spec`) to try; the one whose factors take the fewest
        multiplications is kept.
    slack : float
        Room for L and U in multiples of SuperLU's fill at the reference point (plus n);
        doubled until the first factorisation fits.
    sparsest_rows : bool
        Each pivot chosen afresh (here, and where `factor` re-pivots) the sparsest row that
        passes KEEP, not the largest |x| (SuperLU's, kept otherwise): `sparse_lu_pivots`.

    Attributes
    ----------
    ints, floats : ndarray
        The packed arrays that `factor`, `refactor` and `solve` take, factored at the
        reference point (A's values first in floats, at the positions `slot` gives). Every
        user that factors needs its own copy of both.
    ordering : str
        The ordering kept.
    multiplications : dict
        {"factor": ..., "solve": ...} of `refactor` and `solve`, counted from the patterns.

    Raises
    ------
    ValueError
        When A is singular at the reference point.
    """

    def __init__(self, n, rows, columns, values, *, orderings=ORDERINGS, slack=SLACK,
                 sparsest_rows=False):
        from scipy.sparse import csc_matrix
        from scipy.sparse.linalg import splu

        from .sparse_lu_entry import factor_now  # without numba where the cache has it

        rows, columns = np.asarray(rows, dtype=np.int64), np.asarray(columns, dtype=np.int64)
        self.n = n = int(n)
        matrix = csc_matrix((np.asarray(values, dtype=float), (rows, columns)), shape=(n, n))
        matrix.sum_duplicates()
        matrix.sort_indices()
        pattern = csc_matrix((np.ones(rows.size), (rows, columns)), shape=(n, n))
        pattern.sum_duplicates()
        pattern.sort_indices()
        # the reference values on the full pattern (entries zero there included)
        coo = pattern.tocoo()
        reference = np.asarray(matrix.tocsr()[coo.row, coo.col]).ravel()
        best = None
        for ordering in orderings:
            try:
                lu = splu(matrix, permc_spec=ordering, diag_pivot_thresh=1.0)
            except RuntimeError as error:  # "Factor is exactly singular"
                raise ValueError(f"the matrix is singular at the reference point: {error}") \
                    from None
            # A Q: column j of it is A's column pcol[j]; SuperLU's pivot rows prow seed the
            # pivot choice (ties of magnitude broken as SuperLU broke them: its fill), or
            # none where the sparsest rows are chosen
            pcol, prow = np.argsort(lu.perm_c), np.argsort(lu.perm_r)
            if sparsest_rows:
                prow = np.full(n, -1, dtype=np.int64)
            room = int(slack * (lu.L.nnz + lu.U.nnz)) + n
            while True:
                packed = _pack(n, coo, reference, pcol, prow, room, sparsest_rows)
                ratio = factor_now(*packed, THRESHOLD)
                if ratio != CAPACITY:
                    break
                room *= 2
            if ratio == REJECTED:
                raise ValueError("the matrix is singular at the reference point")
            count = _multiplications(packed[0], n)
            if best is None or count["factor"] < best[0]["factor"]:
                best = count, ordering, packed, pcol
        self.multiplications, self.ordering, (self.ints, self.floats), pcol = best
        # A's entries in the packed (column-permuted CSC) order have increasing keys
        # column position n + row
        position_column = np.argsort(pcol)
        Ap = self.ints[H_SIZE: H_SIZE + n + 1]
        Ai = self.ints[H_SIZE + n + 1: H_SIZE + n + 1 + self.ints[H_NNZ_A]]
        self._slots = PatternSlots(np.repeat(np.arange(n, dtype=np.int64), np.diff(Ap)) * n
                                   + Ai, position_column)
        self._pcol, self._Ai, self._Ap = pcol, Ai, Ap

    def slot(self, rows, columns):
        """The positions in `floats` (A's values) of A's entries (rows, columns) (arrays of
        int, any shape); ValueError if an entry is not in the pattern (`PatternSlots`)."""
        return self._slots(rows, columns)

    def set_matrix(self, dense, floats=None):
        """Put the values of a dense (n, n) A on the pattern into `floats` (default: this
        object's) as A's values."""
        floats = self.floats if floats is None else floats
        values = floats[: self._Ai.size]
        values[:] = np.asarray(dense, dtype=float)[self._Ai, self._pcol[
            np.repeat(np.arange(self.n), np.diff(self._Ap))]]


def _pack(n, coo, reference, pcol, prow, room, sparsest_rows=False):
    """(ints, floats) for the column order pcol with A's reference values in place and prow
    as the pivot rows to keep where they pass the threshold test (-1: none)."""
    from scipy.sparse import csc_matrix

    position_column = np.argsort(pcol)
    permuted = csc_matrix((reference + 0.0, (coo.row, position_column[coo.col])), shape=(n, n))
    permuted.sort_indices()
    nnz = permuted.nnz
    head = np.array([n, nnz, room, room, 0, int(sparsest_rows)], dtype=np.int64)
    zeros = np.zeros
    ints = np.concatenate([head, permuted.indptr, permuted.indices, zeros(n + 1), zeros(room),
                           zeros(n + 1), zeros(room), prow, np.full(n, -1), pcol,
                           np.full(n, -1), zeros(2 * n), zeros(n), np.full(n, -1)])
    floats = np.concatenate([permuted.data, zeros(2 * room + n)])
    return ints.astype(np.int64), floats


def _multiplications(ints, n):
    """Multiplications of one `refactor` and one `solve` on the packed patterns (read at
    `packed_parts`' offsets in Python: a kernel called from here would import numba)."""
    lp = H_SIZE + n + 1 + int(ints[H_NNZ_A])
    up = lp + n + 1 + int(ints[H_ROOM_L])
    Lp, Up, Ui = ints[lp: lp + n + 1], ints[up: up + n + 1], ints[up + n + 1:]
    l_count = np.diff(Lp)
    # each entry (k, j) of U off the diagonal costs nnz(L[:, k]) multiplications in column j
    ends = Up[1:] - 1
    off_diagonal = np.concatenate([Ui[Up[j]: ends[j]] for j in range(n)]) if n else \
        np.zeros(0, dtype=np.int64)
    return {"factor": int(l_count[off_diagonal].sum() + Lp[n]),
            "solve": int(Lp[n] + Up[n])}


# -- compiled ------------------------------------------------------------------------------------
@kernel
def packed_parts(ints, floats):
    """Views of the packed arrays: (n, Ap, Ai, Lp, Li, Up, Ui, prow, pinv, pcol, old, stack,
    pstack, mark, Ax, Lx, Ux, x)."""
    n, na, rl, ru = ints[H_N], ints[H_NNZ_A], ints[H_ROOM_L], ints[H_ROOM_U]
    o = H_SIZE
    Ap = ints[o: o + n + 1]
    o += n + 1
    Ai = ints[o: o + na]
    o += na
    Lp = ints[o: o + n + 1]
    o += n + 1
    Li = ints[o: o + rl]
    o += rl
    Up = ints[o: o + n + 1]
    o += n + 1
    Ui = ints[o: o + ru]
    o += ru
    prow, pinv, pcol, old = ints[o: o + n], ints[o + n: o + 2 * n], ints[o + 2 * n: o + 3 * n], \
        ints[o + 3 * n: o + 4 * n]
    o += 4 * n
    stack, pstack, mark = ints[o: o + 2 * n], ints[o + 2 * n: o + 3 * n], \
        ints[o + 3 * n: o + 4 * n]
    return (n, Ap, Ai, Lp, Li, Up, Ui, prow, pinv, pcol, old, stack, pstack, mark,
            floats[: na], floats[na: na + rl], floats[na + rl: na + rl + ru],
            floats[na + rl + ru: na + rl + ru + n])


@kernel(inline="always")
def unsigned_index(index):
    """An index of the packed patterns (int64, never negative where the hot loops read it)
    as an unsigned one: numba then leaves out its test for a negative (from the end) index
    at every access, the same accesses and arithmetic otherwise (the same bits; 17 to 20 %
    off a solve of the 384-DOF cantilever's J and Newton matrix, compiled loops)."""
    return np.uint64(index)


@kernel
def matrix_values(ints, floats):
    """A's values on its pattern (a view into floats): what assembly writes."""
    return floats[: ints[H_NNZ_A]]


@kernel
def refactor(ints, floats, threshold):
    """Factor P A Q = L U with A's values in `matrix_values` and the kept P, Q and patterns.

    Returns the ratio of the smallest to the largest pivot magnitude, or REJECTED when a
    pivot is zero, not finite or smaller than `threshold` times the largest entry below it
    in its column, or when no factorisation is kept (the work vector is left clean)."""
    n, Ap, Ai, Lp, Li, Up, Ui, _, pinv, _, _, _, _, _, Ax, Lx, Ux, x = packed_parts(ints, floats)
    if ints[H_VALID] != 1:
        return REJECTED
    smallest, largest = np.inf, 0.0
    for j in range(n):
        for p in range(Ap[j], Ap[j + 1]):
            x[unsigned_index(pinv[unsigned_index(Ai[p])])] = Ax[p]
        last = Up[j + 1] - 1  # U's diagonal
        for p in range(Up[j], last):  # x -= L[:, k] x_k over U[:, j] in topological order
            k = unsigned_index(Ui[p])
            xk = x[k]
            Ux[p] = xk
            x[k] = 0.0
            if xk != 0.0:
                for q in range(Lp[k], Lp[k + 1]):
                    x[unsigned_index(Li[q])] -= Lx[q] * xk
        pivot = x[j]
        x[j] = 0.0
        Ux[last] = pivot
        # L[:, j] scaled and x cleared in the one pass that finds the column's largest entry
        # below the pivot: a rejected column's values are left in L, never read (the
        # caller factors afresh)
        big, inverse = 0.0, 1.0 / pivot
        for q in range(Lp[j], Lp[j + 1]):
            i = unsigned_index(Li[q])
            xi = x[i]
            big = max(big, abs(xi))
            Lx[q] = xi * inverse
            x[i] = 0.0
        magnitude = abs(pivot)
        if not (magnitude > 0.0 and magnitude >= threshold * big and magnitude < np.inf):
            return REJECTED
        smallest, largest = min(smallest, magnitude), max(largest, magnitude)
    return smallest / largest if largest > 0.0 else 1.0


@kernel
def factor(ints, floats, threshold):
    """Factor P A Q = L U with partial pivoting, A's values in `matrix_values`: new P and
    patterns of L and U, kept for `refactor`. A row that was pivot j before stays so while
    |x| >= max(threshold, KEEP) max |x| in its column; a pivot chosen afresh is the largest
    |x|, or with the head's H_SPARSEST the row with the fewest entries in A among those with
    |x| >= KEEP max |x| (the largest |x| of them on a tie). Returns the pivot ratio as
    `refactor`, REJECTED for a singular or non-finite matrix, CAPACITY when L or U outgrow
    their room."""
    n, Ap, Ai, Lp, Li, Up, Ui, prow, pinv, _, old, stack, pstack, mark, Ax, Lx, Ux, x = \
        packed_parts(ints, floats)
    room_l, room_u = ints[H_ROOM_L], ints[H_ROOM_U]
    ints[H_VALID] = 0
    for i in range(n):
        old[i] = prow[i]
        pinv[i] = -1
        mark[i] = -1
    sparsest = ints[H_SPARSEST] == 1
    counts = stack[n: 2 * n]  # A's row counts: the search and the reach use stack[:n]
    if sparsest:
        row_counts(Ap, Ai, n, counts)
    lnz = unz = 0
    smallest, largest = np.inf, 0.0
    for j in range(n):
        Lp[j], Up[j] = lnz, unz
        # the rows column j reaches through L (original numbering), in topological order
        # in stack[top:n] (the depth-first search of CSparse's cs_reach / cs_dfs)
        top = n
        for p in range(Ap[j], Ap[j + 1]):
            start = Ai[p]
            if mark[start] == j:
                continue
            head = 0
            stack[0] = start
            while head >= 0:
                i = stack[head]
                k = pinv[i]
                if mark[i] != j:
                    mark[i] = j
                    pstack[head] = Lp[k] if k >= 0 else 0
                done = True
                end = Lp[k + 1] if k >= 0 else 0
                for q in range(pstack[head], end):
                    child = Li[q]
                    if mark[child] == j:
                        continue
                    pstack[head] = q
                    head += 1
                    stack[head] = child
                    done = False
                    break
                if done:
                    head -= 1
                    top -= 1
                    stack[top] = i
        # stack[top:n] overlaps the search stack only below `top`: head + (n - top) <= n
        for p in range(Ap[j], Ap[j + 1]):
            x[Ai[p]] = Ax[p]
        for t in range(top, n):  # x = L^-1 A[:, j] on the reach
            i = stack[t]
            k = pinv[i]
            if k < 0:
                continue
            xi = x[i]
            if xi != 0.0:
                for q in range(Lp[k], Lp[k + 1]):
                    x[Li[q]] -= Lx[q] * xi
        # the pivot among the rows not yet pivotal
        chosen, big = -1, -1.0
        count_l = 0
        for t in range(top, n):
            i = stack[t]
            if pinv[i] < 0:
                count_l += 1
                value = abs(x[i])
                if value > big:
                    chosen, big = i, value
        previous = old[j]
        if previous >= 0 and pinv[previous] < 0 and mark[previous] == j \
                and abs(x[previous]) >= max(threshold, KEEP) * big:
            chosen = previous
        elif sparsest and big > 0.0:
            chosen = sparsest_row(x, stack, top, n, pinv, counts, max(threshold, KEEP) * big)
        if unz + (n - top) - count_l + 1 > room_u or lnz + count_l > room_l:
            _clear(x, stack, top, n)
            return CAPACITY
        pivot = x[chosen] if chosen >= 0 else 0.0
        magnitude = abs(pivot)
        if not (magnitude > 0.0 and magnitude < np.inf):
            _clear(x, stack, top, n)
            return REJECTED
        inverse = 1.0 / pivot
        for t in range(top, n):  # U[:, j] in topological order, then L[:, j]
            i = stack[t]
            k = pinv[i]
            if k >= 0:
                Ui[unz] = k
                Ux[unz] = x[i]
                unz += 1
            elif i != chosen:
                Li[lnz] = i
                Lx[lnz] = x[i] * inverse
                lnz += 1
            x[i] = 0.0
        Ui[unz] = j
        Ux[unz] = pivot
        unz += 1
        pinv[chosen] = j
        prow[j] = chosen
        smallest, largest = min(smallest, magnitude), max(largest, magnitude)
    Lp[n], Up[n] = lnz, unz
    for q in range(lnz):  # L's rows by their pivot positions, for `refactor` and `solve`
        Li[q] = pinv[Li[q]]
    ints[H_VALID] = 1
    return smallest / largest if largest > 0.0 else 1.0


@kernel
def _clear(x, stack, top, n):
    for t in range(top, n):
        x[stack[t]] = 0.0


@kernel
def solve(ints, floats, b, transposed):
    """b <- A^-1 b (or with transposed A^-T b), in place, both in A's own order, with the
    factors of the last successful `factor` or `refactor`."""
    n, _, _, Lp, Li, Up, Ui, prow, _, pcol, _, _, _, _, _, Lx, Ux, x = packed_parts(ints, floats)
    if not transposed:  # L U (Q^T z) = P b
        for i in range(n):
            x[i] = b[unsigned_index(prow[i])]
        for j in range(n):  # L (unit lower)
            xj = x[j]
            if xj != 0.0:
                for q in range(Lp[j], Lp[j + 1]):
                    x[unsigned_index(Li[q])] -= Lx[q] * xj
        for j in range(n - 1, -1, -1):  # U, its diagonal last in each column
            last = Up[j + 1] - 1
            xj = x[j] / Ux[last]
            x[j] = xj
            if xj != 0.0:
                for p in range(Up[j], last):
                    x[unsigned_index(Ui[p])] -= Ux[p] * xj
        for j in range(n):
            b[unsigned_index(pcol[j])] = x[j]
            x[j] = 0.0
        return
    for j in range(n):  # U^T L^T (P z) = Q^T b
        x[j] = b[unsigned_index(pcol[j])]
    for j in range(n):  # U^T: column j of U is row j of U^T
        last = Up[j + 1] - 1
        s = x[j]
        for p in range(Up[j], last):
            s -= Ux[p] * x[unsigned_index(Ui[p])]
        x[j] = s / Ux[last]
    for j in range(n - 1, -1, -1):  # L^T
        s = x[j]
        for q in range(Lp[j], Lp[j + 1]):
            s -= Lx[q] * x[unsigned_index(Li[q])]
        x[j] = s
    for i in range(n):
        b[unsigned_index(prow[i])] = x[i]
        x[i] = 0.0


@kernel
def scatter_dense(ints, floats, dense, row_position, column_position):
    """dense[row_position[r] n + column_position[c]] = A[r, c] for every entry of the pattern
    (dense (n * n,), row-major, zero elsewhere beforehand): the matrix for another
    factorisation when this one cannot serve."""
    n = packed_parts(ints, floats)[0]
    scatter_rows(ints, floats, dense, row_position, column_position, n, 0)


@kernel
def scatter_rows(ints, floats, out, row_position, column_position, step, shift,
                 transposed=False):
    """out[row_position[r] step + shift + column_position[c]] = A[r, c] for every entry of
    the pattern (zero elsewhere beforehand): A into a row storage of row step `step` (n for
    the dense one; the banded LU's compact one, `banded.layout`); with `transposed`, A^T
    (the matrix whose LU is that of its transpose, as the kinematics' J: `sparse_factors`)."""
    n, Ap, Ai, _, _, _, _, _, _, pcol, _, _, _, _, Ax, _, _, _ = packed_parts(ints, floats)
    for j in range(n):
        for p in range(Ap[j], Ap[j + 1]):
            r, c = (pcol[j], Ai[p]) if transposed else (Ai[p], pcol[j])
            out[row_position[r] * step + shift + column_position[c]] = Ax[p]
