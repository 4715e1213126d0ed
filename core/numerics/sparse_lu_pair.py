"""Two right-hand sides solved in one pass over a sparse LU's factors (`sparse_lu`).

Why apart from `solve`: the sparse Newton step of the ESDIRK (`engine.newton`) solves J for
two vectors at once, and reading L's and U's patterns once for both saves a pass over them.
"""

from .jit import kernel
from .sparse_lu import packed_parts
from .sparse_lu import unsigned_index as _u


@kernel
def solve_pair(ints, floats, b, c, work):
    """b <- A^-1 b and c <- A^-1 c in place, in A's own order, with the factors of the last
    successful `factor` or `refactor`: `solve` of each, in one pass over L and U (their
    patterns read once for both), the same operations on each vector in the same order as
    `solve`'s, so the same values (where one vector's entry is zero and the other's not, it
    subtracts a product with zero that `solve` skips: a zero's sign aside, nothing changes).
    work: scratch of at least n entries."""
    n, _, _, Lp, Li, Up, Ui, prow, _, pcol, _, _, _, _, _, Lx, Ux, x = packed_parts(ints, floats)
    for i in range(n):
        x[i] = b[_u(prow[i])]
        work[i] = c[_u(prow[i])]
    for j in range(n):  # L (unit lower)
        xj, wj = x[j], work[j]
        if xj != 0.0 or wj != 0.0:
            for q in range(Lp[j], Lp[j + 1]):
                i = _u(Li[q])
                x[i] -= Lx[q] * xj
                work[i] -= Lx[q] * wj
    for j in range(n - 1, -1, -1):  # U, its diagonal last in each column
        last = Up[j + 1] - 1
        xj, wj = x[j] / Ux[last], work[j] / Ux[last]
        x[j], work[j] = xj, wj
        if xj != 0.0 or wj != 0.0:
            for p in range(Up[j], last):
                i = _u(Ui[p])
                x[i] -= Ux[p] * xj
                work[i] -= Ux[p] * wj
    for j in range(n):
        b[_u(pcol[j])] = x[j]
        c[_u(pcol[j])] = work[j]
        x[j] = 0.0
