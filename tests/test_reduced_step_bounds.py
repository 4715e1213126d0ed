"""The estimates of examples/benchmarks/reduced_step_bounds.py on made-up step records
whose answers follow from the definitions."""

import numpy as np

from examples.benchmarks.reduced_step_bounds import SKIP, TARGET, ideal_count, ladder_count

PERIOD = 2.5e-4  # s: a 4 kHz sample


def records(h, error, jacobians=None):
    """Rows as `replay` gives them for one sample (index SKIP) of steps h (s) with the given
    weighted errors; column 9 the Jacobians' count."""
    rows = np.zeros((h.size, 10))
    rows[:, 0] = SKIP
    rows[:, 1] = SKIP * PERIOD + np.cumsum(h)
    rows[:, 2] = error
    rows[:, 9] = 1 if jacobians is None else jacobians
    return rows


def test_ideal_count_with_a_constant_error_constant():
    # 25 steps of 10 us at an eighth of the aim: C h^3 = TARGET at h = 20 us, so the best
    # sequence is ceil(250 / 20) = 13 steps (twelve just under 20 us, then the rest)
    h = np.full(25, 1e-5)
    actual, ideal = ideal_count(records(h, TARGET / 8.0), h, PERIOD)
    assert actual == 25
    assert ideal == 13


def test_ideal_count_takes_the_largest_error_constant_a_step_overlaps():
    # a first step of 1 us at a thousandth of the aim (C allows 10 us), then 249 us at the
    # aim (C allows 249 us): a step from 0 overlaps the first C and stops just under 10 us,
    # the next covers the rest; by the smaller C alone one step of 250 us would do
    h = np.array([1e-6, 2.49e-4])
    error = np.array([TARGET / 1000.0, TARGET])
    assert ideal_count(records(h, error), h, PERIOD) == (2, 2)


def test_ladder_count_one_lu_per_rung_and_jacobian():
    # r = 2: 10 and 11 us share the rung 2^-17 s (7.63 us), 20 us is 2^-16 s, 40 us 2^-15 s;
    # a second Jacobian makes 10 us's rung new again: 4 LUs over 3 rungs
    h = np.array([10e-6, 11e-6, 20e-6, 40e-6, 10e-6])
    rows = records(h, 0.5, jacobians=np.array([1, 1, 1, 1, 2]))
    lus, rungs, shorter = ladder_count(rows, h, 2.0)
    assert (lus, rungs) == (4, 3)
    rounded = np.array([2.0 ** -17, 2.0 ** -17, 2.0 ** -16, 2.0 ** -15, 2.0 ** -17])
    assert abs(shorter - np.mean(1.0 - rounded / h)) < 1e-12
