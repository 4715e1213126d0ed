"""The banded LU (core/numerics/banded.py) against numpy on random banded and dense matrices."""

import numpy as np
import pytest
from scipy.sparse import random as sparse_random

from flexure.core.numerics import banded


def banded_matrix(rng, n, kl, ku, zero_diagonal=False):
    a = rng.standard_normal((n, n))
    i, j = np.indices((n, n))
    a[(i - j > kl) | (j - i > ku)] = 0.0
    if zero_diagonal:  # a saddle point block needs the pivoting
        a[np.arange(0, n, 3), np.arange(0, n, 3)] = 0.0
    return a


@pytest.mark.parametrize("n, kl, ku", [(1, 0, 0), (7, 6, 6), (40, 3, 5), (60, 8, 2),
                                       (33, 0, 4)])
@pytest.mark.parametrize("zero_diagonal", [False, True])
def test_solves_match_numpy(n, kl, ku, zero_diagonal):
    rng = np.random.default_rng(n + kl + 10 * ku)
    a = banded_matrix(rng, n, kl, ku, zero_diagonal)
    if abs(np.linalg.det(a)) < 1e-8:
        a += np.eye(n)
    b = rng.standard_normal(n)
    lu, piv = a.ravel().copy(), np.zeros(n, dtype=np.int64)
    assert banded.factor(lu, n, piv, kl, ku) > 0.0
    z, zt = b.copy(), b.copy()
    banded.solve(lu, n, piv, kl, ku, z)
    banded.solve_transposed(lu, n, piv, kl, ku, zt)
    for got, expected in ((z, np.linalg.solve(a, b)), (zt, np.linalg.solve(a.T, b))):
        # the forward error bound of a backward-stable solve: cond(A) eps |z|
        bound = 10 * np.linalg.cond(a) * 2.2e-16 * np.max(np.abs(expected))
        assert np.max(np.abs(got - expected)) <= bound


def test_a_singular_matrix_has_a_zero_pivot_ratio():
    a = np.zeros((4, 4))
    a[0, 0] = a[1, 1] = a[3, 3] = 1.0
    assert banded.factor(a.ravel().copy(), 4, np.zeros(4, dtype=np.int64), 1, 1) == 0.0


def test_bandwidth_order_bands_a_shuffled_band():
    """A tridiagonal pattern under a random symmetric permutation: the order gets back a
    bandwidth of 1 (RCM is exact on a path graph)."""
    n = 50
    rng = np.random.default_rng(3)
    band = banded_matrix(rng, n, 1, 1) + np.eye(n)
    shuffle = rng.permutation(n)
    pattern = band[np.ix_(shuffle, shuffle)]
    order, kl, ku = banded.bandwidth_order(*np.nonzero(pattern), n)
    assert sorted(order) == list(range(n)) and (kl, ku) == (1, 1)
    permuted = pattern[np.ix_(order, order)]
    i, j = np.nonzero(permuted)
    assert np.max(i - j) == kl and np.max(j - i) == ku
    random = sparse_random(30, 30, density=0.1, random_state=4) + np.eye(30)
    order, kl, ku = banded.bandwidth_order(*np.nonzero(random), 30)
    assert sorted(order) == list(range(30)) and 0 <= kl < 30 and 0 <= ku < 30
