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
    remaining = np.array(rows, dtype=float)
    if remaining.shape[0] == 0 or count <= 0:
        return []
    chosen, threshold = [], None
    position = np.arange(remaining.shape[0])  # of each row of `remaining` in `rows`
    available = np.ones(remaining.shape[0], dtype=bool)
    while len(chosen) < count and available.any():
        norms = np.where(available, np.linalg.norm(remaining, axis=1), np.nan)
        k = best_first(norms, rtol=rtol)
        if threshold is None:
            threshold = max(relative * norms[k], floor)
        if not norms[k] > threshold:
            break
        direction = remaining[k] / norms[k]
        chosen.append(int(position[k]))
        available[k] = False
        # A row below half the threshold can never be chosen: projections only shorten it
        # (round-off cannot double it), and a tie with a winner above the threshold needs
        # it within rtol of that winner. Such rows and the chosen ones leave the updates
        # (compacted once an eighth of the rows went: on the 816-DOF manipulator the rows
        # that their chosen partners make zero go fast, 2.2 s -> see docs/benchmarks.md).
        available &= ~(norms < 0.5 * threshold)
        if available.sum() < 0.875 * available.size:
            remaining, position = remaining[available], position[available]
            available = np.ones(remaining.shape[0], dtype=bool)
        for _ in range(2):  # Gram-Schmidt twice: orthogonal to round-off
            remaining -= np.outer(remaining @ direction, direction)
    return sorted(chosen)
