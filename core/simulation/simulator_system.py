"""The stepping `Simulator` seen from outside its own `advance`: its first-order system
ydot = f(t, y) and Jacobian for solvers outside SUNDIALS (the scipy baselines of the
work-precision study, finite-difference checks), and the loan of its integrator to a compiled
driver with held inputs (`held_input_drive`: `flexure.core.simulation.sampled_loop`)."""

from __future__ import annotations

import time as _time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np

from ..engine import data as ed
from ..engine import engine
from ..engine.status import status_message
from ..errors import SimulationError
from .stepper import HeldInputDrive

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike


class SimulatorSystem:
    """The first-order system and the integrator's loan of `Simulator` (which sets up the
    attributes they read and write: `data`, `_output_data`, `nstate`, the integrator, the
    state `_t`, `_y`, `_q_ref`, `_u`, `_x`, the engine's `_inputs` and `_q_ref_array`, the
    restart flags and `_wall`)."""

    # -- lending the integrator to a compiled driver (flexure.core.simulation.sampled_loop)
    @contextmanager
    def held_input_drive(self) -> Iterator[HeldInputDrive]:
        """Lend the integrator to a compiled driver that advances it with held inputs
        (`stepper`: the compiled hook), and continue from where the driver left it.

        On entry the state goes into the integrator's vector and the kinematic reference
        into the engine; the driver's first interval restarts as `advance_to` would
        (`HeldInputDrive.loop_state`). When the block ends normally the simulator continues
        from the drive's time, the integrator's state and the drive's held inputs; when it
        raises, the simulator stays where it was and restarts from there.

        Yields
        ------
        HeldInputDrive
            The integrator, the plant's and the outputs' packed data, the loop state [t,
            restart needed, kinematics restart needed] and the held inputs, for the driver
            to keep current.
        """
        self._q_ref_array[:] = self._q_ref
        self.integrator.y_array[:] = self._y
        drive = HeldInputDrive(
            stepper=self.integrator, plant=self.data, outputs=self._output_data,
            loop_state=np.array([self._t, float(self._needs_init),
                                 float(self._kinematics_restart_due())]),
            held=np.array(self._u, dtype=float))
        try:
            yield drive
        except BaseException:
            self._needs_init = self._restart_kinematics = True
            raise
        self._resume_after_drive(drive)

    def _resume_after_drive(self, drive: HeldInputDrive) -> None:
        """Continue from where a compiled driver left the integrator: the time reached
        (s), the integrator's state there, the inputs held there, whether the integrator
        (and the kinematics) must restart before the next step, and its wall time."""
        t, restart_needed = drive.loop_state[0], drive.loop_state[1] != 0.0
        self._t, self._y = float(t), np.array(drive.stepper.y_array, dtype=float)
        self._u = np.array(drive.held, dtype=float)
        self._x = self.data.float_array("x").copy()
        self._outputs_cache = None
        self._needs_init = bool(restart_needed)
        self._restart_kinematics = self._needs_init
        self._wall += drive.wall

    # -- the first-order system, for solvers outside SUNDIALS (scipy baselines) ------------
    def derivative(self, t: float, y: ArrayLike) -> np.ndarray:
        """ydot = f(t, y) of the integrator state y = [q - q_ref, qdot, i].

        Parameters
        ----------
        t : float
            The time, s (for the input functions, the kinematic inputs' path and the
            deadline).
        y : array_like (2 NDOF + n_coils,)
            The integrator state: m, rad; m/s, rad/s; A.

        Returns
        -------
        ndarray (2 NDOF + n_coils,)
            ydot: m/s, rad/s; m/s^2, rad/s^2; A/s.

        Raises
        ------
        SimulationError
            The state cannot be evaluated (the kinematics fail), or the deadline passed.
        """
        self._prepare(t)
        ydot = np.empty(self.nstate)
        status = engine.call(self.data, engine.OP_RHS, np.ascontiguousarray(y, dtype=float),
                             ydot, t=float(t))
        if status != ed.OK:
            raise SimulationError(f"t = {t:.9g} s: {status_message(status)}")
        return ydot

    def jacobian_matrix(self, t: float, y: ArrayLike) -> np.ndarray:
        """d ydot / d y from the model's tangent at (t, y).

        Parameters
        ----------
        t : float
            The time, s.
        y : array_like (2 NDOF + n_coils,)
            The integrator state: m, rad; m/s, rad/s; A.

        Returns
        -------
        ndarray (N, N)
            N = 2 NDOF + n_coils; in units of ydot per unit of y (1/s, 1/s^2, ...).

        Raises
        ------
        SimulationError
            The state cannot be evaluated, or the deadline passed.
        """
        self._prepare(t)
        J = np.empty(self.nstate ** 2)
        status = engine.call(self.data, engine.OP_JACOBIAN, np.ascontiguousarray(y, dtype=float),
                             J, s=0.0, t=float(t))
        if status != ed.OK:
            raise SimulationError(f"t = {t:.9g} s: {status_message(status)}")
        return J.reshape(self.nstate, self.nstate)

    def _prepare(self, t):
        if self.deadline is not None and _time.perf_counter() > self.deadline:
            raise SimulationError(f"t = {t:.9g} s: the time limit of the run is over")
        self._inputs[:] = self._inputs_at(t) if self._input_functions else self._u
        self._q_ref_array[:] = self._q_ref


__all__ = ["SimulatorSystem"]
