"""The snapshots of the stepping `Simulator`: `get_state` and `set_state`.

A snapshot holds the whole state as plain numbers and arrays (version 2): the time t (s),
the integrator's state y = [q - q_ref, qdot(, coil currents)], the reference DOFs q_ref, the
held inputs u, the coordinates x and what a one-step integrator has learnt (its step, its
Jacobian; `esdirk.Esdirk.restart_memory`), and with kinematic inputs their path and the
positions a host set (`simulator_motion`). Taking one marks a restart point, so a run
restored with `set_state` continues bit for bit like the original.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import SimulationError

STATE_VERSION = 2
# what a one-step integrator learns besides its step and Jacobian (esdirk.Esdirk.restart_memory)
MEMORY_KEYS = ("lu_step", "newton_rate", "refresh", "extra_iterations", "input_step",
               "newton_age")


class SimulatorState:
    """The snapshot methods of `Simulator` (which sets up the attributes they read and
    write: the model, `ndof`, `nstate`, the integrator and the state `_t`, `_y`, `_q_ref`,
    `_u`, `_x`, with its restart flags `_needs_init`, `_restart_kinematics` and the outputs'
    `_outputs_cache`)."""

    def get_state(self) -> dict[str, object]:
        """A snapshot of the whole state; the next `advance` restarts from it.

        Returns
        -------
        dict
            Plain numbers and arrays (module docstring): "version", "model", "t" (s), "y"
            (the integrator state), "q_ref" (m, rad), "u" (N, N m, V), "x" (m, rad), what
            a one-step integrator has learnt and, with kinematic inputs, their path
            ("motion_path") and the positions a host set ("motion_times" s,
            "motion_positions" m or rad: `simulator_motion`).
        """
        self._needs_init = self._restart_kinematics = True
        memory = self.integrator.restart_memory  # the stepper's restart point
        return {"version": STATE_VERSION, "model": self.model.name, "t": self._t,
                "y": self._y.copy(), "q_ref": self._q_ref.copy(), "u": self._u.copy(),
                "x": self._x.copy(), "initial_step": memory.get("initial_step", 0.0),
                "jacobian": memory.get("jacobian", np.zeros(0)),
                **{key: value for key, value in memory.items() if key in MEMORY_KEYS},
                **self._motion_snapshot()}

    def set_state(self, state: Mapping[str, object]) -> None:
        """Restore a snapshot of `get_state` (of a simulator of the same model).

        A version-1 snapshot (absolute y = [q, qdot]) is taken from the configuration it
        holds.

        Parameters
        ----------
        state : mapping
            A snapshot of `get_state`.

        Raises
        ------
        SimulationError
            Not a snapshot, one of another model or size, or one with non-finite numbers.
            A snapshot without a motion path keeps the simulator's.
        """
        try:
            version = int(state.get("version", 1))
            y = np.array(state["y"], dtype=float).reshape(-1)
            q_ref = np.array(state["q_ref"] if version >= 2 else y[: y.size // 2],
                             dtype=float).reshape(-1)
            u = np.array(state["u"], dtype=float).reshape(-1)
            x = np.array(state["x"], dtype=float).reshape(-1)
            t = float(state["t"])
        except (AttributeError, KeyError, TypeError, ValueError) as error:
            raise SimulationError(f"not a simulator state: {error}") from None
        if (state.get("model") != self.model.name or y.size != self.nstate
                or q_ref.size != self.ndof):
            raise SimulationError(f"the state is of model {state.get('model')!r} with "
                                  f"{y.size} states; expected {self.model.name!r} with "
                                  f"{self.nstate}")
        if u.size != self._u.size or x.size != self.model.nx:
            raise SimulationError(f"the state holds {u.size} inputs and {x.size} coordinates; "
                                  f"expected {self._u.size} and {self.model.nx}")
        if not (np.isfinite(t) and np.all(np.isfinite(y)) and np.all(np.isfinite(q_ref))
                and np.all(np.isfinite(u)) and np.all(np.isfinite(x))):
            raise SimulationError("the state holds non-finite numbers")
        motion = self._checked_motion(state)
        if version < 2:
            y[: self.ndof] = 0.0
        self._t, self._y, self._u, self._x = t, y, u, x
        self._restore_motion(motion)
        self._q_ref = q_ref
        try:  # what the integrator had learnt (a stepper without a memory forgets)
            self.integrator.restart_memory = {
                "initial_step": float(state.get("initial_step", 0.0)),
                "jacobian": np.asarray(state.get("jacobian", ()), dtype=float),
                **{key: float(state[key]) for key in MEMORY_KEYS if key in state}}
        except (TypeError, ValueError) as error:
            raise SimulationError(f"not a simulator state: {error}") from None
        self._outputs_cache = None
        self._needs_init = self._restart_kinematics = True


__all__ = ["MEMORY_KEYS", "STATE_VERSION", "SimulatorState"]
