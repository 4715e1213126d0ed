"""The dense LU kernels (flexure.core.numerics.dense) against numpy.

`lu_factor` (blocked) against the textbook loop `lu_factor_unblocked` (the same operations
on every entry in the same order: the same factors, pivots and pivot ratio to the bit on the
machine that runs both) and against numpy (P A = L U to the backward error of partial
pivoting), on sizes below, at and across the block, with exact zeros and a zero column.

`lu_solve_rows` solves a block of a larger row-major array in place for many right-hand
sides; it is checked against numpy.linalg.solve (to the backward error of partial pivoting)
and against `lu_solve` column by column (the same operations in the same order: equal to the
last bit on the machine that runs both), and the entries outside the block stay as they were.
"""

import numba
import numpy as np
import pytest

from flexure.core.numerics.dense import (
    BLOCK,
    lu_factor,
    lu_solve,
    lu_solve_rows,
)


@pytest.mark.parametrize("n, width, stride, start", [(1, 1, 1, 0), (5, 3, 7, 4),
                                                      (40, 80, 83, 13), (75, 150, 150, 75)])
def test_lu_solve_rows_solves_a_block_in_place(n, width, stride, start):
    rng = np.random.default_rng(n)
    A = rng.standard_normal((n, n))
    A[rng.random((n, n)) < 0.3] = 0.0  # zeros in the factors, which the solve skips
    A += np.diag(rng.uniform(0.5, 2.0, n))
    B = rng.standard_normal((n, width))
    lu, piv = A.ravel().copy(), np.zeros(n, dtype=np.int64)
    assert lu_factor(lu, n, piv) > 0.0
    flat = rng.standard_normal(start + n * stride + 5)
    for i in range(n):
        flat[start + i * stride: start + i * stride + width] = B[i]
    outside = np.ones(flat.size, dtype=bool)
    for i in range(n):
        outside[start + i * stride: start + i * stride + width] = False
    before = flat[outside].copy()

    lu_solve_rows(lu, n, piv, flat, start, stride, width)

    Z = np.array([flat[start + i * stride: start + i * stride + width] for i in range(n)])
    expected = np.linalg.solve(A, B)
    # backward-stable solve: |Z - Z_exact| <= cond(A) n eps |Z| (generously: 1e3 n eps cond)
    bound = 1e3 * n * np.finfo(float).eps * np.linalg.cond(A) * np.max(np.abs(expected))
    assert np.max(np.abs(Z - expected)) <= bound
    assert np.array_equal(flat[outside], before)
    for c in range(width):  # column by column with lu_solve: the same sums in the same order
        column = B[:, c].copy()
        lu_solve(lu, n, piv, column)
        np.testing.assert_allclose(Z[:, c], column, rtol=0.0,
                                   atol=4 * np.finfo(float).eps * np.max(np.abs(column)))


def _lu_factor_unblocked(a, n, piv):
    """`lu_factor` one elimination step at a time (right-looking, the textbook loop): the
    reference the blocked `lu_factor` is held against, to the bit."""
    smallest, largest = np.inf, 0.0
    for k in range(n):
        p, big = k, abs(a[k * n + k])
        for i in range(k + 1, n):
            value = abs(a[i * n + k])
            if value > big:
                p, big = i, value
        piv[k] = p
        if p != k:
            for j in range(n):
                a[k * n + j], a[p * n + j] = a[p * n + j], a[k * n + j]
        smallest, largest = min(smallest, big), max(largest, big)
        if big == 0.0:
            continue
        inverse = 1.0 / a[k * n + k]
        for i in range(k + 1, n):
            factor = a[i * n + k] * inverse
            a[i * n + k] = factor
            if factor != 0.0:
                for j in range(k + 1, n):
                    a[i * n + j] -= factor * a[k * n + j]
    return smallest / largest if largest > 0.0 else 0.0


lu_factor_unblocked = numba.njit(_lu_factor_unblocked)  # compiled as the kernel is


@pytest.mark.parametrize("n", [1, 7, BLOCK, BLOCK + 1, 3 * BLOCK + 5, 200])
def test_lu_factor_blocked_equals_the_textbook_loop(n):
    rng = np.random.default_rng(100 + n)
    A = rng.standard_normal((n, n))
    A[rng.random((n, n)) < 0.2] = 0.0
    if n > 3:
        A[:, n // 2] = 0.0  # a zero column: a zero pivot step, skipped by both
    blocked, reference = A.ravel().copy(), A.ravel().copy()
    piv, piv_reference = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
    ratio = lu_factor(blocked, n, piv)
    assert ratio == lu_factor_unblocked(reference, n, piv_reference)
    assert np.array_equal(piv, piv_reference)
    assert np.array_equal(blocked, reference)
    if n > 3:
        assert ratio == 0.0  # singular
    # P A = L U: the rows swapped in the order of the pivots
    LU = blocked.reshape(n, n)
    L, U = np.tril(LU, -1) + np.eye(n), np.triu(LU)
    PA = A.copy()
    for k in range(n):
        PA[[k, piv[k]]] = PA[[piv[k], k]]
    # backward error of Gaussian elimination: |L U - P A| <= n eps |L| |U| (Higham, 9.3)
    bound = n * np.finfo(float).eps * (np.abs(L) @ np.abs(U))
    assert np.all(np.abs(L @ U - PA) <= bound)
