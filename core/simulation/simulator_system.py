"""The stepping `Simulator` seen from outside its own `advance`: its first-order system
ydot = f(t, y) and Jacobian for solvers outside SUNDIALS (the scipy baselines of the
work-precision study, finite-difference checks), and the hand-over of its integrator to the
compiled sampled loop (`flexure.core.simulation.sampled_loop`) and back."""

from __future__ import annotations

import time as _time
from typing import TYPE_CHECKING

import numpy as np

from ..engine import data as ed
from ..engine import engine
from ..errors import SimulationError
from .status import STATUS_MESSAGES

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..engine.data import EngineData
    from .esdirk import Esdirk
    from .sundials import Cvode, Ida


class SimulatorSystem:
    """The first-order system and hand-over methods of `Simulator` (which sets up the
    attributes they read and write: `data`, `_output_data`, `nstate`, the integrator, the
    state `_t`, `_y`, `_q_ref`, `_u`, `_x`, the engine's `_inputs` and `_q_ref_array`, the
    restart flags and `_wall`)."""

    # -- handing the integrator to a compiled driver (flexure.core.simulation.sampled_loop)
    def hand_over(self) -> tuple[Cvode | Ida | Esdirk, EngineData, EngineData, bool, bool]:
        """Put the state into the integrator's vector and set the kinematic reference, for a
        compiled driver; the driver's first interval restarts as `advance` would.

        Returns
        -------
        (integrator, EngineData, EngineData, bool, bool)
            The integrator, the plant's packed data, the outputs' packed data, whether the
            integrator needs a restart, and whether the kinematics do.
        """
        self._q_ref_array[:] = self._q_ref
        self.integrator.y_array[:] = self._y
        return (self.integrator, self.data, self._output_data, self._needs_init,
                self._kinematics_restart_due())

    def take_back(self, t: float, y: ArrayLike, u: ArrayLike, *, restart_needed: bool,
                  wall: float) -> None:
        """Continue from where a compiled driver left the integrator.

        Parameters
        ----------
        t : float
            The time reached, s.
        y : array_like (2 NDOF + n_coils,)
            The integrator state there, [q - q_ref, qdot, i] (m, rad; m/s, rad/s; A).
        u : array_like (n_inputs,)
            The inputs held there: N, N m, or V for a drive signal.
        restart_needed : bool
            Whether the integrator (and the kinematics) must restart before the next step.
        wall : float
            The driver's wall time, s, added to the statistics.
        """
        self._t, self._y, self._u = float(t), np.array(y, dtype=float), np.array(u, dtype=float)
        self._x = self.data.float_array("x").copy()
        self._outputs_cache = None
        self._needs_init = bool(restart_needed)
        self._restart_kinematics = self._needs_init
        self._wall += wall

    # -- the first-order system, for solvers outside SUNDIALS (scipy baselines) ------------
    def derivative(self, t: float, y: ArrayLike) -> np.ndarray:
        """ydot = f(t, y) of the integrator state y = [q - q_ref, qdot, i].

        Parameters
        ----------
        t : float
            The time, s (for the input functions and the deadline).
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
                             ydot)
        if status != ed.OK:
            raise SimulationError(f"t = {t:.9g} s: {STATUS_MESSAGES[status]}")
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
                             J, s=0.0)
        if status != ed.OK:
            raise SimulationError(f"t = {t:.9g} s: {STATUS_MESSAGES[status]}")
        return J.reshape(self.nstate, self.nstate)

    def _prepare(self, t):
        if self.deadline is not None and _time.perf_counter() > self.deadline:
            raise SimulationError(f"t = {t:.9g} s: the time limit of the run is over")
        self._inputs[:] = self._inputs_at(t) if self._input_functions else self._u
        self._q_ref_array[:] = self._q_ref


__all__ = ["SimulatorSystem"]
