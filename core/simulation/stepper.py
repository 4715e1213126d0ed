"""The integrator interface: what `Simulator` and the compiled sampled loop ask of a method.

Every method of the registry (`methods.REGISTRY`) runs on a `Stepper`: CVODE and IDA
(`sundials.Cvode`, `sundials.Ida`) and the ESDIRK family (`esdirk.Esdirk`). A stepper works on
the engine's packed model (`EngineData`): the held inputs are in its inputs array, the state is
y = [q - q_ref, qdot(, coil currents)] in `y_array`. `Simulator` owns time, state and inputs;
it drives a stepper through this interface only:

    stepper = Stepper.make(data, method, rtol=..., atol=..., max_step=..., ...)
    stepper.reset(t, y, inputs_changed=False)   # restart at (t, y) with the held inputs
    t, y = stepper.advance(t_stop)              # to t_stop exactly (or one step), inputs held
    stepper.learn_initial_step()                # after each successful advance
    stepper.restart_memory                      # the restart point: what it has learnt
    stepper.statistics(), stepper.step_count()
    stepper.forget()                            # the next restart from nothing

The restart of a simulator is one function, `Simulator._restart`: the held inputs and the
kinematics' start put into the engine by `restart_plant` (a compiled kernel), then
`Stepper.reset`. A one-step method (`Method.one_step`) keeps the kinematics' warm start after a
mere input change; the multistep methods restart them too.

The compiled "advance with held inputs" hook. `run_sampled_loop` drives the methods with
`Method.compiled_loop` without a Python call per sample: `Simulator.held_input_drive()` lends
it the stepper, the plant and the loop state (a `HeldInputDrive`) and takes them back after,
and per sample the loop calls the family's compiled restart kernel (`restart_plant`, then
`esdirk_kernels.restart` or `sundials_restart.cvode_restart`, the very kernels `Stepper.reset`
calls) and its compiled advance (`esdirk_kernels.advance`; CVODE's `CVode` through its C address).
So the loop and a Python loop of `set_inputs` and `advance_to` give the same numbers, bit for
bit.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..engine import access
from ..numerics.dense import copy
from ..numerics.jit import entry, kernel
from ..numerics.native import as_float_pointer, carray, float_address

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..engine.data import EngineData
    from ..errors import SimulationError
    from .methods import Method


class Stepper(ABC):
    """An integrator of y' = f(y) on the engine's packed model, inputs held.

    Attributes
    ----------
    method : Method
        Its registry entry.
    label : str
        Its name in messages ("CVODE BDF", "TR-BDF2").
    n : int
        The size of the state, 2 NDOF + coil currents.
    y_array : ndarray (n,)
        The state the stepper integrates (a view it keeps; a compiled driver reads and
        writes it).
    """

    method: Method
    label: str
    n: int
    y_array: np.ndarray

    @classmethod
    @abstractmethod
    def make(cls, data: EngineData, method: Method, *, rtol: float, atol: ArrayLike,
             max_step: float | None = None, jacobian: str = "analytic",
             max_order: int | None = None, input_function=None) -> Stepper:
        """The stepper for `method` on packed data (options it does not take are refused
        by `Simulator` first, from `Method.options`).

        Raises
        ------
        SimulationError
            An option value it cannot run with (a max_order out of range, ...).
        """

    @abstractmethod
    def reset(self, t: float, y: ArrayLike, *, inputs_changed: bool = False) -> None:
        """Restart at time t (s) from state y with the inputs now in the engine;
        inputs_changed: nothing but the inputs changed since its last step (a one-step
        method then keeps its last stage)."""

    @abstractmethod
    def advance(self, t_stop: float, *, one_step: bool = False,
                max_steps: int | None = None) -> tuple[float, np.ndarray]:
        """Integrate to t_stop (s), landing on it, never past it; one accepted step only
        with one_step; at most max_steps steps (else `StepBudgetSpent`). Returns the time
        reached and a view of y. Raises SimulationError (with `last_good`) on failure."""

    @abstractmethod
    def failure(self, status: int, t: float) -> SimulationError:
        """The SimulationError of a failed advance with this status at time t (s), naming
        the cause, with `last_good` = (t, y)."""

    @abstractmethod
    def statistics(self) -> dict[str, int]:
        """Counts since the stepper was made: at least "steps", "solver_rhs_evaluations" and
        "solver_jacobian_evaluations"."""

    def step_count(self) -> int:
        """Accepted steps since the stepper was made (for a step budget)."""
        return self.statistics()["steps"]

    def forget(self) -> None:  # noqa: B027 (a default: most steppers have nothing to do)
        """Start the next restart from nothing (no learnt step size or Jacobian)."""

    def learn_initial_step(self) -> None:  # noqa: B027 (a default: most steppers have nothing to do)
        """After a successful `advance`: keep what the first step taught, for the next
        restart."""

    @property
    def restart_memory(self) -> dict[str, object]:
        """The restart point: what the stepper has learnt, as plain numbers ("initial_step"
        (s), "jacobian" (n * n,) or empty, and its own keys); a snapshot holds it."""
        return {}

    @restart_memory.setter
    def restart_memory(self, memory: dict[str, object]) -> None:
        self.forget()

    def close(self) -> None:  # noqa: B027 (a default: most steppers have nothing to do)
        """Free what the stepper holds outside Python (idempotent)."""


@dataclass
class HeldInputDrive:
    """What `Simulator.held_input_drive()` lends a compiled driver (`run_sampled_loop`).

    Attributes
    ----------
    stepper : Stepper
        The simulator's integrator, its state in `stepper.y_array`.
    plant, outputs : EngineData
        The plant's packed model (the stepper's) and the outputs' (for measuring).
    loop_state : ndarray (3,)
        [t (s), 1.0 if the stepper must restart before its next step, 1.0 if the kinematics
        must start afresh there]; the driver keeps it current.
    held : ndarray (n_inputs,)
        The held inputs (N, N m, V); the driver keeps it current.
    wall : float
        The driver's wall time (s), added to the simulator's statistics.
    """

    stepper: Stepper
    plant: EngineData
    outputs: EngineData
    loop_state: np.ndarray
    held: np.ndarray
    wall: float = 0.0


@kernel
def restart_plant(table, inputs, x, kinematics):
    """The engine's side of a restart: the held inputs (N, N m, V) into the packed model at
    address `table`, and with `kinematics` the next kinematic solution started afresh (full
    Newton) from the coordinates x (NX,)."""
    copy(access.inputs(table), inputs)
    if kinematics:
        access.restart_kinematics(table, x)


@entry("void(int64, voidptr, int64, voidptr, int64, int64)")
def _restart_plant_entry(table, inputs, n_inputs, x, nx, kinematics):
    """`restart_plant` as a C entry, the arrays by address and size."""
    restart_plant(table, carray(as_float_pointer(inputs), (n_inputs,)),
                  carray(as_float_pointer(x), (nx,)), kinematics != 0)


def restart_plant_now(table, inputs, x, kinematics):
    """`restart_plant` from Python (through its C entry: a process that loads compiled code
    from the cache calls it without numba); inputs and x contiguous float64 arrays."""
    _restart_plant_entry.ctypes(table, float_address(inputs), inputs.size, float_address(x),
                                x.size, int(bool(kinematics)))


__all__ = ["HeldInputDrive", "Stepper", "restart_plant", "restart_plant_now"]
