"""The pure part of examples.benchmarks.reduced_methods.py: its errors' scaling on made-up
states."""

import numpy as np

from examples.benchmarks.reduced_methods import errors


def test_errors_over_the_largest_motion_and_velocity():
    reference = np.array([[1.0, -4.0, 0.5, 2.0], [0.0, 2.0, -1.0, 0.0]])  # n = 2
    states = reference + np.array([[0.1, 0.0, 0.0, 0.02], [0.0, -0.3, 0.05, 0.0]])
    q_error, v_error = errors(states, reference, 2)
    assert abs(q_error - 0.3 / 4.0) < 1e-15
    assert abs(v_error - 0.05 / 2.0) < 1e-15
