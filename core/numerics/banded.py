"""LU with partial pivoting of a banded matrix, in compact band storage, compiled.

The engine's constraint Jacobian J and its augmented system are sparse; ordered by
`bandwidth_order` (reverse Cuthill-McKee at packing) they are banded, with kl sub- and ku
super-diagonals, and a factorisation that only visits the band costs O(n kl (kl + ku))
instead of O(n^3): the difference between a refined stage's evaluation growing with the cube
of its size and growing linearly.

The algorithm is LAPACK's dgbtf2 / dgbtrs (partial pivoting within the kl rows below the
diagonal; the interchanges are applied to the active columns only, so the multipliers of a
column stay where they were computed and the solves apply the interchanges one column at a
time; the U factor has up to kl + ku super-diagonals).

Storage. Row i of the factorisation reaches columns i - kl to i + kl + ku (the pivoting
moves a row up by at most kl, bringing its ku super-diagonals with it), so the engine keeps
each row's 2 kl + ku + 1 entries side by side: entry (i, j) at a[i (2 kl + ku) + kl + j]
(the compact storage; row-major rows of LAPACK's band width; the entries of a row that fall
outside 0 <= j < n are never read). Where that is no smaller than the dense storage (a band
of more than a third of n), the storage is the dense (n, n) row-major one, entry (i, j) at
a[i n + j]. Which of the two an array is, its length says: n * n entries the dense one,
fewer (`storage_size`) the compact one (`layout`). The two run the same products in the same
order, so they give the same bits; against the dense storage the compact one clears in one
contiguous fill and keeps the rows of a 512-unknown band of 14 + 14 in 0.17 MB instead of
2 MB. With kl = ku = n - 1 it is an ordinary dense LU. `tests/test_banded.py` and
`tests/test_banded_storage.py` check it against numpy and scipy on random banded and dense
matrices.
"""

import numpy as np

from .jit import kernel


def storage_size(n, kl, ku):
    """Entries of the storage an (n, n) matrix of kl sub- and ku super-diagonals is packed
    in: n rows of 2 kl + ku + 1 (compact), or n * n (dense) when that is no larger."""
    return n * min(n, 2 * kl + ku + 1)


@kernel(inline="always")
def layout(size, n, kl, ku):
    """(step, shift) of a storage of `size` entries of an (n, n) band: entry (i, j) at
    a[i * step + shift + j]; the dense storage's (n, 0) when size == n * n, else the compact
    one's (2 kl + ku, kl)."""
    if size == n * n:
        return n, 0
    return 2 * kl + ku, kl


@kernel
def factor(a, n, piv, kl, ku):
    """Factor the banded a (its storage as `layout` says; zero outside kl sub- and ku
    super-diagonals) in place; piv (n,) the interchanges. Returns the ratio of the smallest
    to the largest pivot magnitude (0 for an exactly singular matrix)."""
    step, shift = layout(a.size, n, kl, ku)
    smallest, largest = np.inf, 0.0
    for k in range(n):
        last = min(n - 1, k + kl)
        right = min(n - 1, k + ku + kl)
        rk = k * step + shift  # entry (k, j) at a[rk + j]
        p, big = k, abs(a[rk + k])
        for i in range(k + 1, last + 1):
            value = abs(a[i * step + shift + k])
            if value > big:
                p, big = i, value
        piv[k] = p
        smallest, largest = min(smallest, big), max(largest, big)
        if big == 0.0:
            continue
        if p != k:
            rp = p * step + shift
            for j in range(k, right + 1):
                a[rk + j], a[rp + j] = a[rp + j], a[rk + j]
        inverse = 1.0 / a[rk + k]
        for i in range(k + 1, last + 1):
            ri = i * step + shift
            f = a[ri + k] * inverse
            a[ri + k] = f
            if f != 0.0:
                for j in range(k + 1, right + 1):
                    a[ri + j] -= f * a[rk + j]
    return smallest / largest if largest > 0.0 else 0.0


@kernel
def solve(a, n, piv, kl, ku, b):
    """Solve A z = b in place with the factors of `factor` (b (n,))."""
    step, shift = layout(a.size, n, kl, ku)
    for k in range(n):
        p = piv[k]
        if p != k:
            b[k], b[p] = b[p], b[k]
        bk = b[k]
        if bk != 0.0:
            for i in range(k + 1, min(n - 1, k + kl) + 1):
                b[i] -= a[i * step + shift + k] * bk
    w = kl + ku
    for i in range(n - 1, -1, -1):
        ri = i * step + shift
        s = b[i]
        for j in range(i + 1, min(n - 1, i + w) + 1):
            s -= a[ri + j] * b[j]
        b[i] = s / a[ri + i]


@kernel
def solve_transposed(a, n, piv, kl, ku, b):
    """Solve A^T z = b in place with the factors of `factor` (b (n,))."""
    step, shift = layout(a.size, n, kl, ku)
    w = kl + ku
    for i in range(n):  # U^T v = b
        s = b[i]
        for j in range(max(0, i - w), i):
            s -= a[j * step + shift + i] * b[j]
        b[i] = s / a[i * step + shift + i]
    for k in range(n - 1, -1, -1):  # then L^T and the interchanges, last column first
        s = b[k]
        for i in range(k + 1, min(n - 1, k + kl) + 1):
            s -= a[i * step + shift + k] * b[i]
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
