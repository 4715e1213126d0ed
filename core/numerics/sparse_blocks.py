"""The independent blocks of a sparse matrix: rows and columns linked by its non-zero entries.

Rows and columns that share no entry, directly or through a chain of others, form independent
blocks: after a permutation the matrix is block-diagonal. A large model's constraint rows
fall apart so (the 816-DOF manipulator's 766 x 1582 prescribed rows into 863 blocks), and so
do the projections its DOF choice compares; the null space (`mechanics.nullspace`) and the
greedy choice of independent rows (`ties.independent_rows`) then work block by block.
"""

from __future__ import annotations

import numpy as np


def blocks(matrix: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The independent blocks of `matrix` (m, n): (row indices, column indices) of each
    connected set of rows and columns (linked by non-zero entries), in the order of their
    first row; rows without an entry are blocks with no column, columns without one belong
    to no block.

    Parameters
    ----------
    matrix : ndarray (m, n)

    Returns
    -------
    list of (ndarray, ndarray)
        Sorted row and column indices of each block.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m, n = matrix.shape
    rows, columns = np.nonzero(matrix)
    # the bipartite graph of rows (0 .. m-1) and columns (m .. m+n-1)
    graph = coo_matrix((np.ones(rows.size), (rows, m + columns)), shape=(m + n, m + n))
    _, label = connected_components(graph, directed=False)
    row_label, column_label = label[:m], label[m:]
    order = dict.fromkeys(row_label.tolist())  # the blocks in the order of their first row
    by_label = {key: (np.flatnonzero(row_label == key), np.flatnonzero(column_label == key))
                for key in order}
    return list(by_label.values())
