"""The graph orders of a sparse pattern (core/numerics/graph_orders.py) against scipy's
csgraph: a matching as large as scipy's maximum one, valid, and the reverse Cuthill-McKee
bandwidths of scipy's own within a stated factor; both the same on a second call."""

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching, reverse_cuthill_mckee

from flexure.core.numerics import graph_orders


def _random_pattern(rng, n, density, diagonal):
    mask = rng.random((n, n)) < density
    if diagonal:
        mask |= np.eye(n, dtype=bool)[rng.permutation(n)]  # structurally nonsingular
    return np.nonzero(mask)


def _bandwidth(rows, cols, order):
    position = np.empty(order.size, dtype=np.int64)
    position[order] = np.arange(order.size)
    return int(np.max(np.abs(position[rows] - position[cols]), initial=0))


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("diagonal", [True, False])
def test_matching_is_maximum_and_valid(seed, diagonal):
    rng = np.random.default_rng(seed)
    n = 40 + 20 * seed
    rows, cols = _random_pattern(rng, n, 2.5 / n, diagonal)
    ours = graph_orders.matching(rows, cols, n)
    pattern = coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n)).tocsr()
    theirs = maximum_bipartite_matching(pattern, perm_type="column")
    assert np.sum(ours >= 0) == np.sum(theirs >= 0)
    matched = ours[ours >= 0]
    assert matched.size == np.unique(matched).size  # each column at most once
    entries = set(zip(rows.tolist(), cols.tolist(), strict=True))
    assert all((r, c) in entries for r, c in enumerate(ours.tolist()) if c >= 0)
    if diagonal:
        assert np.all(ours >= 0)
    assert np.array_equal(ours, graph_orders.matching(rows, cols, n))


def test_matching_of_a_long_alternating_path():
    """A pattern whose greedy start leaves one row free that only an augmenting path through
    every other row can match (row i -> columns i and i+1, row n-1 -> column 0)."""
    n = 3000
    rows = np.concatenate([np.arange(n - 1), np.arange(n - 1), [n - 1]])
    cols = np.concatenate([np.arange(n - 1), np.arange(1, n), [0]])
    ours = graph_orders.matching(rows, cols, n)
    assert np.all(ours >= 0) and np.unique(ours).size == n


@pytest.mark.parametrize("seed", range(6))
def test_reverse_cuthill_mckee_bands_as_scipy_does(seed):
    """On random symmetric patterns of a hidden band under a random permutation, the
    bandwidth is within 1.5 times scipy's (the same algorithm; ties are broken by index)."""
    rng = np.random.default_rng(10 + seed)
    n, width = 60 + 30 * seed, 2 + seed
    i, j = np.nonzero(np.abs(np.subtract.outer(np.arange(n), np.arange(n))) <= width)
    keep = rng.random(i.size) < 0.7
    shuffle = rng.permutation(n)
    rows, cols = shuffle[i[keep]], shuffle[j[keep]]
    order = graph_orders.reverse_cuthill_mckee(rows, cols, n)
    assert np.array_equal(np.sort(order), np.arange(n))
    symmetric = coo_matrix((np.ones(2 * rows.size), (np.r_[rows, cols], np.r_[cols, rows])),
                           shape=(n, n)).tocsr()
    theirs = np.asarray(reverse_cuthill_mckee(symmetric, symmetric_mode=True))
    assert _bandwidth(rows, cols, order) <= 1.5 * _bandwidth(rows, cols, theirs)
    assert _bandwidth(rows, cols, order) <= 2 * width + 2  # near the hidden band
    assert np.array_equal(order, graph_orders.reverse_cuthill_mckee(rows, cols, n))


def test_reverse_cuthill_mckee_orders_every_component():
    """Two separate paths and an isolated node: every node once, each path banded."""
    rows = np.array([0, 1, 2, 5, 6])
    cols = np.array([1, 2, 3, 6, 7])
    order = graph_orders.reverse_cuthill_mckee(rows, cols, 9)
    assert np.array_equal(np.sort(order), np.arange(9))
    assert _bandwidth(rows, cols, order) == 1
