"""The block-wise null space of `core.mechanics.nullspace` against one SVD of the whole
matrix: the same rank verdicts and the same null space (its projector, any orthonormal basis
of it), on matrices with independent blocks, empty rows and untouched columns, and on the
prescribed rows of the 816-DOF manipulator."""

import numpy as np
import pytest

from flexure.core.mechanics.nullspace import rank_and_null_space
from flexure.core.numerics.sparse_blocks import blocks

RTOL = 1e-9


def reference(matrix):
    """(rank by entries, null space) from numpy's SVD of the whole matrix."""
    rank_entries = np.linalg.matrix_rank(
        matrix, tol=RTOL * max(np.abs(matrix).max(initial=0.0), 1e-300)) if matrix.size else 0
    if matrix.shape[0] == 0:
        return rank_entries, np.eye(matrix.shape[1])
    _, s, vt = np.linalg.svd(matrix)
    rank = int(np.sum(s > RTOL * max(s.max(initial=0.0), 1e-300)))
    return rank_entries, vt[rank:].T


def block_matrix(seed):
    """Rows in independent blocks (one of them rank deficient), an empty row, untouched
    columns, rows and columns shuffled."""
    rng = np.random.default_rng(seed)
    parts = [rng.normal(size=(3, 5)), rng.normal(size=(2, 2)), rng.normal(size=(4, 6))]
    parts[2][3] = parts[2][0] - 2.0 * parts[2][1]  # a dependent row
    rows = sum(p.shape[0] for p in parts) + 1
    columns = sum(p.shape[1] for p in parts) + 3
    matrix = np.zeros((rows, columns))
    r = c = 0
    for part in parts:
        matrix[r: r + part.shape[0], c: c + part.shape[1]] = part
        r, c = r + part.shape[0], c + part.shape[1]
    return matrix[rng.permutation(rows)][:, rng.permutation(columns)]


@pytest.mark.parametrize("seed", range(4))
def test_the_blocks_give_the_whole_matrix_svd_verdicts(seed):
    matrix = block_matrix(seed)
    assert len(blocks(matrix)) == 4  # three blocks and the empty row
    rank, _, basis = rank_and_null_space(matrix, RTOL)
    expected_rank, expected = reference(matrix)
    assert rank == expected_rank == 8
    assert basis.shape == expected.shape
    assert np.allclose(basis.T @ basis, np.eye(basis.shape[1]), atol=1e-13)
    assert np.abs(basis @ basis.T - expected @ expected.T).max() < 1e-12
    assert np.abs(matrix @ basis).max() < 1e-12


def test_no_rows_leave_every_motion_free():
    rank, top, basis = rank_and_null_space(np.zeros((0, 4)), RTOL)
    assert (rank, top) == (0, 0.0) and np.array_equal(basis, np.eye(4))


@pytest.mark.slow
def test_on_the_manipulator_the_blocks_give_the_svd_null_space():
    from flexure.core import load_scene
    from flexure.core.mechanics.constraints import RANK_TOLERANCE, scaled_jacobian

    model = load_scene("manipulator")
    _, scaled = scaled_jacobian(model, None)
    rigid = scaled[np.ix_(model.rigid_deformations, model.free_coordinates)]
    rank, _, basis = rank_and_null_space(rigid, RANK_TOLERANCE)
    expected_rank, expected = reference(rigid)
    assert rank == expected_rank == rigid.shape[0]
    assert basis.shape == expected.shape == (1582, 816)
    assert np.abs(basis @ basis.T - expected @ expected.T).max() < 1e-11


@pytest.mark.parametrize("deficient", [False, True])
def test_a_large_block_by_qr_or_by_svd_where_the_qr_is_not_clear(deficient):
    """A chain of 80 rows on 120 columns (one block, above SVD_UP_TO), beside small ones:
    regular, it is cleared by its QR; with a dependent row the QR is not clear and the SVDs
    decide; both as one SVD of the whole matrix."""
    from flexure.core.mechanics import nullspace

    rng = np.random.default_rng(7)
    chain = np.zeros((80, 120))
    for k in range(80):  # each row on three neighbouring columns: one connected block
        chain[k, k: k + 3] = rng.normal(size=3)
    if deficient:
        chain[40] = chain[39] + chain[41]
    matrix = np.zeros((90, 130))
    matrix[:80, :120] = chain
    matrix[80:, 120:] = rng.normal(size=(10, 10))
    assert max(c.size for _, c in blocks(matrix)) > nullspace.SVD_UP_TO
    assert (nullspace.by_blocks(matrix, RTOL, nullspace.SVD_UP_TO) is None) == deficient
    rank, _, basis = rank_and_null_space(matrix, RTOL)
    expected_rank, expected = reference(matrix)
    assert rank == expected_rank == 90 - deficient
    assert basis.shape == expected.shape
    assert np.abs(basis @ basis.T - expected @ expected.T).max() < 1e-10
