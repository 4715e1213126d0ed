"""Third-order (jerk-limited) point-to-point motion profiles.

A third-order profile moves a stroke S in a time T with a piecewise-constant jerk of seven
segments: +J, 0, -J, 0, -J, 0, +J over the times t_j, t_a, t_j, t_v, t_j, t_a, t_j, so that

    T = 4 t_j + 2 t_a + t_v
    v_max = S / (2 t_j + t_a + t_v),   a_max = v_max / (t_j + t_a),   J = a_max / t_j

(the acceleration phase ends at v_max and, by symmetry, covers the distance v_max (2 t_j + t_a)
/ 2). The default split t_j = t_a = T/8, t_v = T/4 gives, for S = 1 mm in 1 s, v_max = 1.6 mm/s,
a_max = 6.4 mm/s^2 and J = 51.2 mm/s^3. Position, velocity, acceleration and jerk are exact
piecewise polynomials (degree 3, 2, 1, 0), evaluated at any times; before the start the profile
is at rest at 0, after the end at rest at S.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from flexure.core import FlexureError

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike


class ProfileError(FlexureError, ValueError):
    """A motion profile was asked for with impossible timing or a non-finite stroke."""


@dataclass(frozen=True)
class ThirdOrderProfile:
    """A jerk-limited point-to-point move of `stroke` (m or rad) in `duration` (s).

    `jerk_time` and `acceleration_time` (s) are the lengths of each constant-jerk and each
    constant-acceleration segment (default T/8 each); the constant-velocity segment takes the
    rest, T - 4 t_j - 2 t_a >= 0. `start` (s) delays the move. Below, m stands for the
    stroke's unit (rad for a rotation).

    Raises
    ------
    ProfileError
        A duration that is not positive, a stroke that is not finite, or segment times that
        do not fit in the duration.
    """

    stroke: float
    duration: float = 1.0
    jerk_time: float | None = None
    acceleration_time: float | None = None
    start: float = 0.0
    _knots: np.ndarray = field(init=False, repr=False)
    _jerks: np.ndarray = field(init=False, repr=False)
    _states: np.ndarray = field(init=False, repr=False)
    _integrals: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        T, S = float(self.duration), float(self.stroke)
        if not (np.isfinite(T) and T > 0):
            raise ProfileError(f"profile duration must be a positive number of seconds, got {T}")
        if not np.isfinite(S):
            raise ProfileError(f"profile stroke must be finite, got {S}")
        tj = T / 8 if self.jerk_time is None else float(self.jerk_time)
        ta = T / 8 if self.acceleration_time is None else float(self.acceleration_time)
        tv = T - 4 * tj - 2 * ta
        if tj <= 0 or ta < 0 or tv < -1e-12 * T:
            raise ProfileError(
                f"profile timing: need jerk_time > 0, acceleration_time >= 0 and "
                f"4 jerk_time + 2 acceleration_time <= duration = {T} s; "
                f"got jerk_time = {tj} s, acceleration_time = {ta} s")
        tv = max(tv, 0.0)
        v_max = S / (2 * tj + ta + tv)
        a_max = v_max / (tj + ta)
        J = a_max / tj
        lengths = np.array([tj, ta, tj, tv, tj, ta, tj])
        jerks = np.array([J, 0.0, -J, 0.0, -J, 0.0, J])
        knots = self.start + np.concatenate([[0.0], np.cumsum(lengths)])
        # (position, velocity, acceleration) at the start of each segment, then at the end.
        states = np.zeros((8, 3))
        for i, (h, j) in enumerate(zip(lengths, jerks, strict=True)):
            states[i + 1] = _advance(states[i], j, h)
        states[-1] = [S, 0.0, 0.0]  # the exact end point (removes round-off of the sums)
        object.__setattr__(self, "_knots", knots)
        object.__setattr__(self, "_jerks", jerks)
        object.__setattr__(self, "_states", states)
        integrals = np.zeros(8)  # integral of the position from the start to each knot
        for i, (h, j) in enumerate(zip(lengths, jerks, strict=True)):
            p, v, a = states[i]
            integrals[i + 1] = integrals[i] + p * h + v * h**2 / 2 + a * h**3 / 6 + j * h**4 / 24
        object.__setattr__(self, "_integrals", integrals)

    @property
    def peak_velocity(self) -> float:
        """The largest velocity magnitude (m/s)."""
        return float(np.max(np.abs(self._states[:, 1])))

    @property
    def peak_acceleration(self) -> float:
        """The largest acceleration magnitude (m/s^2)."""
        return float(np.max(np.abs(self._states[:, 2])))

    @property
    def peak_jerk(self) -> float:
        """The jerk magnitude J (m/s^3)."""
        return float(abs(self._jerks[0]))

    @property
    def end(self) -> float:
        """The time (s) at which the move ends."""
        return float(self._knots[-1])

    def evaluate(self, t: ArrayLike,
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration and jerk at given times.

        Parameters
        ----------
        t : array_like
            Times, s.

        Returns
        -------
        (ndarray, ndarray, ndarray, ndarray)
            Shaped as t: m, m/s, m/s^2, m/s^3.
        """
        t = np.asarray(t, dtype=float)
        _, h, p0, v0, a0, j = self._segment_start(t)
        before, after = t < self._knots[0], t >= self._knots[-1]
        position = p0 + v0 * h + a0 * h**2 / 2 + j * h**3 / 6
        velocity = v0 + a0 * h + j * h**2 / 2
        acceleration = a0 + j * h
        return tuple(np.where(after, rest, np.where(before, 0.0, value))
                     for value, rest in ((position, float(self.stroke)), (velocity, 0.0),
                                         (acceleration, 0.0), (j, 0.0)))

    def _segment_start(self, t):
        """For times t (s, an array): the segment each lies in (the first before the start,
        the last after the end), the time since that segment's start (s, >= 0), the position,
        velocity and acceleration there (m, m/s, m/s^2) and the segment's jerk (m/s^3)."""
        segment = np.clip(np.searchsorted(self._knots, t, side="right") - 1, 0, 6)
        h = np.clip(t - self._knots[segment], 0.0, None)
        p0, v0, a0 = (self._states[segment, i] for i in range(3))
        return segment, h, p0, v0, a0, self._jerks[segment]

    def position(self, t: ArrayLike) -> np.ndarray:
        """The position at given times.

        Parameters
        ----------
        t : array_like
            Times, s.

        Returns
        -------
        ndarray
            Shaped as t, m.
        """
        return self.evaluate(t)[0]

    def sample(self, fs: float, *, stop: float | None = None,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The profile sampled from `start` up to `stop`.

        Parameters
        ----------
        fs : float
            The sample rate, Hz.
        stop : float, optional
            The last time, s (default: the end of the move).

        Returns
        -------
        (ndarray, ndarray, ndarray, ndarray, ndarray)
            The times (s), then position, velocity, acceleration and jerk (m, m/s, m/s^2,
            m/s^3).

        Raises
        ------
        ProfileError
            A sample rate that is not a positive number.
        """
        if not (np.isfinite(fs) and fs > 0):
            raise ProfileError(f"sample rate must be a positive number of Hz, got {fs}")
        stop = self.end if stop is None else float(stop)
        t = self.start + np.arange(int(np.floor((stop - self.start) * fs + 1e-9)) + 1) / fs
        return (t, *self.evaluate(t))

    def position_integral(self, t: ArrayLike) -> np.ndarray:
        """The integral of the position from the start to given times, exact.

        Parameters
        ----------
        t : array_like
            Times, s.

        Returns
        -------
        ndarray
            Shaped as t, m s.
        """
        t = np.asarray(t, dtype=float)
        segment, h, p0, v0, a0, j = self._segment_start(t)
        inside = (self._integrals[segment] + p0 * h + v0 * h**2 / 2 + a0 * h**3 / 6
                  + j * h**4 / 24)
        end = self._knots[-1]
        after = self._integrals[-1] + float(self.stroke) * (t - end)
        return np.where(t >= end, after, np.where(t < self._knots[0], 0.0, inside))

    def interval_average(self, t0: ArrayLike, t1: ArrayLike,
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mean position, velocity and acceleration over the intervals [t0, t1).

        All three are exact: (P(t1) - P(t0)) / h with P the integral of the position,
        (p(t1) - p(t0)) / h and (v(t1) - v(t0)) / h. This is what a zero-order hold applies.

        Parameters
        ----------
        t0, t1 : array_like
            The start and end times of each interval, s (t1 > t0).

        Returns
        -------
        (ndarray, ndarray, ndarray)
            The means, m, m/s and m/s^2.
        """
        t0, t1 = np.asarray(t0, dtype=float), np.asarray(t1, dtype=float)
        h = t1 - t0
        p0, v0, _, _ = self.evaluate(t0)
        p1, v1, _, _ = self.evaluate(t1)
        mean = (self.position_integral(t1) - self.position_integral(t0)) / h
        return mean, (p1 - p0) / h, (v1 - v0) / h


def _advance(state, jerk, h):
    p, v, a = state
    return np.array([p + v * h + a * h**2 / 2 + jerk * h**3 / 6,
                     v + a * h + jerk * h**2 / 2,
                     a + jerk * h])
