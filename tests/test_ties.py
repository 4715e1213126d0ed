"""Choices made by comparing numbers: equals (within ties.TIE_RTOL) go to the first in order,
so that the last bits of a CPU's round-off never decide (core/numerics/ties.py)."""

import copy

import numpy as np
import pytest

from flexure.core import build_model
from flexure.core.numerics.ties import TIE_RTOL, best_first, independent_rows, ordered
from flexure.core.scene.building import parse_toml, scene_path

ROUND_OFF = 4e-16  # a few ulps: what two CPUs' results of the same formula differ by


@pytest.mark.parametrize("first, second", [(1.0, 1.0 + ROUND_OFF), (1.0 + ROUND_OFF, 1.0)])
def test_best_first_takes_the_first_of_equals_whichever_is_larger_by_round_off(first, second):
    assert best_first([0.5, first, second]) == 1
    assert best_first([second, first, 0.5]) == 0
    assert best_first([2.0, first, second], largest=False) == 1


def test_best_first_keeps_a_real_difference_and_skips_nan():
    assert best_first([1.0, 1.0 + 10 * TIE_RTOL]) == 1
    assert best_first([np.nan, 1.0, 3.0, np.nan]) == 2
    with pytest.raises(ValueError, match="no candidate"):
        best_first([np.nan, np.nan])
    with pytest.raises(ValueError, match="no candidate"):
        best_first([])


def test_ordered_keeps_equals_in_their_order_and_sorts_the_rest():
    values = [3.0, 1.0 + ROUND_OFF, 2.0, 1.0, 1.0 - ROUND_OFF]
    assert ordered(values) == [1, 3, 4, 2, 0]
    assert ordered(values[::-1]) == [0, 1, 3, 2, 4]
    assert ordered([]) == []


def test_independent_rows_is_pivoted_qr_with_ties_in_order():
    """Two equal rows (up to round-off) and a third independent one: the first of the two is
    chosen whichever is larger by round-off, and the rank stops the choice."""
    tie = np.array([[1.0, 0.0, 0.0], [1.0 + ROUND_OFF, 0.0, 0.0], [0.0, 0.5, 0.0]])
    assert independent_rows(tie, 3) == [0, 2]
    assert independent_rows(tie[[1, 0, 2]], 3) == [0, 2]
    assert independent_rows(tie, 1) == [0]
    # the largest remaining part first, as LAPACK's geqp3 chooses when nothing ties
    rows = np.array([[0.1, 0.0], [0.0, 2.0], [1.0, 1.0]])
    assert independent_rows(rows, 1) == [1] and independent_rows(rows, 2) == [1, 2]
    assert independent_rows(np.zeros((2, 2)), 2) == []
    assert independent_rows(rows, 2, floor=10.0) == []


def test_a_dof_choice_tie_goes_to_the_first_node_of_the_scene():
    """The planar 1-DOF stage without its DOF: its two leaves' top nodes 3 and 5 move alike,
    so 3.x and 5.x tie; the one listed first in the scene is the DOF, and listing node 5
    first makes it 5.x (the frequencies do not change: the same mechanism)."""
    data = copy.deepcopy(parse_toml(scene_path("stage_planar_1dof")))
    for node in data["nodes"].values():
        node.pop("dof", None)
    assert build_model(data).chosen_dofs == ("3.x",)
    nodes = data["nodes"]
    data["nodes"] = {"5": nodes["5"], **{k: v for k, v in nodes.items() if k != "5"}}
    assert build_model(data).chosen_dofs == ("5.x",)


def _plain_independent_rows(rows, count, *, floor=0.0, relative=1e-6):
    """The greedy choice written out without dropping rows: the reference for the fast path,
    which leaves the chosen rows and those below half the threshold out of the updates."""
    remaining = np.array(rows, dtype=float)
    chosen, threshold = [], None
    available = np.ones(remaining.shape[0], dtype=bool)
    while len(chosen) < count and available.any():
        norms = np.where(available, np.linalg.norm(remaining, axis=1), np.nan)
        k = best_first(norms)
        threshold = max(relative * norms[k], floor) if threshold is None else threshold
        if not norms[k] > threshold:
            break
        chosen.append(k)
        available[k] = False
        direction = remaining[k] / norms[k]
        for _ in range(2):
            remaining -= np.outer(remaining @ direction, direction)
    return sorted(chosen)


@pytest.mark.parametrize("seed", range(5))
def test_independent_rows_drops_nothing_it_could_choose(seed):
    """Rank-deficient rows (copies, scaled copies and sums of others: many go to zero as
    their partners are chosen, as a mechanism's linked coordinates do), exact ties among
    them: the same choice as the plain loop."""
    rng = np.random.default_rng(seed)
    base = rng.normal(size=(30, 40))
    rows = np.vstack([base, base[:20] * 1.0, 2.0 * base[5:25], base[:10] + base[10:20],
                      1e-9 * rng.normal(size=(10, 40))])
    rows = rows[rng.permutation(rows.shape[0])]
    for count in (5, 30, 60):
        assert independent_rows(rows, count) == _plain_independent_rows(rows, count)


@pytest.mark.parametrize("seed", range(5))
def test_independent_rows_block_by_block_is_the_choice_over_all_rows(seed):
    """Rows that fall apart into independent blocks (permuted; rank-deficient blocks, the
    same block twice on other columns so that rows of different blocks tie exactly, an
    empty row, columns no row touches): the same choice, in the same order of ties, as the
    plain loop's updates over all rows."""
    rng = np.random.default_rng(seed)
    pieces = []
    for _ in range(4):
        base = rng.normal(size=(rng.integers(2, 6), rng.integers(3, 7)))
        piece = np.vstack([base, base[:1] * 2.0, base[:2].sum(axis=0, keepdims=True)])
        pieces += [piece, piece.copy()]  # the copy: exact ties across blocks
    width = sum(piece.shape[1] for piece in pieces) + 3
    rows = np.zeros((sum(piece.shape[0] for piece in pieces) + 1, width))
    r = c = 0
    for piece in pieces:
        rows[r:r + piece.shape[0], c:c + piece.shape[1]] = piece
        r, c = r + piece.shape[0], c + piece.shape[1]
    rows = rows[rng.permutation(rows.shape[0])][:, rng.permutation(width)]
    for count in (3, 12, rows.shape[0]):
        assert independent_rows(rows, count) == _plain_independent_rows(rows, count)
