"""The stepping `Simulator`: a model's nonlinear equations of motion under SUNDIALS.

The integrator's state is y = [q - q_ref, qdot] on the DOFs (m, rad, m/s, rad/s): the deviation
from a reference configuration q_ref, the DOFs where the run started (`reset`), and the
velocities. A flexure moves micrometres to millimetres away from a configuration whose
coordinates are centimetres (the 3-DOF stage: y = 0.1 m, moving 2 mm in x), so integrating the
absolute DOFs would let rtol act on 0.1 m; on the deviation it acts on the motion. The
constraints are solved away at every evaluation by the compiled engine
(`flexure.core.engine.engine`), never integrated; SUNDIALS calls the engine through compiled
callbacks (`flexure.core.simulation.sundials`), so no Python runs per evaluation. Inputs are
forces on the scene's input coordinates, or the drive signals (V) of the voice-coil actuators
that drive them (`flexure.core.mechanics.actuators`), held constant between `set_inputs` calls
(zero-order hold); a change of input is a discontinuity, so the integrator restarts there
(order 1, new step). A voltage-driven actuator's coil current (A) is a state: the state is then
y = [q - q_ref, qdot, i].

    sim = Simulator(model, method="cvode-bdf", rtol=1e-8)
    sim.set_inputs([1.0])            # N
    sim.advance_to(0.5)              # s: the end time, not a step
    sim.outputs()                    # the scene's outputs, m and m/s

A snapshot `get_state()` (`simulator_state`) is a restart point: the next `advance_to` restarts
the integrator from it, with the kinematics started afresh from the snapshot's coordinates, so
a run restored with `set_state` continues bit for bit like the original. The measuring
methods are in `simulator_outputs`, the snapshots in `simulator_state`, and the first-order
system for other solvers and the hand-over to the compiled sampled loop in
`simulator_system`.
"""

from __future__ import annotations

import math
import time as _time
import warnings
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np

from ..engine import data as ed
from ..engine.data import EngineData
from ..engine.status import status_message
from ..errors import SimulationError, StepBudgetSpent
from ..mechanics.ports import output_dofs
from .element_readings import ElementReadings
from .held_inputs import checked_inputs
from .methods import METHODS, REGISTRY
from .simulator_motion import SimulatorMotion, check_motion
from .simulator_outputs import SimulatorOutputs, measured_orders
from .simulator_state import STATE_VERSION, SimulatorState
from .simulator_system import SimulatorSystem
from .start import scene_dofs, solve_start, start_kinematics
from .stepper import Stepper, restart_plant_now
from .stepwise_motion import held_path
from .tolerances import atol_vector

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..model import Model

class Simulator(SimulatorOutputs, SimulatorState, SimulatorSystem, SimulatorMotion):
    """Integrates a model's nonlinear equations of motion step by step.

    Parameters
    ----------
    model : Model
        The model; its inputs are forces (N, N m) or moments about a global axis (N m), or
        actuators' drive signals (V); its outputs positions or velocities (m, rad, m/s,
        rad/s; an angle about a global axis is a rotation-vector component,
        `flexure.core.mechanics.ports`), then its outputs on elements, deformations (m) and
        stress resultants (N) (`element_readings`: a stress resultant is S e + D edot, its
        viscous term included; a rigid or prescribed deformation's the reaction).
    method : str
        "cvode-bdf" (stiff, default), "cvode-adams" (non-stiff), "ida", or "esdirk" (a one-step
        L-stable method of order 4, `flexure.core.simulation.esdirk`: no restart cost when an
        input changes, so the choice for sampled loops and co-simulation steps), "esdirk3" (its
        order-3 sibling: 4 stages instead of 6) or "esdirk2" (TR-BDF2, order 2, 3 stages: the
        sampled loop's default, where the sample period bounds the step).
    rtol : float
        Relative tolerance of the integrator.
    atol : float or array (2 NDOF + coil currents,), optional
        Absolute tolerance; default `tolerances.default_atol(model, rtol)` (per state).
    max_step : float, optional
        Largest step (s); None for no limit.
    jacobian : str
        "analytic" (the model's tangent, default) or "finite-difference" (SUNDIALS').
    max_order : int, optional
        Largest order of the multistep formulas (default SUNDIALS': 5 for BDF and IDA, 12
        for Adams). 2 makes BDF A-stable (docs/decisions.md: why it is not the default).
    input_functions : dict of int to callable, optional
        {input index: callable(t) -> N or V}: inputs that vary within an interval. They are
        evaluated in Python at every evaluation (the compiled path is for held inputs).
    rigid : bool
        Whether the engine eliminates the rigid clusters' slave coordinates (default True;
        False solves for every free coordinate, for comparison: `engine.rigid`).
    motion_duration : float, optional
        s: how long the scene's move of its kinematic inputs takes from t = 0 (a model with
        kinematic inputs needs it or `stepwise_motion`: `simulator_motion`, `set_motion`).
    stepwise_motion : bool
        The kinematic inputs are moved by a host step by step (`move_to`: the position at
        the end of each step, `stepwise_motion`), held at their `start` until then (default
        False; only for a model with kinematic inputs, and not with motion_duration).

    Raises
    ------
    SimulationError
        An unknown method, an rtol outside (0, 1), a max_step or atol that is not positive,
        an option the one-step methods do not take, a scene configuration the DOFs
        cannot be assembled in, or kinematic inputs without a motion_duration or
        stepwise_motion (or with both), or either without them.
    """

    def __init__(self, model: Model, *, method: str = "cvode-bdf", rtol: float = 1e-8,
                 atol: float | ArrayLike | None = None, max_step: float | None = None,
                 jacobian: str = "analytic", max_order: int | None = None,
                 input_functions: Mapping[int, Callable[[float], float]] | None = None,
                 rigid: bool = True, motion_duration: float | None = None,
                 stepwise_motion: bool = False) -> None:
        if method not in METHODS:
            raise SimulationError(f"unknown method {method!r}; expected one of "
                                  f"{', '.join(METHODS)}")
        if not (np.isfinite(rtol) and 0 < rtol < 1):
            raise SimulationError(f"rtol must be a number between 0 and 1, got {rtol!r}")
        if max_step is not None and not (np.isfinite(max_step) and max_step > 0):
            raise SimulationError(f"max_step must be a positive number (s), got {max_step!r}")
        check_motion(model, motion_duration, stepwise_motion)
        self._elements = ElementReadings(model)  # the outputs on elements
        self.model = model
        self.method, self.rtol, self.max_step, self.jacobian = method, rtol, max_step, jacobian
        self.data = EngineData(model, rigid=rigid)
        self.ndof = model.declared_dof_count
        # the integrator's states: [q - q_ref, qdot] and the coil currents (A)
        self.ncurrents = len(model.coil_actuators)
        self.nstate = 2 * self.ndof + self.ncurrents
        self.atol = atol_vector(model, rtol, atol, self.nstate, self.data)
        self.input_names = [p.name for p in model.inputs]
        self.input_units = [p.unit for p in model.inputs]
        ports = [*model.outputs, *model.element_outputs]  # the coordinate outputs first
        self.output_names = [p.name for p in ports]
        self.output_units = [p.unit for p in ports]
        self.dof_names = model.dof_names
        self.deadline = None  # a time.perf_counter() value past which `advance` stops
        self._u = np.zeros(len(model.inputs))
        self._input_functions = dict(input_functions or {})
        self._inputs = self.data.float_array("inputs")
        self._q_ref_array = self.data.float_array("q_ref")
        self.integrator: Stepper = _make_integrator(
            self.data, method, rtol=rtol, atol=self.atol, max_step=max_step, jacobian=jacobian,
            max_order=max_order,
            input_function=self._inputs_at if self._input_functions else None)
        self._output_data = EngineData(model, rigid=rigid)
        # the coordinates of the outputs on one coordinate (-1 for those about an axis, which
        # `_port_value` measures)
        self._output_coordinates = np.array([-1 if port.about_axis else port.coordinate
                                             for port in model.outputs], dtype=np.int64)
        self._about_axis = any(port.about_axis for port in model.outputs)
        self._orders = measured_orders(model)  # what of the state each output reads
        self._positions_only = not any(self._orders) and not model.element_outputs
        # every output a coordinate DOF (a stage's carriage): read from q, no kinematics
        dofs = output_dofs(model)
        self._output_dofs = (dofs if dofs.size and np.all(dofs >= 0)
                             and not model.element_outputs else None)
        self._output_dof_list = [] if self._output_dofs is None else self._output_dofs.tolist()
        self._range = None  # plausibility.RangeCheck, made on first use
        self._within = None  # its compiled check of the last evaluation, made on first use
        # views of the coordinates and deformations of the engine's last evaluation
        self._last_x, self._last_e = self.data.float_array("x"), self.data.float_array("e")
        if motion_duration is not None:  # the scene's move from t = 0 (`simulator_motion`)
            self._write_path(motion_duration, 0.0)
        elif model.kinematic_inputs:  # held at the start until a host moves them
            self._set_path(held_path(model.motion_starts, 0.0))
        self.reset()

    # -- state ----------------------------------------------------------------------------
    def reset(self, *, t0: float = 0.0, q0: ArrayLike | None = None,
              qdot0: ArrayLike | None = None, i0: ArrayLike | None = None) -> None:
        """Start again at t0 from q0, qdot0 and the coil currents i0 (default: the scene's
        configuration at rest, no current). The inputs are kept; the statistics restart.

        Parameters
        ----------
        t0 : float
            The start time, s.
        q0 : array_like (NDOF,), optional
            The DOFs, m or rad; they become the reference q_ref.
        qdot0 : array_like (NDOF,), optional
            The DOF velocities, m/s or rad/s.
        i0 : array_like (n_coils,), optional
            The coil currents of the voltage-driven actuators, A.

        Raises
        ------
        SimulationError
            A vector of the wrong size or not finite, or DOFs q0 the kinematics cannot be
            assembled at.
        """
        q = self._initial_dofs() if q0 is None else _vector(q0, self.ndof, "q0")
        qdot = np.zeros(self.ndof) if qdot0 is None else _vector(qdot0, self.ndof, "qdot0")
        i = (np.zeros(self.ncurrents) if i0 is None
             else _vector(i0, self.ncurrents, "i0"))
        if self.model.kinematic_inputs:  # on their path at t0, whatever q0 says
            q[self.model.prescribed_dofs] = self.prescribed_values(t0)[0]
        status = solve_start(self.model, self.data, q)
        if status != ed.OK:
            raise SimulationError(f"t = {t0:.9g} s: the initial DOFs q0 cannot be assembled: "
                                  f"{status_message(status)} (q0 = {np.array2string(q)})")
        self._t = float(t0)
        self._q_ref = q.copy()
        # the packed model's reference too (as `_restart` sets it): an engine call on
        # `data` before the first step evaluates y about the start, not about q = 0
        self._q_ref_array[:] = q
        self._y = np.concatenate([np.zeros(self.ndof), qdot, i])
        self._put_on_path()  # the kinematic inputs' entries (`simulator_motion`)
        self._restart_samples()
        self._x = self.data.float_array("x").copy()
        self._outputs_cache = None
        self._needs_init = self._restart_kinematics = True
        self._counters_at_reset = self._counts()
        self._wall = 0.0
        self.integrator.forget()

    def _initial_dofs(self):
        return scene_dofs(self.model, self.data)

    def _start_kinematics(self, x, data=None):
        """The next kinematic solution starts with full Newton from x (NX,)."""
        start_kinematics(data or self.data, x)

    @property
    def time(self) -> float:
        """The current time (s)."""
        return self._t

    @property
    def q(self) -> np.ndarray:
        """The current DOFs (NDOF,) m, rad (a copy)."""
        return self._q_ref + self._y[: self.ndof]

    @property
    def q_ref(self) -> np.ndarray:
        """The reference DOFs (NDOF,) m, rad the integrator's state is taken from (a copy)."""
        return self._q_ref.copy()

    @property
    def state(self) -> np.ndarray:
        """The integrator's state [q - q_ref, qdot, coil currents] (2 NDOF + currents,) (a
        copy)."""
        return self._y.copy()

    def absolute(self, y: ArrayLike) -> np.ndarray:
        """Absolute states [q, qdot(, i)] of integrator states [q - q_ref, qdot(, i)].

        Parameters
        ----------
        y : array_like (..., 2 NDOF + n_coils)
            Integrator states: m, rad; m/s, rad/s; A.

        Returns
        -------
        ndarray (..., 2 NDOF + n_coils)
            A copy with q_ref added to the DOFs.
        """
        y = np.array(y, dtype=float)
        y[..., : self.ndof] += self._q_ref
        return y

    @property
    def qdot(self) -> np.ndarray:
        """The current DOF velocities (NDOF,) m/s, rad/s (a copy)."""
        return self._y[self.ndof: 2 * self.ndof].copy()

    @property
    def currents(self) -> np.ndarray:
        """The coil currents now (A, one per voltage-driven actuator, `Model.coil_actuators`;
        a copy)."""
        return self._y[2 * self.ndof:].copy()

    @property
    def inputs(self) -> np.ndarray:
        """The inputs held now (n_inputs,) N or V (a copy)."""
        return self._u.copy()

    def set_inputs(self, u: ArrayLike) -> None:
        """Hold the inputs from now on (zero-order hold); a change restarts the integrator.

        Parameters
        ----------
        u : array_like (n_inputs,)
            N, N m for forces and moments, V for actuators' drive signals.

        Raises
        ------
        SimulationError
            The wrong number of inputs, or one that is not finite.
        """
        u, values = checked_inputs(u, self.input_names, self._t)
        if values != self._u.tolist():
            self._u = u
            self._needs_init = True
            # outputs that read the held inputs at this state (an acceleration, a kinematic
            # input's reaction) are measured again
            self._outputs_cache = None

    def close(self) -> None:
        """Free what the integrator holds outside Python (SUNDIALS' memory), now rather than
        when the collector finds it (idempotent); the simulator cannot advance after it.
        `with Simulator(...) as sim:` closes it at the end of the block."""
        self.integrator.close()

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def statistics(self) -> dict[str, float]:
        """Solver statistics since `reset`: steps, rhs and Jacobian evaluations, wall time (s)."""
        now, start = self._counts(), self._counters_at_reset
        return {"steps": now["steps"] - start["steps"],
                "rhs_evaluations": now["rhs"] - start["rhs"],
                "jacobian_evaluations": now["jacobians"] - start["jacobians"],
                "wall_time_s": self._wall}

    def _counts(self):
        counters = self.data.int_array("counters")
        solver = self.integrator.statistics()
        jacobians = (int(counters[ed.JACOBIAN_COUNT]) if self.jacobian == "analytic"
                     else solver["solver_jacobian_evaluations"])
        return {"steps": solver["steps"], "rhs": int(counters[ed.RHS_COUNT]),
                "jacobians": jacobians}

    # -- integration ----------------------------------------------------------------------
    def _inputs_at(self, t):
        u = self._u.copy()
        for i, function in self._input_functions.items():
            u[i] = function(t)
            if not np.isfinite(u[i]):
                raise SimulationError(f"t = {t:.9g} s: input {self.input_names[i]!r} is not "
                                      f"finite ({u[i]})")
        return u

    def _restart(self):
        """Restart the integrator at the current state with the held inputs: the one restart
        of an integrator (`stepper`), which the compiled sampled loop runs through the same
        kernels. The kinematics start afresh from the state's coordinates after anything that
        sets a state (reset, set_state, get_state, a failure), so that a restored run
        continues bit for bit; after a mere input change a one-step method keeps the warm
        start of its last evaluation (CVODE and IDA start afresh there too)."""
        self._q_ref_array[:] = self._q_ref
        restart_plant_now(self.data.address, self._u, self._x, self._kinematics_restart_due())
        # no state set since the last step: only the inputs changed
        self.integrator.reset(self._t, self._y, inputs_changed=not self._restart_kinematics)
        self._needs_init = self._restart_kinematics = False

    def _kinematics_restart_due(self):
        """Whether the next restart starts the kinematics afresh from the state's
        coordinates: always for the multistep methods, for a one-step method only after a
        state was set or a failure."""
        return self._restart_kinematics or not self.integrator.method.one_step

    def advance(self, t_end: float, *, max_steps: int | None = None) -> None:
        """Deprecated: `advance_to`, the same call under a name that says its argument is the
        absolute end time, not a step length.

        Parameters
        ----------
        t_end : float
            The end time, s, after the current one.
        max_steps : int, optional
            A budget of integrator steps for this call.
        """
        warnings.warn("Simulator.advance(t_end) is renamed advance_to(t_end): t_end is the "
                      "absolute end time, not a step", DeprecationWarning, stacklevel=2)
        self.advance_to(t_end, max_steps=max_steps)

    def advance_to(self, t_end: float, *, max_steps: int | None = None,
                   _record: Callable[[float, np.ndarray], None] | None = None,
                   _progress: Callable[[float], None] | None = None) -> None:
        """Integrate from `time` to the absolute time t_end, stopping exactly there.

        Parameters
        ----------
        t_end : float
            The end time, s, after the current one (an absolute time: a step of h from the
            current time is `advance_to(sim.time + h)`).
        max_steps : int, optional
            A budget of integrator steps for this call.

        Raises
        ------
        SimulationError
            A t_end not after the current time, a spent step budget, the deadline passed,
            or a failure of the integrator or the kinematics (naming the time and the
            cause); the simulator then stays at its last good state.
        """
        t_end = float(t_end)
        if not math.isfinite(t_end) or t_end <= self._t:
            raise SimulationError(f"t = {self._t:.9g} s: advance to t_end = {t_end!r}: expected "
                                  "a finite time after the current one")
        start = _time.perf_counter()
        steps_before = self.integrator.step_count() if max_steps is not None else 0
        # with a budget alone the integrator counts its steps itself (normal mode); a record,
        # a progress report or a deadline need control back after every step
        one_step = _record is not None or _progress is not None or self.deadline is not None
        retried_at = None
        try:
            while self._t < t_end:
                try:
                    if self._needs_init:
                        self._restart()
                    budget = None
                    if max_steps is not None and not one_step:
                        budget = max(1, max_steps - (self.integrator.step_count()
                                                     - steps_before))
                    t, y = self.integrator.advance(t_end, one_step=one_step, max_steps=budget)
                except StepBudgetSpent as error:  # no retry: the budget is the host's limit
                    self._back_to_last_good(error, t_end)
                    raise SimulationError(f"t = {self._t:.9g} s: the step budget of {max_steps} "
                                          "integrator steps is spent") from None
                except SimulationError as error:
                    self._back_to_last_good(error, t_end)
                    if retried_at == self._t:  # failed again from the same good state
                        raise SimulationError(
                            f"simulation of {self.model.name!r} stopped at t = {self._t:.9g} s "
                            f"(last good state): {error}") from None
                    retried_at = self._t
                    continue
                self._t = t
                self._y = np.array(y, dtype=float)
                self._x = self._last_x.copy()
                self.integrator.learn_initial_step()
                self._outputs_cache = None
                if _record is not None:
                    _record(t, self._y)
                if _progress is not None:
                    _progress(t)
                if one_step:
                    self._check_budget(steps_before, max_steps)
        finally:
            self._wall += _time.perf_counter() - start

    def _back_to_last_good(self, error, t_end):
        """After a failed integrator call: continue from the last good state the error
        carries (if it is past the current time), with a restart of the integrator and the
        kinematics."""
        self._needs_init = self._restart_kinematics = True
        t_good, y_good = getattr(error, "last_good", (self._t, None))
        if y_good is not None and self._t < t_good < t_end:
            self._t, self._y = t_good, np.array(y_good, dtype=float)
            self._x = self.data.float_array("x").copy()
            self._outputs_cache = None

    def _check_budget(self, steps_before, max_steps):
        if self.deadline is not None and _time.perf_counter() > self.deadline:
            self._needs_init = True
            raise SimulationError(f"t = {self._t:.9g} s: the time limit of the run is over")
        if max_steps is not None and self.integrator.step_count() - steps_before >= max_steps \
                and self._t < np.inf:
            self._needs_init = True
            raise SimulationError(f"t = {self._t:.9g} s: the step budget of {max_steps} "
                                  "integrator steps is spent")


def _make_integrator(data, method, *, rtol, atol, max_step, jacobian, max_order,
                     input_function):
    """The registered method's `Stepper` (its module, e.g. SUNDIALS' callbacks, loaded only
    where it runs), after refusing the options the method does not take."""
    entry = REGISTRY[method]
    refused = {"max_order": ("max_order", max_order is not None),
               "jacobian": ("finite-difference", jacobian != "analytic"),
               "input_functions": ("input_functions", input_function is not None)}
    for name, (option, given) in refused.items():
        if given and not entry.takes(option):
            raise SimulationError(f"method {method!r} takes no {name} (a one-step method "
                                  "with the analytic Jacobian and held inputs); use a CVODE "
                                  "or IDA method for that")
    return entry.stepper_class().make(data, entry, rtol=rtol, atol=atol, max_step=max_step,
                                      jacobian=jacobian, max_order=max_order,
                                      input_function=input_function)


def _vector(value, size, name):
    v = np.array(value, dtype=float).reshape(-1)
    if v.size != size or not np.all(np.isfinite(v)):
        raise SimulationError(f"{name}: expected {size} finite values, got {value!r}")
    return v


__all__ = ["METHODS", "Simulator", "STATE_VERSION"]
