"""The null space of a sparse constraint matrix, block by block.

The prescribed deformations' rows R (n_rigid x n_free, rotations scaled to lengths) of a
large model are almost empty: a deformation depends on at most 14 coordinates. Rows and
columns that share no entry, directly or through a chain of others, form independent blocks
(after a permutation R is block-diagonal), and the singular values of R are those of its
blocks together, its null space the blocks' null spaces side by side (each on its own
columns, zero elsewhere), plus a unit vector for every column no row touches. On the
816-DOF manipulator R has 863 blocks of at most 36 x 42: the SVDs of the blocks take
milliseconds where the one of R took 0.5 s (one BLAS thread), twice (its rank, then its null
space). A model with one large block (the manipulator with its elongations prescribed:
810 x 1042 of 937 x 1582) still saves the columns outside it and the second SVD.

The basis differs from the full SVD's by an orthogonal transformation within the null
space (up to round-off): `choose_dofs` uses it only through projections, rows @ N, whose
norms and inner products do not depend on the basis chosen.
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


def rank_and_null_space(matrix: np.ndarray, rtol: float) -> tuple[int, float, np.ndarray]:
    """The singular values' verdicts on `matrix` (m, n) and an orthonormal basis of its null
    space, from the SVDs of its independent blocks (module docstring).

    Parameters
    ----------
    matrix : ndarray (m, n)
        Any units; the thresholds are relative.
    rtol : float
        A singular value counts for the null space when above `rtol` times the largest
        (as `numpy.linalg.svd` would be read on the whole matrix).

    Returns
    -------
    rank_by_entries : int
        The singular values above `rtol` times the largest entry magnitude (the count of
        `numpy.linalg.matrix_rank(matrix, tol=rtol * max|matrix|)`).
    top : float
        The largest singular value (units of `matrix`).
    null_space : ndarray (n, n - rank)
        Orthonormal columns spanning the vectors the matrix maps to zero, rank counted
        with the threshold `rtol` times the largest singular value.
    """
    m, n = matrix.shape
    parts = []  # (columns, s, vt) of every block
    for rows, columns in blocks(matrix):
        if columns.size == 0:  # an empty row: a singular value zero
            parts.append((columns, np.zeros(1), np.zeros((0, 0))))
            continue
        _, s, vt = np.linalg.svd(matrix[np.ix_(rows, columns)])
        # a block with more rows than columns has min(rows, columns) singular values; its
        # other rows add zeros, which only the rank by entries counts
        s = np.concatenate([s, np.zeros(max(rows.size - columns.size, 0))])
        parts.append((columns, s, vt))
    values = np.concatenate([s for _, s, _ in parts]) if parts else np.zeros(0)
    top = float(values.max(initial=0.0))
    entries = float(np.abs(matrix).max(initial=0.0))
    rank_by_entries = int(np.sum(values > rtol * max(entries, 1e-300)))
    threshold = rtol * max(top, 1e-300)
    vectors = []
    touched = np.zeros(n, dtype=bool)
    for columns, s, vt in parts:
        touched[columns] = True
        rank = int(np.sum(s > threshold))
        block = vt[rank:]  # (columns - rank, columns)
        if block.shape[0]:
            full = np.zeros((block.shape[0], n))
            full[:, columns] = block
            vectors.append(full)
    free = np.flatnonzero(~touched)
    if free.size:
        vectors.append(np.eye(n)[free])
    basis = np.vstack(vectors).T if vectors else np.zeros((n, 0))
    return rank_by_entries, top, basis
