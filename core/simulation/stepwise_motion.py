"""Kinematic inputs moved step by step by a host: the path through the positions it sets.

A host that drives a kinematic input (a co-simulation master, the FMU's `NAME` input) knows
where the input is to be at the end of each step, not its rate or acceleration; the engine
needs all three at every time (`flexure.core.engine.prescribed`). The rule that makes a path
of the positions: at each step [t_n, t_n+1] the host gives u_n+1, the position (m, rad) at
t_n+1, and the path over the step is the quintic piece

- that starts with the path's own value, rate and acceleration at t_n (the path is twice
  continuously differentiable: the inertia sees no jump of acceleration, the integrator no
  jump of its right-hand side), and
- ends at u_n+1 with the rate and acceleration at t_n+1 of the polynomial through the last
  four positions set, (t_n-2, u_n-2) .. (t_n+1, u_n+1) (variable steps allowed; fewer at the
  start, where the start position is the first: a line, then a parabola). Before the first
  step the path holds the start, at rest.

The end's rate and acceleration are taken from the positions alone, never from the path
before: an error in them does not carry over to the next step. (Continuing the path's own
rate and acceleration to the end, a cubic that reaches u_n+1, would multiply such an error
by -2 - sqrt(3) per step.)

Order in the step h, for a smooth motion: the cubic's rate at its newest point is within
O(h^3) of the motion's, its acceleration within O(h^2); the quintic with those ends is then
within O(h^4) of the motion in value, O(h^3) in rate and O(h^2) in acceleration over the
step, exact at the step ends in value. The efforts, which carry the inertia of the path's
acceleration, converge at order 2, the motion of what the inputs drive at least as fast
(tests/test_fmu_motion.py measures both). A motion that does not start at rest at the
host's start time (a rate or acceleration at once) differs from the path over the first
steps: the path starts at rest.

A path record is the engine's: [t_start, t_end, c_0 .. c_5] per input, u(t) = sum c_j
(t - t_start)^j (`prescribed.PATH_WIDTH`).
"""

from __future__ import annotations

import numpy as np

from ..engine.prescribed import PATH_WIDTH

# how many positions the end's rate and acceleration are taken from: a cubic through four
SAMPLES = 4


def end_derivatives(times, values):
    """The rate and acceleration at the last of `times` of the polynomial through the
    samples (degree len(times) - 1: 0 gives rest, 1 a line's rate and no acceleration).

    Parameters
    ----------
    times : array_like (k,)
        s, increasing.
    values : array_like (k, n_inputs)
        m or rad at those times.

    Returns
    -------
    rate, acceleration : ndarray (n_inputs,)
        m/s, m/s^2 (rad/s, rad/s^2).
    """
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float).reshape(times.size, -1)
    weights = derivative_weights(times - times[-1])
    # of the differences from the newest: the same sums (a derivative's weights add up to
    # zero), without the round-off of the positions' size (equal positions give exact rest)
    differences = values - values[-1]
    return weights[1] @ differences, weights[2] @ differences


def derivative_weights(offsets):
    """Weights w (3, k) with sum_i w[d, i] f(x_i) the d-th derivative at 0 of the polynomial
    through (x_i, f(x_i)) (Fornberg's recursion, 1988), for d = 0, 1, 2.

    Parameters
    ----------
    offsets : array_like (k,)
        The sample points relative to the point of evaluation (s), distinct.

    Returns
    -------
    ndarray (3, k)
        Zero for derivatives above the polynomial's degree k - 1.
    """
    x = np.asarray(offsets, dtype=float)
    k, orders = x.size, 3
    weights = np.zeros((orders, k))
    weights[0, 0] = 1.0
    c1 = 1.0
    for i in range(1, k):
        c2 = 1.0
        top = min(i, orders - 1)
        for j in range(i):
            c3 = x[i] - x[j]
            c2 *= c3
            if j == i - 1:
                for m in range(top, 0, -1):
                    weights[m, i] = c1 * (m * weights[m - 1, i - 1]
                                          - x[i - 1] * weights[m, i - 1]) / c2
                weights[0, i] = -c1 * x[i - 1] * weights[0, i - 1] / c2
            for m in range(top, 0, -1):
                weights[m, j] = (x[i] * weights[m, j] - m * weights[m - 1, j]) / c3
            weights[0, j] = x[i] * weights[0, j] / c3
        c1 = c2
    return weights


def hermite_piece(t0, t1, start, end):
    """The path records of the quintic from (u, u', u'') = `start` at t0 to `end` at t1.

    With s = t - t0, T = t1 - t0, c_0 = u0, c_1 = u0', c_2 = u0'' / 2 and the remainders
    du = u1 - c_0 - c_1 T - c_2 T^2, dv = u1' - c_1 - 2 c_2 T, da = u1'' - 2 c_2:

        c_3 = (20 du - 8 dv T + da T^2) / (2 T^3)
        c_4 = (-30 du + 14 dv T - 2 da T^2) / (2 T^4)
        c_5 = (12 du - 6 dv T + da T^2) / (2 T^5)

    (the rest-to-rest move of `prescribed.quintic_path` is dv = da = 0).

    Parameters
    ----------
    t0, t1 : float
        s, t1 > t0.
    start, end : tuple of array_like (n_inputs,)
        (u, u', u''): m, m/s, m/s^2 (rad, rad/s, rad/s^2).

    Returns
    -------
    ndarray (PATH_WIDTH n_inputs,)
        [t0, t1, c_0 .. c_5] per input.
    """
    u0, v0, a0 = (np.asarray(part, dtype=float).reshape(-1) for part in start)
    u1, v1, a1 = (np.asarray(part, dtype=float).reshape(-1) for part in end)
    T = float(t1) - float(t0)
    c2 = 0.5 * a0
    du = u1 - u0 - v0 * T - c2 * T**2
    dv = v1 - v0 - 2.0 * c2 * T
    da = a1 - a0
    path = np.zeros((u0.size, PATH_WIDTH))
    path[:, 0], path[:, 1] = t0, t1
    path[:, 2], path[:, 3], path[:, 4] = u0, v0, c2
    path[:, 5] = (20.0 * du - 8.0 * dv * T + da * T**2) / (2.0 * T**3)
    path[:, 6] = (-30.0 * du + 14.0 * dv * T - 2.0 * da * T**2) / (2.0 * T**4)
    path[:, 7] = (12.0 * du - 6.0 * dv * T + da * T**2) / (2.0 * T**5)
    return path.reshape(-1)


def held_path(values, t):
    """The path records that hold each input at its value (m, rad) at rest, from t (s).

    Parameters
    ----------
    values : array_like (n_inputs,)
    t : float

    Returns
    -------
    ndarray (PATH_WIDTH n_inputs,)
    """
    values = np.asarray(values, dtype=float).reshape(-1)
    path = np.zeros((values.size, PATH_WIDTH))
    path[:, 0], path[:, 1], path[:, 2] = t, t, values
    return path.reshape(-1)


def next_piece(samples, start, t, t_end, positions):
    """The path over [t, t_end] by the module's rule, and the samples it is taken from.

    Parameters
    ----------
    samples : tuple (times (k,), values (k, n_inputs))
        The positions set so far (s; m, rad), oldest first; those after t (a step that did
        not reach its end) are left out.
    start : tuple of ndarray (n_inputs,)
        (u, u', u'') of the path at t.
    t, t_end : float
        s, t_end > t.
    positions : array_like (n_inputs,)
        Where the inputs are at t_end (m, rad).

    Returns
    -------
    path : ndarray (PATH_WIDTH n_inputs,)
        The piece's records (each reaching a step past t_end: the same polynomial).
    samples : tuple (times, values)
        The last SAMPLES positions including (t_end, positions): the samples of the next
        step once this one is reached.
    """
    times, values = samples
    kept = np.asarray(times, dtype=float) <= t
    times = np.append(np.asarray(times, dtype=float)[kept], t_end)[-SAMPLES:]
    values = np.vstack([np.asarray(values, dtype=float)[kept],
                        np.asarray(positions, dtype=float).reshape(1, -1)])[-SAMPLES:]
    rate, acceleration = end_derivatives(times, values)
    path = hermite_piece(t, t_end, start, (values[-1], rate, acceleration))
    # the records reach a step past t_end: an evaluation at a stage time t + c h that rounds
    # an ulp past t_end sees the same polynomial, not the held end (rate and acceleration 0)
    records = path.reshape(-1, PATH_WIDTH)
    records[:, 1] = t_end + (t_end - t)
    return path, (times, values)


__all__ = ["SAMPLES", "derivative_weights", "end_derivatives", "held_path", "hermite_piece",
           "next_piece"]
