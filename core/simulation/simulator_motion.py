"""The `Simulator`'s kinematic inputs: their path, the prescribed entries of q and the
efforts.

A model with kinematic inputs (`Model.kinematic_inputs`) is integrated by the engine's
prescribed forms (`flexure.core.engine.prescribed`, and `prescribed_residual` for IDA's
implicit form), by every method: every evaluation puts the inputs' u(t), u'(t) into q and qdot
at its own time and solves the accelerations of the DOFs proper with u'' given. The path is
held at each input's `start` until `set_motion` gives the scene's move (a rest-to-rest quintic
from `start` to `value`, `analysis.motion_paths`), or a host moves the inputs step by step
(`move_to`: the positions at the end of each step, made a path by `stepwise_motion`'s rule; a
Simulator made with `stepwise_motion=True`). The state keeps the prescribed entries (integrated
from qdot and u'', within the integrator's tolerance of the path); what this module reports of
them (`prescribed_values`, the `q` and `qdot` of a recorded trajectory in `simulate`) is the
path itself. The efforts (N, N m) come from one evaluation of the state on the simulator's
second packed model, so that reading them leaves the integrator's own evaluations as they were.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..engine import data as ed
from ..engine import engine
from ..engine.prescribed import PATH_WIDTH, quintic_path
from ..engine.status import status_message
from ..errors import SimulationError
from .stepwise_motion import SAMPLES, held_path, next_piece

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

def path_values(path, t):
    """(u, u', u'') (nki,) each at time t (s) from the records of slot motion_path (plain
    numpy: the reference for `prescribed.path_point`)."""
    records = np.asarray(path, dtype=float).reshape(-1, PATH_WIDTH)
    t_start, t_end, c = records[:, 0], records[:, 1], records[:, 2:]
    s = np.clip(t, t_start, t_end) - t_start
    inside = (t_start <= t) & (t < t_end)
    powers = np.arange(6)
    value = np.sum(c * s[:, None] ** powers, axis=1)
    rate = np.sum(c[:, 1:] * powers[1:] * s[:, None] ** powers[:-1], axis=1)
    acceleration = np.sum(c[:, 2:] * (powers[2:] * powers[1:-1]) * s[:, None] ** powers[:-2],
                          axis=1)
    return value, np.where(inside, rate, 0.0), np.where(inside, acceleration, 0.0)


def path_point_now(path, t):
    """(u, u', u'') (nki,) each at time t (s): `prescribed.path_point`'s Horner sums in plain
    Python, which the simulator evaluates a few times per step (for a handful of inputs the
    sums cost less than numpy's `path_values` arrays and reductions, a third of a small
    model's step)."""
    t = float(t)
    records = np.asarray(path, dtype=float).reshape(-1, PATH_WIDTH).tolist()
    values, rates, accelerations = [], [], []
    for record in records:
        t_start, t_end = record[0], record[1]
        s = min(max(t, t_start), t_end) - t_start
        value = rate = acceleration = 0.0
        for c in reversed(record[2:]):  # Horner, from the highest power
            acceleration = acceleration * s + 2.0 * rate
            rate = rate * s + value
            value = value * s + c
        inside = t_start <= t < t_end
        values.append(value)
        rates.append(rate if inside else 0.0)
        accelerations.append(acceleration if inside else 0.0)
    return np.array(values), np.array(rates), np.array(accelerations)


def check_motion(model, duration, stepwise=False):
    """SimulationError unless a model with kinematic inputs comes with the duration of its
    move (s) or is moved step by step (`stepwise`), not both; a model without them with
    neither. Every registered method integrates them (the engine's prescribed forms: the
    first-order one of CVODE and the ESDIRKs, `engine.prescribed`, and IDA's implicit one,
    `engine.prescribed_residual`)."""
    if not model.kinematic_inputs:
        if duration is not None or stepwise:
            given = (f"motion_duration {duration!r}" if duration is not None
                     else "stepwise_motion")
            raise SimulationError(f"{given}: {model.name!r} has no kinematic input to move "
                                  "([inputs.NAME] kind = \"motion\")")
        return
    names = ", ".join(port.name for port in model.kinematic_inputs)
    if duration is None and not stepwise:
        raise SimulationError(f"{model.source}: model {model.name!r} has kinematic inputs "
                              f"({names}): a time simulation needs the duration of their "
                              "move (Simulator(..., motion_duration=T), `flexure simulate "
                              "--motion-duration`) or a host that moves them step by step "
                              "(Simulator(..., stepwise_motion=True), the FMU)")
    if duration is not None and stepwise:
        raise SimulationError(f"{model.name!r}: motion_duration {duration!r} and "
                              "stepwise_motion: the kinematic inputs ({names}) follow either "
                              "the scene's move or a host's steps, not both")


class SimulatorMotion:
    """The kinematic inputs' part of `Simulator` (module docstring)."""

    def set_motion(self, duration: float, *, t0: float | None = None) -> None:
        """Move every kinematic input from its `start` to its `value` (`Model.motion_starts`,
        `Model.motion_values`) by the rest-to-rest quintic over `duration` s from t0, held
        before and after (`analysis.motion_paths.increment_path`). The state's prescribed
        entries are put on the path at the current time, and the integrator restarts.

        Parameters
        ----------
        duration : float
            s, > 0: how long the move takes.
        t0 : float, optional
            s: when it starts (default: now).

        Raises
        ------
        SimulationError
            A model without kinematic inputs, or a duration or t0 that is not a finite
            number (a duration > 0).
        """
        self._write_path(duration, self._t if t0 is None else t0)
        self._put_on_path()
        self._restart_samples()
        self._needs_init = self._restart_kinematics = True
        self._outputs_cache = None

    def _write_path(self, duration, t0):
        """The quintic records into both packed models (`set_motion`), checked."""
        model = self.model
        if not model.kinematic_inputs:
            raise SimulationError(f"{model.name!r} has no kinematic input to move "
                                  "([inputs.NAME] kind = \"motion\")")
        if not (np.isfinite(duration) and duration > 0.0 and np.isfinite(t0)):
            raise SimulationError(f"the move's duration must be a finite number of seconds "
                                  f"> 0 from a finite t0, got {duration!r} from {t0!r}")
        self._set_path(quintic_path(model.motion_starts, model.motion_values, duration,
                                    float(t0)))

    def move_to(self, positions: ArrayLike, t_end: float, *,
                max_steps: int | None = None) -> None:
        """Move the kinematic inputs to `positions` at t_end, and integrate to t_end: the
        host's step of a stepwise motion (`stepwise_motion`: the path over [now, t_end] is
        the quintic that continues the path's value, rate and acceleration now and reaches
        the positions with the rate and acceleration of the cubic through the last four
        positions set). The state's prescribed entries are put on the path now and at t_end.

        Parameters
        ----------
        positions : array_like (n_kinematic,)
            m or rad, in the order of `Model.kinematic_inputs`: where each input is at t_end.
        t_end : float
            s, after the current time (an absolute time, as `advance_to` takes it).
        max_steps : int, optional
            A budget of integrator steps (`advance_to`).

        Raises
        ------
        SimulationError
            A model without kinematic inputs, positions of the wrong number or not finite
            (naming the input), or `advance_to`'s failures; the simulator then stays at its
            last good time, on the piece (a next `move_to` starts from there).
        """
        positions = self._checked_positions(positions)
        t_end = float(t_end)
        if not (np.isfinite(t_end) and t_end > self._t):
            raise SimulationError(f"t = {self._t:.9g} s: move the kinematic inputs to t_end = "
                                  f"{t_end!r}: expected a finite time after the current one")
        path, samples = next_piece(self._motion_samples, self.prescribed_values(), self._t,
                                   t_end, positions)
        self._set_path(path)
        self._put_on_path()
        self._needs_init = True  # a new right-hand side from now on, as a new input
        self._outputs_cache = None
        self.advance_to(t_end, max_steps=max_steps)
        self._motion_samples = samples
        self._put_on_path()
        self._needs_init = True
        self._outputs_cache = None

    def hold_motion(self, positions: ArrayLike) -> None:
        """Hold the kinematic inputs at `positions`, at rest, from now on: where a stepwise
        motion starts (then `reset` puts the state there), or a stop.

        Parameters
        ----------
        positions : array_like (n_kinematic,)
            m or rad, in the order of `Model.kinematic_inputs`.

        Raises
        ------
        SimulationError
            A model without kinematic inputs, or positions of the wrong number or not finite.
        """
        positions = self._checked_positions(positions)
        self._set_path(held_path(positions, self._t))
        self._put_on_path()
        self._restart_samples()
        self._needs_init = self._restart_kinematics = True
        self._outputs_cache = None

    def _checked_positions(self, positions):
        ports = self.model.kinematic_inputs
        if not ports:
            raise SimulationError(f"{self.model.name!r} has no kinematic input to move "
                                  "([inputs.NAME] kind = \"motion\")")
        values = np.array(positions, dtype=float).reshape(-1)
        if values.size != len(ports):
            raise SimulationError(f"t = {self._t:.9g} s: expected {len(ports)} positions of "
                                  f"the kinematic inputs ({', '.join(p.name for p in ports)}), "
                                  f"got {values.size}")
        for port, value in zip(ports, values, strict=True):
            if not np.isfinite(value):
                raise SimulationError(f"t = {self._t:.9g} s: kinematic input {port.name!r} = "
                                      f"{float(value)!r} {port.unit}: expected a finite position")
        return values

    def _set_path(self, path):
        for data in (self.data, self._output_data):
            data.float_array("motion_path")[:] = path

    def _restart_samples(self):
        """The positions a stepwise motion's next piece is taken from: the path's now."""
        if self.model.kinematic_inputs:
            self._motion_samples = (np.array([self._t]), self.prescribed_values()[0][None])

    def _motion_snapshot(self):
        """The path and the positions set, for `get_state` (empty without kinematic inputs)."""
        if not self.model.kinematic_inputs:
            return {}
        times, values = self._motion_samples
        return {"motion_path": self.data.float_array("motion_path").copy(),
                "motion_times": times.copy(), "motion_positions": values.reshape(-1).copy()}

    def _checked_motion(self, state):
        """(path, samples) of a snapshot, or None for one without them (the path is kept);
        SimulationError for sizes that do not fit or numbers that are not finite."""
        if not self.model.kinematic_inputs or "motion_path" not in state:
            return None
        nki = len(self.model.kinematic_inputs)
        try:
            path = np.array(state["motion_path"], dtype=float).reshape(-1)
            times = np.array(state["motion_times"], dtype=float).reshape(-1)
            values = np.array(state["motion_positions"], dtype=float).reshape(-1)
        except (KeyError, TypeError, ValueError) as error:
            raise SimulationError(f"not a simulator state: its motion: {error}") from None
        if (path.size != PATH_WIDTH * nki or not 1 <= times.size <= SAMPLES
                or values.size != times.size * nki):
            raise SimulationError(f"the state's motion holds {path.size} path numbers and "
                                  f"{times.size} times of {values.size} positions; expected "
                                  f"{PATH_WIDTH * nki} and 1 to {SAMPLES} times of {nki} "
                                  "positions each")
        if not (np.all(np.isfinite(path)) and np.all(np.isfinite(times))
                and np.all(np.isfinite(values))):
            raise SimulationError("the state's motion holds non-finite numbers")
        if np.any(np.diff(times) <= 0.0):
            raise SimulationError(f"the state's motion: the times of its positions "
                                  f"{times.tolist()} s do not increase")
        return path, (times, values.reshape(times.size, nki))

    def _restore_motion(self, checked):
        if checked is not None:
            path, self._motion_samples = checked
            self._set_path(path)

    def prescribed_values(self, t: float | None = None
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The kinematic inputs on their path.

        Parameters
        ----------
        t : float, optional
            s (default now).

        Returns
        -------
        tuple of ndarray (n_kinematic,)
            u, u', u'': m, m/s, m/s^2 (rad, rad/s, rad/s^2 on an angle), in the order of
            `Model.kinematic_inputs`.
        """
        return path_point_now(self.data.float_array("motion_path"),
                              self._t if t is None else t)

    def _put_on_path(self):
        """The state's prescribed entries at the path's value and rate now."""
        if self.model.kinematic_inputs:
            k, n = self.model.prescribed_dofs, self.ndof
            u, rate, _ = self.prescribed_values()
            self._y[k] = u - self._q_ref[k]
            self._y[n + k] = rate

    def on_path(self, times: ArrayLike, states: ArrayLike) -> np.ndarray:
        """Absolute states with the prescribed entries replaced by the path's.

        Parameters
        ----------
        times : array_like (n,)
            s.
        states : array_like (n, 2 NDOF)
            Absolute states [q, qdot]: m, rad; m/s, rad/s.

        Returns
        -------
        ndarray (n, 2 NDOF)
            A copy, the kinematic inputs' entries of q and qdot the path's values and rates.
        """
        states = np.array(states, dtype=float)
        if self.model.kinematic_inputs:
            k, n = self.model.prescribed_dofs, self.ndof
            for row, t in zip(states, np.asarray(times, dtype=float), strict=True):
                u, rate, _ = self.prescribed_values(t)
                row[k], row[n + k] = u, rate
        return states

    def efforts_along(self, times: ArrayLike, states: ArrayLike, *,
                      start: np.ndarray | None = None,
                      inputs: ArrayLike | None = None) -> np.ndarray:
        """The efforts that realise the kinematic inputs along states: F = M_k. qddot - Q_k.

        Parameters
        ----------
        times : array_like (n,)
            s.
        states : array_like (n, 2 NDOF)
            Absolute states [q, qdot] (m, rad; m/s, rad/s), the inputs' entries on the path.
        start : ndarray (NX,), optional
            The coordinates the first kinematics starts from (default the scene's); each
            next starts from the last solution.
        inputs : array_like (n, n_inputs), optional
            The inputs held at each state (N, N m, V; default the ones held now): a force on
            an input's row is part of what its effort balances.

        Returns
        -------
        ndarray (n, n_kinematic)
            N or N m, in the order of `Model.kinematic_inputs`.

        Raises
        ------
        SimulationError
            A state the engine cannot evaluate (naming the time and the cause).
        """
        times = np.asarray(times, dtype=float).reshape(-1)
        states = np.asarray(states, dtype=float)
        nki, n = len(self.model.kinematic_inputs), self.ndof
        efforts = np.zeros((times.size, nki))
        if not nki:
            return efforts
        data = self._output_data
        q_ref, held = data.float_array("q_ref"), data.float_array("inputs")
        given = (np.broadcast_to(self._u, (times.size, self._u.size)) if inputs is None
                 else np.asarray(inputs, dtype=float).reshape(times.size, self._u.size))
        self._start_kinematics(self.model.initial_coordinates if start is None else start,
                               data)
        for row, (t, state) in enumerate(zip(times, states, strict=True)):
            q_ref[:] = state[:n]
            held[:] = given[row]
            y = np.concatenate([np.zeros(n), state[n: 2 * n]])
            status = engine.call(data, engine.OP_RHS, y, t=float(t))
            if status != ed.OK:
                raise SimulationError(f"t = {t:.9g} s: the efforts of the kinematic inputs: "
                                      f"{status_message(status)}")
            efforts[row] = data.float_array("efforts")
        return efforts

    def efforts(self) -> np.ndarray:
        """The efforts of the kinematic inputs now (`efforts_along`).

        Returns
        -------
        ndarray (n_kinematic,)
            N or N m.
        """
        state = self.on_path([self._t], [self.absolute(self._y)])
        return self.efforts_along([self._t], state, start=self._x)[0]


__all__ = ["SimulatorMotion", "check_motion", "path_point_now", "path_values"]
