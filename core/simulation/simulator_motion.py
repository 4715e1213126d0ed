"""The `Simulator`'s kinematic inputs: their path, the prescribed entries of q and the
efforts.

A model with kinematic inputs (`Model.kinematic_inputs`) is integrated by the engine's
prescribed form (`flexure.core.engine.prescribed`): every right-hand side puts the inputs'
u(t), u'(t) into q and qdot at its own time and solves the accelerations of the DOFs proper
with u'' given. The path is held at each input's `start` until `set_motion` gives the scene's
move (a rest-to-rest quintic from `start` to `value`, `analysis.motion_paths`). The state keeps
the prescribed entries (integrated from qdot and u'', within the integrator's tolerance of
the path); what this module reports of them (`prescribed_values`, the `q` and `qdot` of a
recorded trajectory in `simulate`) is the path itself. The efforts (N, N m) come from one
evaluation of the state on the simulator's second packed model, so that reading them leaves
the integrator's own evaluations as they were.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..engine import data as ed
from ..engine import engine
from ..engine.prescribed import PATH_WIDTH, quintic_path
from ..errors import SimulationError
from .methods import METHOD_TABLE
from .status import STATUS_MESSAGES

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

# the methods that take kinematic inputs: those of the first-order form (OP_RHS; IDA's
# implicit form has no prescribed twin yet)
MOTION_METHODS = tuple(m.name for m in METHOD_TABLE if "OP_RHS" in m.operations)


def path_values(path, t):
    """(u, u', u'') (nki,) each at time t (s) from the records of slot motion_path (plain
    numpy: the reference for `prescribed.path_point`)."""
    records = np.asarray(path, dtype=float).reshape(-1, PATH_WIDTH)
    t_start, t_end, c = records[:, 0], records[:, 1], records[:, 2:]
    s = np.clip(t, t_start, t_end) - t_start
    inside = (t_start < t) & (t < t_end)
    powers = np.arange(6)
    value = np.sum(c * s[:, None] ** powers, axis=1)
    rate = np.sum(c[:, 1:] * powers[1:] * s[:, None] ** powers[:-1], axis=1)
    acceleration = np.sum(c[:, 2:] * (powers[2:] * powers[1:-1]) * s[:, None] ** powers[:-2],
                          axis=1)
    return value, np.where(inside, rate, 0.0), np.where(inside, acceleration, 0.0)


def check_motion_method(model, method, duration):
    """SimulationError unless a model with kinematic inputs comes with the duration of its
    move (s) and a method that integrates it, and a model without them with no duration."""
    if not model.kinematic_inputs:
        if duration is not None:
            raise SimulationError(f"motion_duration {duration!r}: {model.name!r} has no "
                                  "kinematic input to move ([inputs.NAME] kind = \"motion\")")
        return
    names = ", ".join(port.name for port in model.kinematic_inputs)
    if duration is None:
        raise SimulationError(f"{model.source}: model {model.name!r} has kinematic inputs "
                              f"({names}): a time simulation needs the duration of their "
                              "move (Simulator(..., motion_duration=T), `flexure simulate "
                              "--motion-duration`); the sampled loop and the FMU do not take "
                              "them yet (docs/analyses.md)")
    if method not in MOTION_METHODS:
        raise SimulationError(f"method {method!r} cannot integrate the kinematic inputs "
                              f"({names}) of {model.name!r} yet; use one of "
                              f"{', '.join(MOTION_METHODS)}")


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
        path = quintic_path(model.motion_starts, model.motion_values, duration, float(t0))
        for data in (self.data, self._output_data):
            data.float_array("motion_path")[:] = path

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
        return path_values(self.data.float_array("motion_path"), self._t if t is None else t)

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
                      start: np.ndarray | None = None) -> np.ndarray:
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
        q_ref = data.float_array("q_ref")
        self._start_kinematics(self.model.initial_coordinates if start is None else start,
                               data)
        for row, (t, state) in enumerate(zip(times, states, strict=True)):
            q_ref[:] = state[:n]
            y = np.concatenate([np.zeros(n), state[n: 2 * n]])
            status = engine.call(data, engine.OP_RHS, y, t=float(t))
            if status != ed.OK:
                raise SimulationError(f"t = {t:.9g} s: the efforts of the kinematic inputs: "
                                      f"{STATUS_MESSAGES[status]}")
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


__all__ = ["MOTION_METHODS", "SimulatorMotion", "check_motion_method", "path_values"]
