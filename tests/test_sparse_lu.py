"""The sparse LU with kept pivots (core/numerics/sparse_lu.py) against numpy and scipy: random
sparse matrices, refactoring at new values, the transposed solve, two right-hand sides in one
pass, a kept pivot that vanishes (re-pivoting), a singular matrix, fill beyond the packed
room; the manipulator's J and augmented system in the slow tier."""

import numpy as np
import pytest
from scipy.sparse import random as sparse_random

from flexure.core.numerics import sparse_lu, sparse_lu_pair, sparse_lu_pattern, sparse_lu_pivots

EPS = 2.2e-16


def random_matrix(rng, n, density, zero_diagonal=False):
    a = sparse_random(n, n, density=density, random_state=rng).toarray()
    a += np.diag(rng.uniform(0.5, 1.5, n) * rng.choice([-1, 1], n))
    if zero_diagonal and n > 1:  # 2 x 2 blocks [[0, 2], [2, d]] need pivoting off the diagonal
        i = np.arange(0, n - 1, 3)
        a[i, i] = 0.0
        a[i, i + 1] += 2.0
        a[i + 1, i] += 2.0
    return a


def analysed(a):
    rows, cols = np.nonzero(a)
    return sparse_lu.StaticLU(a.shape[0], rows, cols, a[rows, cols])


def random_case(seed, n, density, zero_diagonal=False):
    """A generator seeded with `seed`, a random matrix of it and that matrix analysed."""
    rng = np.random.default_rng(seed)
    a = random_matrix(rng, n, density, zero_diagonal)
    return rng, a, analysed(a)


def factor(lu):
    """Factor with pivoting afresh: the pivot ratio (> 0), REJECTED or CAPACITY."""
    return sparse_lu.factor(lu.ints, lu.floats, sparse_lu.THRESHOLD)


def refactor(lu):
    """Factor on the kept pivots: the pivot ratio (> 0) or REJECTED."""
    return sparse_lu.refactor(lu.ints, lu.floats, sparse_lu.THRESHOLD)


def assert_solves(lu, a, rng, floats=None):
    """A z = b and A^T z = b against numpy.linalg.solve, to 100 cond(A) eps of the solution:
    the forward error bound of a backward-stable solve, with room for the growth that the
    threshold (multipliers up to 10) allows."""
    floats = lu.floats if floats is None else floats
    b = rng.standard_normal(a.shape[0])
    for transposed, matrix in ((False, a), (True, a.T)):
        z = b.copy()
        sparse_lu.solve(lu.ints, floats, z, transposed)
        expected = np.linalg.solve(matrix, b)
        bound = 100 * np.linalg.cond(a) * EPS * np.max(np.abs(expected))
        assert np.max(np.abs(z - expected)) <= bound


@pytest.mark.parametrize("n, density", [(1, 1.0), (12, 0.3), (60, 0.05), (150, 0.02)])
@pytest.mark.parametrize("zero_diagonal", [False, True])
def test_factors_at_the_reference_solve_as_numpy(n, density, zero_diagonal):
    rng, a, lu = random_case(n, n, density, zero_diagonal)
    assert lu.ordering in sparse_lu.ORDERINGS
    assert_solves(lu, a, rng)
    # the counted work: a solve visits each entry of L and U once, and U has the diagonal
    assert lu.multiplications["solve"] >= n and lu.multiplications["factor"] >= 0


@pytest.mark.parametrize("n, density", [(40, 0.08), (120, 0.03)])
def test_refactor_at_new_values_keeps_the_pivots_and_solves(n, density):
    """New values on the same pattern: the kept pivots pass their test (the values moved by
    10 %) and the factors solve as numpy; the matrix put back by scatter_dense is A."""
    rng, a, lu = random_case(7, n, density)
    rows, cols = np.nonzero(a)
    moved = a.copy()
    moved[rows, cols] *= 1.0 + 0.1 * rng.uniform(-1.0, 1.0, rows.size)
    lu.set_matrix(moved)
    assert refactor(lu) > 0.0
    assert_solves(lu, moved, rng)
    dense = np.zeros(n * n)
    sparse_lu.scatter_dense(lu.ints, lu.floats, dense, np.arange(n), np.arange(n))
    assert np.array_equal(dense.reshape(n, n), moved)
    # another row and column order of the same matrix
    order = rng.permutation(n)
    dense[:] = 0.0
    sparse_lu.scatter_dense(lu.ints, lu.floats, dense, order, order)
    assert np.array_equal(dense.reshape(n, n)[np.ix_(order, order)], moved)


@pytest.mark.parametrize("n, density", [(1, 0.0), (12, 0.2), (60, 0.05)])
def test_a_pair_of_right_hand_sides_solves_as_each_alone(n, density):
    """`solve_pair` against `solve` of each vector: equal values (its pass subtracts products
    with zero where one vector's entry is zero and the other's not), among them vectors with
    zeros where the other has none (one all zero), and against numpy within `assert_solves`'
    bound."""
    rng, a, lu = random_case(n + 7, n, density)
    assert factor(lu) > 0.0
    b, c = rng.standard_normal(n), rng.standard_normal(n)
    c[: n // 2] = 0.0
    for first, second in ((b, c), (c, b), (b, np.zeros(n))):
        x, y, work = first.copy(), second.copy(), np.full(n, np.nan)
        sparse_lu_pair.solve_pair(lu.ints, lu.floats, x, y, work)
        for solved, vector in ((x, first), (y, second)):
            alone = vector.copy()
            sparse_lu.solve(lu.ints, lu.floats, alone, False)
            assert np.array_equal(solved, alone)
            expected = np.linalg.solve(a, vector)
            bound = 100 * np.linalg.cond(a) * EPS * max(np.max(np.abs(expected)), 1e-300)
            assert np.max(np.abs(solved - expected)) <= bound


def test_a_kept_pivot_that_vanishes_is_rejected_and_the_matrix_pivots_afresh():
    """Pivot 0 of a 2 x 2 block [[1, 1], [1e-3, 1]] at the reference: row 0. With its
    entry at 1e-3 and the other at 1, the kept pivot fails the threshold test (1e-3 < 0.1):
    refactor says REJECTED, factor pivots on row 1 instead and solves as numpy; refactor
    then keeps the new pivots."""
    rng = np.random.default_rng(3)
    a = random_matrix(rng, 30, 0.05)
    a[:2, :2] = [[1.0, 1.0], [1e-3, 1.0]]
    lu = analysed(a)
    moved = a.copy()
    moved[:2, :2] = [[1e-3, 1.0], [1.0, 1.0]]
    lu.set_matrix(moved)
    assert refactor(lu) == sparse_lu.REJECTED
    x = lu.floats[-30:]  # the work vector is left clean
    assert np.all(x == 0.0)
    assert factor(lu) > 0.0
    assert_solves(lu, moved, rng)
    assert refactor(lu) > 0.0
    assert_solves(lu, moved, rng)
    # an exactly vanishing pivot too
    moved[:2, :2] = [[0.0, 1.0], [1.0, 1.0]]
    lu.set_matrix(moved)
    refactored = refactor(lu)
    if refactored == sparse_lu.REJECTED:
        assert factor(lu) > 0.0
    assert_solves(lu, moved, rng)


def test_a_singular_matrix_is_rejected_and_refused_at_packing():
    rng, a, lu = random_case(4, 20, 0.1)
    singular = a.copy()
    singular[:, 5] = 0.0
    lu.set_matrix(singular)
    assert refactor(lu) == sparse_lu.REJECTED
    assert factor(lu) == sparse_lu.REJECTED
    # no factorisation is kept: refactor refuses until a factor works
    lu.set_matrix(a)
    assert refactor(lu) == sparse_lu.REJECTED
    assert factor(lu) > 0.0
    with pytest.raises(ValueError, match="singular at the reference point"):
        rows, cols = np.nonzero(a)
        sparse_lu.StaticLU(20, rows, cols, singular[rows, cols])


def test_fill_beyond_the_packed_room_is_reported():
    """An arrow matrix (diagonal, full first row and column) factors on its diagonal with the
    full part last: L and U hold 59 and 119 entries, packed with no slack (room 120). With
    the diagonal but the first at 1e-9 the full row becomes a pivot and U fills in beyond
    the room: CAPACITY, and no factorisation is kept."""
    n = 60
    a = np.eye(n) * 4.0
    a[0, :] = a[:, 0] = 1.0
    a[0, 0] = 4.0
    rows, cols = np.nonzero(a)
    lu = sparse_lu.StaticLU(n, rows, cols, a[rows, cols], slack=0)
    assert lu.multiplications["solve"] == 59 + 119
    rng = np.random.default_rng(6)
    swapped = a.copy()
    swapped[np.arange(1, n), np.arange(1, n)] = rng.uniform(1e-9, 2e-9, n - 1)
    lu.set_matrix(swapped)
    assert refactor(lu) == sparse_lu.REJECTED
    assert factor(lu) == sparse_lu.CAPACITY
    assert refactor(lu) == sparse_lu.REJECTED
    # with the default room the same matrix factors, and solves
    roomy = analysed(a)
    roomy.set_matrix(swapped)
    assert factor(roomy) > 0.0
    assert_solves(roomy, swapped, rng)


def test_slots_name_the_entries_of_the_pattern():
    rng, a, lu = random_case(5, 25, 0.1)
    rows, cols = np.nonzero(a)
    values = sparse_lu.matrix_values(lu.ints, lu.floats)
    values[:] = 0.0
    values[lu.slot(rows, cols)] = a[rows, cols]
    assert factor(lu) > 0.0
    assert_solves(lu, a, rng)
    outside = np.argwhere(a == 0.0)[0]
    with pytest.raises(ValueError, match=rf"entry \({outside[0]}, {outside[1]}\) is not in"):
        lu.slot([outside[0]], [outside[1]])


@pytest.mark.parametrize("n, density", [(12, 0.3), (60, 0.05)])
def test_the_pattern_read_in_python_rebuilds_the_matrix(n, density):
    """`pattern` (the packed ints read without numba) with the values in their packed order
    gives A back, after a factorisation too (the factors do not overwrite A's values)."""
    from scipy.sparse import csc_matrix

    _, a, lu = random_case(7, n, density)
    for _ in range(2):
        size, rows, columns = sparse_lu_pattern.pattern(lu.ints)
        values = lu.floats[: rows.size]
        rebuilt = csc_matrix((values, (rows, columns)), shape=(size, size)).toarray()
        assert size == n and np.array_equal(rebuilt, a)
        assert factor(lu) > 0.0


def test_the_sparsest_row_kernel_against_a_plain_choice():
    """`sparse_lu_pivots.sparsest_row` against the rule written out: of the rows not yet
    pivotal with |x| >= bound, the fewest entries in A, then the largest |x|."""
    rng = np.random.default_rng(11)
    for _ in range(200):
        n = int(rng.integers(1, 12))
        x = rng.standard_normal(n) * rng.choice([0.0, 1.0], n, p=[0.2, 0.8])
        counts = rng.integers(1, 4, n)  # ties of counts are common
        pinv = np.where(rng.uniform(size=n) < 0.3, 0, -1)
        top = int(rng.integers(0, n + 1))
        stack = np.concatenate([np.zeros(top, dtype=np.int64), rng.permutation(n)[top:]])
        bound = 0.5 * np.max(np.abs(x)) if rng.uniform() < 0.8 else 0.0
        candidates = [i for i in stack[top:] if pinv[i] < 0 and abs(x[i]) >= bound]
        expected = min(candidates, key=lambda i: (counts[i], -abs(x[i])), default=-1)
        assert sparse_lu_pivots.sparsest_row(x, stack, top, n, pinv, counts, bound) == expected


def unit_row_matrix(rng, m):
    """[[B, C], [0, I]] (2 m, 2 m): B diagonally dominant (diagonal 2 to 3, off it up to
    0.05: multipliers under 0.1 whatever the order), C two entries of 1.2 to 1.4 a column,
    so a column of C has |x| < 2 at its turn; the unit rows below: partial pivoting takes a
    row of B's (|x| > 1), the sparsest-row choice the unit row (1 >= KEEP 2)."""
    b = 0.05 * sparse_random(m, m, density=0.1, random_state=rng).toarray()
    b += np.diag(rng.uniform(2.0, 3.0, m))
    c = np.zeros((m, m))
    for k in range(m):
        c[rng.choice(m, 2, replace=False), k] = rng.uniform(1.2, 1.4, 2) * rng.choice([-1, 1], 2)
    return np.block([[b, c], [np.zeros((m, m)), np.eye(m)]])


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_sparsest_rows_pivot_on_unit_rows_and_solve_as_numpy(seed):
    """With sparsest_rows every unit row is the pivot of its column, the factors solve as
    numpy, at the reference and refactored at moved values, and take no more multiplications
    than partial pivoting's."""
    rng = np.random.default_rng(seed)
    m = 20
    n = 2 * m
    a = unit_row_matrix(rng, m)
    rows, cols = np.nonzero(a)
    plain = sparse_lu.StaticLU(n, rows, cols, a[rows, cols])
    lu = sparse_lu.StaticLU(n, rows, cols, a[rows, cols], sparsest_rows=True)
    parts = sparse_lu.packed_parts(lu.ints, lu.floats)
    prow, pinv, pcol = parts[7], parts[8], parts[9]
    for u in range(m, n):
        assert prow[pinv[u]] == u and pcol[pinv[u]] == u
    assert lu.multiplications["factor"] < plain.multiplications["factor"]
    assert lu.multiplications["solve"] < plain.multiplications["solve"]
    assert_solves(lu, a, rng)
    moved = a.copy()
    moved[rows, cols] *= 1.0 + 0.1 * rng.uniform(-1.0, 1.0, rows.size)
    lu.set_matrix(moved)
    assert refactor(lu) > 0.0
    assert_solves(lu, moved, rng)


def plain_pivots(a, pcol, old, threshold):
    """The pivot rows (by position) of a dense left-looking LU of a[:, pcol] that chooses as
    `factor` with sparsest_rows: the old pivot of the position while |x| >= max(threshold,
    KEEP) max |x|, else of the rows with |x| >= KEEP max |x| the fewest entries in a, the
    largest |x| on a tie; and how many of them are not the largest |x| of their column."""
    n = a.shape[0]
    counts = np.count_nonzero(a, axis=1)
    bound_factor = max(threshold, sparse_lu.KEEP)
    L = np.zeros((n, n))
    pivots, pivotal, smaller = [], np.zeros(n, dtype=bool), 0
    for j, column in enumerate(pcol):
        x = a[:, column].astype(float)
        for k, r in enumerate(pivots):  # in pivot order: a topological order of L
            x -= L[:, k] * x[r]
        free = np.flatnonzero(~pivotal & (x != 0.0))
        big = np.max(np.abs(x[free]))
        if old[j] >= 0 and not pivotal[old[j]] and abs(x[old[j]]) >= bound_factor * big:
            chosen = old[j]
        else:
            eligible = free[np.abs(x[free]) >= bound_factor * big]
            chosen = min(eligible, key=lambda i: (counts[i], -abs(x[i])))
        smaller += abs(x[chosen]) < big
        pivots.append(chosen)
        pivotal[chosen] = True
        L[:, j] = np.where(pivotal, 0.0, x / x[chosen])
    return np.array(pivots), smaller


@pytest.mark.parametrize("seed", [4, 5, 6])
def test_the_sparsest_rows_choice_against_a_plain_lu(seed):
    """The pivots of StaticLU with sparsest_rows (at the reference: no seeds) and of a
    re-pivoting `factor` (the kept pivots as seeds) against `plain_pivots`, on random
    matrices with unit rows and zero diagonal entries, and the factors solve as numpy."""
    rng = np.random.default_rng(seed)
    n = 40
    a = random_matrix(rng, n, 0.08, zero_diagonal=True)
    units = np.arange(n - 5, n)
    a[units, :] = 0.0
    a[units, units] = 1.0  # unit rows, beside larger entries of other rows in their columns
    a[rng.choice(n - 5, 5), units] = rng.uniform(1.2, 1.6, 5)
    rows, cols = np.nonzero(a)
    lu = sparse_lu.StaticLU(n, rows, cols, a[rows, cols], sparsest_rows=True)
    parts = sparse_lu.packed_parts(lu.ints, lu.floats)
    prow, pcol = parts[7], parts[9]
    expected, smaller = plain_pivots(a, pcol, np.full(n, -1), sparse_lu.THRESHOLD)
    assert np.array_equal(prow, expected)
    assert smaller > 0  # partial pivoting would have chosen otherwise
    assert_solves(lu, a, rng)
    moved = a.copy()
    moved[rows, cols] *= rng.uniform(0.2, 5.0, rows.size)  # many kept pivots fail KEEP
    lu.set_matrix(moved)
    old = prow.copy()
    assert factor(lu) > 0.0
    assert np.array_equal(prow, plain_pivots(moved, pcol, old, sparse_lu.THRESHOLD)[0])
    assert not np.array_equal(prow, old)  # some pivots were chosen afresh
    assert_solves(lu, moved, rng)
