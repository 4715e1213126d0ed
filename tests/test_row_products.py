"""The tangent's product C += A^T B over chosen rows (`dense.add_row_products`, and
`dense.add_row_groups`, which takes rows four at a time) against the plain triple loop over
its formula and against numpy.

A and B are tall (nrows, n) with each row's entries in a column range, as DF and K_x DF are
in the tangent: some rows in groups of four with equal ranges (the kernel's four-row path),
some alone, some zero (left out of the rows taken). The plain loop adds the products to each
C_ij in the order of the rows, as the kernel does, so the two agree to a few ulps of the
largest |a_ri b_rj| summed; numpy (BLAS, another order) to round-off, n eps of that sum. The
symmetric form (B = X A with a symmetric X) forms the upper triangle and mirrors it: checked
against the full plain product to round-off, and exactly symmetric.
"""

import numpy as np
import pytest

from flexure.core.numerics.dense import add_row_groups, add_row_products

KERNELS = pytest.mark.parametrize("kernel", [add_row_products, add_row_groups])


def _rows(nrows, n, seed):
    """A (nrows, n) with ranged rows (groups of four sharing a range, single rows, a zero
    row), its ranges (5 nrows: rows taken, A's and B's [first, end)), the rows taken."""
    rng = np.random.default_rng(seed)
    A = np.zeros((nrows, n))
    first, end = np.zeros(nrows, np.int64), np.zeros(nrows, np.int64)
    r = 0
    while r < nrows:
        size = 4 if rng.random() < 0.6 else 1
        lo = int(rng.integers(0, n))
        hi = int(rng.integers(lo + 1, n + 1))
        for row in range(r, min(r + size, nrows)):
            A[row, lo:hi] = rng.standard_normal(hi - lo)
            A[row, lo:hi][rng.random(hi - lo) < 0.3] = 0.0  # zeros inside the range
            first[row], end[row] = lo, hi
        r += size
    A[nrows // 2] = 0.0  # a zero row: not taken
    first[nrows // 2] = end[nrows // 2] = 0
    taken = np.array([row for row in range(nrows) if end[row] > first[row]], np.int64)
    return A, first, end, taken


def _plain(A, B, taken, n):
    """C = sum over the taken rows of A[r]^T B[r], entry by entry in the rows' order."""
    C = np.zeros((n, n))
    for r in taken:
        for i in range(n):
            for j in range(n):
                C[i, j] += A[r, i] * B[r, j]
    return C


def _ranges(nrows, taken, first, end, b_first, b_end):
    ranges = np.zeros(5 * nrows, np.int64)
    ranges[: taken.size] = taken
    ranges[nrows: 2 * nrows], ranges[2 * nrows: 3 * nrows] = first, end
    ranges[3 * nrows: 4 * nrows], ranges[4 * nrows:] = b_first, b_end
    return ranges


@KERNELS
@pytest.mark.parametrize("nrows, n, seed", [(1, 1, 0), (9, 7, 1), (40, 23, 2), (61, 50, 3)])
def test_row_products_against_the_plain_loop_and_numpy(kernel, nrows, n, seed):
    A, first, end, taken = _rows(nrows, n, seed)
    rng = np.random.default_rng(seed + 100)
    B = np.zeros((nrows, n))
    b_first, b_end = np.zeros(nrows, np.int64), np.zeros(nrows, np.int64)
    for r in range(nrows):  # B's own ranges, alike within A's groups where A's are
        lo = int(rng.integers(0, n))
        hi = int(rng.integers(lo + 1, n + 1))
        if r and first[r] == first[r - 1] and end[r] == end[r - 1]:
            lo, hi = b_first[r - 1], b_end[r - 1]
        B[r, lo:hi] = rng.standard_normal(hi - lo)
        b_first[r], b_end[r] = lo, hi
    C0 = rng.standard_normal((n, n))  # added to
    C = C0.ravel().copy()
    if kernel is add_row_groups:  # some four rows of equal ranges: its grouped path
        assert any(np.all(first[taken[t: t + 4]] == first[taken[t]])
                   and np.all(end[taken[t: t + 4]] == end[taken[t]])
                   and np.all(b_first[taken[t: t + 4]] == b_first[taken[t]])
                   and np.all(b_end[taken[t: t + 4]] == b_end[taken[t]])
                   for t in range(taken.size - 3)) or taken.size < 4

    kernel(A.ravel(), B.ravel(), n, taken, taken.size,
                     _ranges(nrows, taken, first, end, b_first, b_end), False, C)

    expected = C0 + _plain(A, B, taken, n)
    scale = (np.abs(A[taken]).T @ np.abs(B[taken])) + np.abs(C0)  # sum of |terms|
    eps = np.finfo(float).eps
    assert np.all(np.abs(C.reshape(n, n) - expected) <= 4 * eps * scale)
    numpy = C0 + A[taken].T @ B[taken]
    assert np.all(np.abs(C.reshape(n, n) - numpy) <= (nrows + 2) * eps * scale)


@KERNELS
@pytest.mark.parametrize("nrows, n, seed", [(8, 6, 4), (40, 23, 5), (61, 50, 6)])
def test_symmetric_row_products_mirror_the_upper_triangle(kernel, nrows, n, seed):
    A, first, end, taken = _rows(nrows, n, seed)
    rng = np.random.default_rng(seed + 200)
    X = rng.standard_normal((nrows, nrows))
    X = X + X.T
    X[np.abs(np.subtract.outer(np.arange(nrows), np.arange(nrows))) > 3] = 0.0  # banded
    X[:, nrows // 2] = X[nrows // 2, :] = 0.0  # the zero row of A has no row of B either
    B = X @ A
    b_first, b_end = np.zeros(nrows, np.int64), np.zeros(nrows, np.int64)
    for r in range(nrows):  # B's rows: the union of their neighbours' ranges
        near = [s for s in range(nrows) if X[r, s] != 0.0 and end[s] > first[s]]
        if near:
            b_first[r], b_end[r] = min(first[near]), max(end[near])
        else:
            B[r] = 0.0
    C = np.zeros(n * n)

    kernel(A.ravel(), B.ravel(), n, taken, taken.size,
                     _ranges(nrows, taken, first, end, b_first, b_end), True, C)

    C = C.reshape(n, n)
    assert np.array_equal(C, C.T)
    expected = _plain(A, B, taken, n)
    scale = np.abs(A[taken]).T @ np.abs(B[taken])
    # the mirrored entries are the upper triangle's sums: A^T X A's other order, round-off
    assert np.all(np.abs(C - expected) <= (nrows + 2) * np.finfo(float).eps
                  * (scale + scale.T))
