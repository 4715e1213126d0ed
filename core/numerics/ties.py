"""Choices made by comparing numbers, made the same on every CPU.

Floating-point results differ in their last bits from one machine to the next: numba compiles
for the host CPU (which decides, among others, whether a * b + c is fused), numpy and OpenBLAS
choose their kernels by the CPU's instruction set. A choice between two numbers that are equal
in exact arithmetic (the two leaves of a symmetric parallel guide, two nodes that move alike)
would then be decided by round-off and flip with the machine. Every such choice in flexure
follows one rule, implemented here:

    Candidates whose measure lies within TIE_RTOL times the largest measure of the best one
    count as equal, and among equals the candidates' own order (the scene's order) decides.

TIE_RTOL = 1e-8 is far above the round-off of the measures compared (about 1e-15 relative
for the projections and energy shares in question, 1e-12 for ill-conditioned ones) and far
below any difference a designer would call a preference.
"""

import numpy as np

from .sparse_blocks import blocks

TIE_RTOL = 1e-8


def best_first(values, *, largest=True, rtol=TIE_RTOL) -> int:
    """The position of the best of `values`: the first (in their order) within
    `rtol * max|values|` of the largest (or, with largest=False, the smallest).

    Parameters
    ----------
    values : array_like (n,)
        The candidates' measures, any unit; NaN never wins.
    largest : bool
        Whether the best is the largest (else the smallest).
    rtol : float
        The relative tolerance within which two measures are equal.

    Returns
    -------
    int
        The position of the chosen candidate.

    Raises
    ------
    ValueError
        `values` is empty or all NaN.
    """
    values = np.asarray(values, dtype=float).ravel()
    finite = ~np.isnan(values)
    if not finite.any():
        raise ValueError("best_first: no candidate to choose from (empty or all NaN)")
    signed = values if largest else -values
    best = np.max(signed[finite])
    slack = rtol * np.max(np.abs(values[finite]))
    return int(np.flatnonzero(finite & (signed >= best - slack))[0])


def ordered(values, *, rtol=TIE_RTOL) -> list[int]:
    """The positions of `values` from the smallest to the largest, equals in their order.

    Sorted by value, the values are cut into runs: a run starts at a value and takes every
    next one within `rtol * max|values|` of that first value; within a run the positions keep
    their given order. A stable sort whose ties are not decided by round-off.

    Parameters
    ----------
    values : array_like (n,)
        Finite measures, any unit.
    rtol : float
        The relative tolerance within which two measures are equal.

    Returns
    -------
    list of int
        A permutation of range(n).
    """
    values = np.asarray(values, dtype=float).ravel()
    if values.size == 0:
        return []
    slack = rtol * np.max(np.abs(values))
    by_value = np.argsort(values, kind="stable")
    result, run = [], []
    for position in by_value:
        if run and values[position] > values[run[0]] + slack:
            result.extend(sorted(run))
            run = []
        run.append(int(position))
    result.extend(sorted(run))
    return result


def independent_rows(rows: np.ndarray, count: int, *, floor: float = 0.0,
                     relative: float = 1e-6, rtol=TIE_RTOL) -> list[int]:
    """Up to `count` rows of `rows` that are linearly independent, chosen greedily: each
    time the row with the largest part not yet spanned by the rows chosen before it, ties
    (by `best_first`) going to the first in order. This is QR with column pivoting (Businger
    and Golub) written out, so that no LAPACK kernel decides a tie.

    The rows are taken block by block (`sparse_blocks.blocks`): a chosen row's direction has
    no entry outside its block's columns, so it leaves every other block's rows exactly as
    they were (their products with it are sums of exact zeros), and only its own block is
    updated. The choice and its order are those of the updates over all rows; the DOF
    choice's projections on a large model are almost empty (678 x 816 with 0.4 % non-zero
    entries on the 816-DOF manipulator, 0.93 s -> see docs/benchmarks.md).

    Parameters
    ----------
    rows : ndarray (n, m)
        The candidates' rows.
    count : int
        How many rows to choose at most.
    floor : float
        A remaining norm at or below max(`floor`, `relative` * the first chosen norm) counts
        as zero: the choice stops there (the rows' rank).
    relative : float
        See `floor`.
    rtol : float
        The tie tolerance of `best_first`.

    Returns
    -------
    list of int
        The chosen rows' positions, sorted.
    """
    rows = np.asarray(rows, dtype=float)
    if rows.shape[0] == 0 or count <= 0:
        return []
    # per block: its rows' positions still updated (sorted) and their remaining parts
    members, parts = [], []
    block_of = np.empty(rows.shape[0], dtype=np.int64)
    for b, (block_rows, block_columns) in enumerate(blocks(rows)):
        members.append(block_rows)
        parts.append(rows[np.ix_(block_rows, block_columns)])
        block_of[block_rows] = b
    norms = np.linalg.norm(rows, axis=1)
    chosen, threshold = [], None
    available = np.ones(rows.shape[0], dtype=bool)
    while len(chosen) < count and available.any():
        k = best_first(np.where(available, norms, np.nan), rtol=rtol)
        if threshold is None:
            threshold = max(relative * norms[k], floor)
        if not norms[k] > threshold:
            break
        chosen.append(int(k))
        available[k] = False
        # A row below half the threshold can never be chosen: projections only shorten it
        # (round-off cannot double it), and a tie with a winner above the threshold needs
        # it within rtol of that winner. Such rows and the chosen ones leave the updates
        # (their block compacted once an eighth of its rows went).
        available &= ~(norms < 0.5 * threshold)
        b = block_of[k]
        part = parts[b]
        direction = part[np.searchsorted(members[b], k)] / norms[k]
        keep = available[members[b]]
        if keep.sum() < 0.875 * keep.size:
            members[b], part = members[b][keep], part[keep]
        for _ in range(2):  # Gram-Schmidt twice: orthogonal to round-off
            part -= np.outer(part @ direction, direction)
        parts[b] = part
        norms[members[b]] = np.linalg.norm(part, axis=1)
    return sorted(chosen)
