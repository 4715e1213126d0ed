"""Products with a matrix on a packed sparse LU's pattern (`numerics.sparse_lu`), on its
values as assembled (`sparse_lu.matrix_values`), in the original row and column numbering:
column j of the stored pattern is the matrix's column pcol[j], its row indices Ai are the
matrix's own. Used by the sparse Newton matrix (`newton`) and the stage force
(`stage_force`)."""

from ..numerics import sparse_lu
from ..numerics.jit import kernel
from ..numerics.sparse_lu import unsigned_index as _u  # no wraparound test (its docstring)


@kernel
def pattern_product(ints, floats, values, v, out, limit, scale):
    """out[r] += scale A[r, c] v[c] over the entries of the pattern packed in ints (floats:
    its packed floats, for the views) with values `values`, rows and columns below limit."""
    n, Ap, Ai, _, _, _, _, _, _, pcol, _, _, _, _, _, _, _, _ = sparse_lu.packed_parts(ints, floats)
    for j in range(n):
        c = pcol[j]
        if c >= limit or v[c] == 0.0:
            continue
        vc = scale * v[c]
        for p in range(Ap[j], Ap[j + 1]):
            if Ai[p] < limit:
                out[_u(Ai[p])] += values[p] * vc


@kernel
def pattern_product_pair(ints, floats, first, v, second, w, out, limit, scale):
    """out[r] += A1[r, c] v[c] + scale A2[r, c] w[c] over the entries of the pattern packed in
    ints (floats: its packed floats, for the views), A1 and A2 with values `first` and
    `second` on it, rows and columns below limit: `pattern_product` of both in one pass over
    the pattern."""
    n, Ap, Ai, _, _, _, _, _, _, pcol, _, _, _, _, _, _, _, _ = sparse_lu.packed_parts(ints, floats)
    for j in range(n):
        c = pcol[j]
        if c >= limit or (v[c] == 0.0 and w[c] == 0.0):
            continue
        vc, wc = v[c], scale * w[c]
        for p in range(Ap[j], Ap[j + 1]):
            if Ai[p] < limit:
                out[_u(Ai[p])] += first[p] * vc + second[p] * wc


@kernel
def pattern_product_transposed(ints, floats, values, v, out):
    """out[c] += sum_r A[r, c] v[r] (out += A^T v) over all the entries of the pattern packed
    in ints (floats: its packed floats) with values `values`."""
    n, Ap, Ai, _, _, _, _, _, _, pcol, _, _, _, _, _, _, _, _ = sparse_lu.packed_parts(ints, floats)
    for j in range(n):
        s = 0.0
        for p in range(Ap[j], Ap[j + 1]):
            s += values[p] * v[_u(Ai[p])]
        out[_u(pcol[j])] += s
