"""A reference of your own: the loops' positions as samples or as a function of time.

Instead of the third-order profile, `run_loop(..., reference=...)` takes

- an array of the loops' positions (m, or rad on an angle) at the samples t_k = k / fs,
  k = 0 .. N: shape (N+1,) for one loop or (N+1, n_loops). The run then spans these N
  intervals (`duration` and `settle` are not used); after t_N the last sample holds;
- a callable r(t) -> positions: called with each sample time t_k (a float, s) for
  k = 0 .. N+1, N = round((duration + settle) fs), it returns a number (one loop) or an
  array (n_loops,).

These are positions, not displacements: the plant starts where the scene puts it
(`LoopController.offsets`, `initial_positions`), so a reference that does not start there asks
for a step.

Feedforward. The modal feedforward u = M y'' + C y' + K (y - y_eq) (feedforward.py) needs the
reference's velocity and acceleration, which samples do not give. It is taken from the cubic
spline through the samples (not-a-knot ends, so nothing is assumed about rest before the
first sample; one more sample holding the last one closes it), with the interval means that a
zero-order hold applies (as for the built-in profile, loop_controller.py): over
[t_k, t_k+1) the mean position is the spline's exact integral, the mean velocity
(r_k+1 - r_k) fs and the mean acceleration (s'(t_k+1) - s'(t_k)) fs. For a smooth reference
the mean acceleration errs by O(h^4) in the interior (h = 1 / fs) and by O(h^3) over the
first few samples (on a 3 Hz sine at 4 kHz: 2e-10 and 2e-8 of its peak;
`tests/test_loop_plug.py` measures the orders). A reference with a kink (a step in
velocity) gets the spline's smoothed version of it: the feedforward then rings for a few
samples around the kink, which the feedback takes up. The 'inverse' feedforward (one loop)
applies the stable inverse to the samples directly; a move path (`path`) is a reference of its
own and does not combine with one given here.
"""

from __future__ import annotations

import numpy as np

from .errors import LoopError


def reference_samples(reference, *, n_loops: int, fs: float, samples: int,
                      unit: str = "m") -> tuple[np.ndarray, int, str]:
    """The loops' reference at the samples k = 0 .. N+1 from an array or a callable.

    Parameters
    ----------
    reference : array (N+1,) or (N+1, n_loops), or callable r(t) -> positions
    n_loops : int
    fs : float
        Sample rate (Hz).
    samples : int
        N for a callable (an array sets its own).
    unit : str
        The loops' position unit, for the messages.

    Returns
    -------
    (r (N+2, n_loops) in m or rad, N, "samples" or "callable")
    """
    if callable(reference):
        rows = []
        for k in range(samples + 2):
            value = reference(k / fs)
            try:
                row = np.asarray(value, float).reshape(-1)
            except (TypeError, ValueError):
                row = np.array([])
            if row.size == 1 and n_loops > 1:
                row = np.full(n_loops, row[0])
            if row.size != n_loops or not np.all(np.isfinite(row)):
                raise LoopError(f"the reference r(t) returned {value!r} at t = {k / fs:.9g} s; "
                                f"expected {n_loops} finite position(s) ({unit})")
            rows.append(row)
        return np.array(rows), samples, "callable"
    try:
        r = np.asarray(reference, float)
    except (TypeError, ValueError):
        raise LoopError("the reference must be an array of positions or a callable r(t), got "
                        f"{type(reference).__name__}") from None
    expected = f"(N+1,) or (N+1, {n_loops})" if n_loops == 1 else f"(N+1, {n_loops})"
    if r.ndim == 1 and n_loops == 1:
        r = r[:, None]
    if r.ndim != 2 or r.shape[1] != n_loops or r.shape[0] < 2:
        raise LoopError(f"the reference samples: expected shape {expected} with N >= 1 (one "
                        f"column per loop), got {r.shape}")
    if not np.all(np.isfinite(r)):
        bad = int(np.argwhere(~np.isfinite(r))[0, 0])
        raise LoopError(f"the reference samples: sample {bad} is not finite ({unit})")
    return np.vstack([r, r[-1:]]), r.shape[0] - 1, "samples"


def interval_means(reference, fs: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean position, velocity and acceleration (m, m/s, m/s^2) of the reference's cubic spline
    over each interval [t_k, t_k+1), k = 0 .. len(reference) - 1; arrays like `reference`."""
    from scipy.interpolate import CubicSpline  # for a given reference only

    r = np.asarray(reference, float)
    knots = np.vstack([r, r[-1:]])  # one more sample, held, closes the last interval
    h = 1.0 / fs
    spline = CubicSpline(np.arange(knots.shape[0]) * h, knots, axis=0)
    # on interval k: s(t) = c0 x^3 + c1 x^2 + c2 x + c3, x = t - t_k (exact integrals)
    c0, c1, c2, c3 = spline.c
    position = c0 * h**3 / 4 + c1 * h**2 / 3 + c2 * h / 2 + c3
    velocity = (knots[1:] - knots[:-1]) / h
    acceleration = 3 * c0 * h + 2 * c1
    return position, velocity, acceleration


def reference_forces(lf_model, reference, fs: float) -> np.ndarray:
    """The modal feedforward (N) held over each interval for a sampled reference (m);
    (len(reference), n_loops)."""
    return lf_model.force(*interval_means(reference, fs))


def reference_stroke(reference, samples: int) -> float:
    """The largest excursion |r_k - r_0| (m, rad) of any loop over k = 0 .. N; LoopError when
    the reference does not move (the tracking error would have no scale)."""
    r = np.asarray(reference, float)[: samples + 1]
    stroke = float(np.max(np.abs(r - r[0])))
    if stroke == 0:
        raise LoopError("the reference does not move: its stroke, the scale of the tracking "
                        "error, is zero; give a reference that moves")
    return stroke
