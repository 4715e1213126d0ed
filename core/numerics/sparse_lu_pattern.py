"""The packed pattern of a sparse LU (`sparse_lu`) read back in plain Python, without numba:
for a caller that wants A's entries in the order of its values, such as the linearisation on
the sparse step's packing (`flexure.core.analysis.linear_sparse`)."""

import numpy as np

from .sparse_lu import H_SIZE, H_VALID


def pattern(ints):
    """(n, rows, columns) of A's stored entries, in the order of its values (`matrix_values`),
    read from the packed ints in Python (no numba): rows and columns int64 arrays (nnz,) of
    A's own (unpermuted) indices, so that A = csc_matrix((values, (rows, columns)), (n, n))."""
    n, nnz, room_l, room_u = (int(v) for v in ints[:H_VALID])
    Ap = ints[H_SIZE: H_SIZE + n + 1]
    rows = ints[H_SIZE + n + 1: H_SIZE + n + 1 + nnz]
    # past Ap, Ai, Lp, Li, Up, Ui, prow and pinv: pcol, packed column j's column of A
    o = H_SIZE + 3 * (n + 1) + nnz + room_l + room_u + 2 * n
    return n, rows.copy(), ints[o: o + n][np.repeat(np.arange(n), np.diff(Ap))]
