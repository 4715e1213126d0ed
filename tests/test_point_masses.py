"""The element inertia kernels of core/engine/point_masses.py against plain numpy.

An element's point forces w = Mp f and mass Me = Dp^T Mp Dp, for a symmetric Mp filled on a
pattern of its entries and a Dp with exact zeros (as a BEAM's: each point moves with few
coordinates), from `element_mass` (over Dp's non-zeros) and `dense_element_mass` (whole rows
of a padded width), against the dense products.
"""

import numpy as np
import pytest

from flexure.core.engine.point_masses import (
    dense_element_mass,
    element_mass,
    mass_rows_product,
    massless,
    padded_width,
    point_columns,
    point_forces,
    sparse_rows_product,
)


def element(P, m, seed):
    """(Mp (P P,), pattern (ascending flat p P + q), Dp (P, m)) of a random element: Mp
    symmetric with about half its entries zero, Dp with about two thirds zero."""
    rng = np.random.default_rng(seed)
    Mp = rng.standard_normal((P, P))
    Mp = Mp + Mp.T
    Mp[rng.random((P, P)) < 0.5] = 0.0
    Mp = np.where(Mp.T == 0.0, 0.0, Mp)  # symmetric again: zero where either is
    Dp = rng.standard_normal((P, m))
    Dp[rng.random((P, m)) < 0.65] = 0.0
    return Mp.ravel(), np.flatnonzero(Mp.ravel()).astype(np.int64), Dp


@pytest.mark.parametrize("P, m", [(24, 14), (9, 4), (5, 17)])
def test_element_mass(P, m):
    """w = Mp f, Me = Dp^T Mp Dp and Dp's non-zero columns per row, to round-off."""
    Mp, pattern, Dp = element(P, m, seed=P + m)
    f = np.random.default_rng(1).standard_normal(P)
    w, Me = np.zeros(P), np.zeros(m * m)
    columns = np.full(P * (m + 1) + m, -7, dtype=np.int64)
    element_mass(Mp, pattern, P, m, Dp, f, w, Me, columns)
    M = Mp.reshape(P, P)
    expected = Dp.T @ M @ Dp
    assert np.max(np.abs(Me - expected.ravel())) <= 1e-13 * np.max(np.abs(expected))
    assert np.max(np.abs(w - M @ f)) <= 1e-13 * np.max(np.abs(M @ f))
    counts = columns[P * m: P * m + P]
    for p in range(P):
        assert list(columns[p * m: p * m + counts[p]]) == list(np.flatnonzero(Dp[p]))
    w2 = np.zeros(P)
    point_forces(Mp, pattern, P, f, w2)
    assert np.array_equal(w2, w)


@pytest.mark.parametrize("P, m", [(24, 14), (24, 16), (5, 17), (9, 4)])
def test_dense_element_mass(P, m):
    """Me = D^T Mp D from D in rows of the padded width, packed to m * m, to round-off; with
    a vector d in D's column m (a padding lane), column m of the product D^T Mp d, to
    round-off, and nothing else changed by it (Me to the bit)."""
    Mp, pattern, D = element(P, m, seed=2 * P + m)
    stride = padded_width(m)
    assert stride >= m and stride % 16 == 0
    padded = np.zeros((P, stride))
    padded[:, :m] = D
    MD, Me = np.full(P * stride, np.nan), np.full(m * stride, np.nan)
    dense_element_mass(Mp, pattern, P, m, padded.ravel(), MD, Me, stride, np.zeros(0))
    expected = D.T @ Mp.reshape(P, P) @ D
    assert np.max(np.abs(Me[: m * m] - expected.ravel())) <= 1e-13 * np.max(np.abs(expected))
    stride = padded_width(m + 1)
    d = np.random.default_rng(3).standard_normal(P)
    padded = np.zeros((P, stride))
    padded[:, :m], padded[:, m] = D, d
    MD2, Me2, column = np.full(P * stride, np.nan), np.full(m * stride, np.nan), \
        np.full(m, np.nan)
    dense_element_mass(Mp, pattern, P, m, padded.ravel(), MD2, Me2, stride, column)
    assert np.array_equal(Me2[: m * m], Me[: m * m])
    expected = D.T @ Mp.reshape(P, P) @ d
    assert np.max(np.abs(column - expected)) <= 1e-13 * np.max(np.abs(expected))


@pytest.mark.parametrize("P, stride", [(24, 16), (9, 75), (5, 1)])
def test_mass_rows_product(P, stride):
    """MD = Mp D along rows of any length (the reduced form's Mp (Dp DF_e) has NDOF), to
    round-off; one column is `point_forces`' w = Mp f, the same sums to the bit."""
    Mp, pattern, _ = element(P, 3, seed=4 * P + stride)
    D = np.random.default_rng(5).standard_normal((P, stride))
    MD = np.full(P * stride, np.nan)
    mass_rows_product(Mp, pattern, P, D.ravel(), stride, MD)
    expected = Mp.reshape(P, P) @ D
    assert np.max(np.abs(MD - expected.ravel())) <= 1e-13 * np.max(np.abs(expected))
    w = np.full(P, np.nan)
    point_forces(Mp, pattern, P, D[:, 0].copy(), w)
    assert np.array_equal(w, MD[::stride])


@pytest.mark.parametrize("P, m, mz", [(24, 14, 14), (9, 4, 7), (5, 17, 20)])
def test_sparse_rows_product(P, m, mz):
    """Dp T over Dp's non-zero columns, in rows of the padded width (zero past mz)."""
    _, _, Dp = element(P, m, seed=3 * P + m)
    T = np.random.default_rng(4).standard_normal((m, mz))
    stride = padded_width(mz)
    padded = np.zeros((m, stride))
    padded[:, :mz] = T
    columns = np.zeros(P * (m + 1) + m, dtype=np.int64)
    point_columns(P, m, Dp, columns)
    D = np.full(P * stride, np.nan)
    sparse_rows_product(P, m, Dp, columns, padded.ravel(), stride, D)
    D = D.reshape(P, stride)
    expected = Dp @ T
    assert np.max(np.abs(D[:, :mz] - expected)) <= 1e-14 * np.max(np.abs(expected))
    assert np.array_equal(D[:, mz:], np.zeros((P, stride - mz)))


@pytest.mark.parametrize("P", [1, 9, 24])
def test_massless(P):
    """Whether Mp is zero on its pattern: as numpy says, for a massive Mp, one whose pattern
    holds only zeros, and one with a single entry left."""
    Mp, pattern, _ = element(P, 4, seed=P)
    assert massless(Mp, pattern) == (not np.any(Mp[pattern]))
    zero = np.zeros_like(Mp)
    assert massless(zero, pattern)
    one = zero.copy()
    one[pattern[-1]] = 1e-30
    assert not massless(one, pattern)
