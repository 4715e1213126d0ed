"""LU with partial pivoting of a banded matrix kept in dense row-major storage, compiled.

The engine's constraint Jacobian J and its augmented system are sparse; ordered by
`bandwidth_order` (reverse Cuthill-McKee at packing) they are banded, with kl sub- and ku
super-diagonals, and a factorisation that only visits the band costs O(n kl (kl + ku))
instead of O(n^3): the difference between a refined stage's evaluation growing with the cube
of its size and growing linearly.

The algorithm is LAPACK's dgbtf2 / dgbtrs (partial pivoting within the kl rows below the
diagonal; the interchanges are applied to the active columns only, so the multipliers of a
column stay where they were computed and the solves apply the interchanges one column at a
time; the U factor has up to kl + ku super-diagonals). The storage stays dense (n, n): the
matrices are a few hundred rows at most, and dense storage keeps the assembly simple. With
kl = ku = n - 1 it is an ordinary dense LU. `tests/test_banded.py` checks it against
numpy.linalg.solve on random banded and dense matrices.
"""

import numpy as np

from .jit import kernel


@kernel
def factor(a, n, piv, kl, ku):
    """Factor the (n, n) row-major a (zero outside kl sub- and ku super-diagonals) in place;
    piv (n,) the interchanges. Returns the ratio of the smallest to the largest pivot
    magnitude (0 for an exactly singular matrix)."""
    smallest, largest = np.inf, 0.0
    for k in range(n):
        last = min(n - 1, k + kl)
        right = min(n - 1, k + ku + kl)
        p, big = k, abs(a[k * n + k])
        for i in range(k + 1, last + 1):
            value = abs(a[i * n + k])
            if value > big:
                p, big = i, value
        piv[k] = p
        smallest, largest = min(smallest, big), max(largest, big)
        if big == 0.0:
            continue
        if p != k:
            for j in range(k, right + 1):
                a[k * n + j], a[p * n + j] = a[p * n + j], a[k * n + j]
        inverse = 1.0 / a[k * n + k]
        for i in range(k + 1, last + 1):
            f = a[i * n + k] * inverse
            a[i * n + k] = f
            if f != 0.0:
                for j in range(k + 1, right + 1):
                    a[i * n + j] -= f * a[k * n + j]
    return smallest / largest if largest > 0.0 else 0.0


@kernel
def solve(a, n, piv, kl, ku, b):
    """Solve A z = b in place with the factors of `factor`."""
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
        bk = b[k]
        if bk != 0.0:
            for i in range(k + 1, min(n - 1, k + kl) + 1):
                b[i] -= a[i * n + k] * bk
    w = kl + ku
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, min(n - 1, i + w) + 1):
            s -= a[i * n + j] * b[j]
        b[i] = s / a[i * n + i]


@kernel
def solve_transposed(a, n, piv, kl, ku, b):
    """Solve A^T z = b in place with the factors of `factor`."""
    w = kl + ku
    for i in range(n):  # U^T v = b
        s = b[i]
        for j in range(max(0, i - w), i):
            s -= a[j * n + i] * b[j]
        b[i] = s / a[i * n + i]
    for k in range(n - 1, -1, -1):  # then L^T and the interchanges, last column first
        s = b[k]
        for i in range(k + 1, min(n - 1, k + kl) + 1):
            s -= a[i * n + k] * b[i]
        b[k] = s
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]


def bandwidth_order(rows, cols, n):
    """A symmetric permutation that makes the (n, n) sparsity pattern with the entries
    (rows[k], cols[k]) banded: reverse Cuthill-McKee on the pattern and its transpose
    (`graph_orders`). Returns (order, kl, ku): order[i] the original index at position i, kl
    and ku the sub- and super-diagonal widths of the permuted pattern."""
    from .graph_orders import reverse_cuthill_mckee

    rows, cols = np.asarray(rows, dtype=np.int64), np.asarray(cols, dtype=np.int64)
    if n == 0:
        return np.zeros(0, dtype=np.int64), 0, 0
    order = reverse_cuthill_mckee(rows, cols, n)
    position = np.empty(n, dtype=np.int64)
    position[order] = np.arange(n)
    offsets = position[rows] - position[cols]
    kl = int(max(0, offsets.max(initial=0)))
    ku = int(max(0, -offsets.min(initial=0)))
    return order, kl, ku
