"""Nonlinear time-domain simulation: a stepping `Simulator` and the one-call `simulate`.

The integrator's state is y = [q - q_ref, qdot] on the DOFs (m, rad, m/s, rad/s): the
deviation from a reference configuration q_ref, the DOFs where the run started (`reset`),
and the velocities. A flexure moves micrometres to millimetres away from a configuration
whose coordinates are centimetres (the 3-DOF stage: y = 0.1 m, moving 2 mm in x), so
integrating the absolute DOFs would let rtol act on 0.1 m; on the deviation it acts on the
motion. The constraints are solved away at every evaluation (`flexure.core.dynamics`) and
never integrated. Inputs are forces on the scene's input coordinates, held constant between
`set_inputs` calls (zero-order hold); a change of input is a discontinuity, so the
integrator restarts there (order 1, new step).

    sim = Simulator(model, method="cvode-bdf", rtol=1e-8)
    sim.set_inputs([1.0])            # N
    sim.advance(0.5)                 # s
    sim.outputs()                    # the scene's outputs, m and m/s

A snapshot `get_state()` is a restart point: the next `advance` restarts the integrator from
it, so a run restored with `set_state` continues bit for bit like the original.
"""

import time as _time
from dataclasses import dataclass, field

import numpy as np

from .dynamics import Dynamics, FirstOrderSystem
from .errors import ConvergenceError, FlexureError, SimulationError
from .integrators import METHODS, make_integrator

STATE_VERSION = 2


class Simulator:
    """Integrates a model's nonlinear equations of motion step by step.

    Parameters
    ----------
    model : Model
        The model; its inputs are forces (N, N m), its outputs positions or velocities.
    method : str
        "cvode-bdf" (stiff, default), "cvode-adams" (non-stiff) or "ida".
    rtol : float
        Relative tolerance of the integrator.
    atol : float or array (2 NDOF,), optional
        Absolute tolerance; default `default_atol(model, rtol)` (per state).
    max_step : float, optional
        Largest step (s); None for no limit.
    jacobian : str
        "analytic" (the model's tangent, default) or "finite-difference" (SUNDIALS').
    max_order : int, optional
        Largest order of the multistep formulas (default SUNDIALS': 5 for BDF and IDA, 12
        for Adams). 2 makes BDF A-stable; measured, that is not the better default, see
        `flexure.core.integrators`.
    """

    def __init__(self, model, *, method="cvode-bdf", rtol=1e-8, atol=None, max_step=None,
                 jacobian="analytic", max_order=None):
        if method not in METHODS:
            raise SimulationError(f"unknown method {method!r}; expected one of "
                                  f"{', '.join(METHODS)}")
        if not (np.isfinite(rtol) and rtol > 0):
            raise SimulationError(f"rtol must be a positive number, got {rtol!r}")
        if max_step is not None and not (np.isfinite(max_step) and max_step > 0):
            raise SimulationError(f"max_step must be a positive number (s), got {max_step!r}")
        self.model = model
        self.method, self.rtol, self.max_step, self.jacobian = method, rtol, max_step, jacobian
        self.dynamics = Dynamics(model)
        self.ndof = self.dynamics.ndof
        self.atol = _atol_vector(model, rtol, atol, self.ndof)
        self.input_names = [p.name for p in model.inputs]
        self.input_units = [p.unit for p in model.inputs]
        self.output_names = [p.name for p in model.outputs]
        self.output_units = [p.unit for p in model.outputs]
        self.dof_names = model.dof_names
        self._u = np.zeros(len(model.inputs))
        self._input_functions = {}  # index -> callable(t), used by `simulate`
        self.system = FirstOrderSystem(self.dynamics, self._inputs_at)
        self.integrator = make_integrator(self.system, method, rtol=rtol, atol=self.atol,
                                          max_step=max_step, jacobian=jacobian,
                                          max_order=max_order)
        self._output_dynamics = Dynamics(model, mechanics=self.dynamics.mech)
        self.reset()

    # -- state ----------------------------------------------------------------------------
    def reset(self, *, t0=0.0, q0=None, qdot0=None):
        """Start again at t0 (s) from q0, qdot0 (default: the scene's configuration at rest).

        The inputs are kept; the statistics restart from zero.
        """
        dyn = self.dynamics
        dyn.reset_warm_start()
        q = dyn.kin.dofs_of(self.model.initial_coordinates) if q0 is None else _vector(
            q0, self.ndof, "q0")
        qdot = np.zeros(self.ndof) if qdot0 is None else _vector(qdot0, self.ndof, "qdot0")
        try:
            config = dyn.solve(q)
        except ConvergenceError as error:
            raise SimulationError(f"t = {t0:.9g} s: the initial DOFs q0 cannot be "
                                  f"assembled: {error}") from None
        self._t = float(t0)
        self._q_ref = q.copy()
        self.system.q_ref = self._q_ref
        self._y = np.concatenate([np.zeros(self.ndof), qdot])
        self._x = config.x.copy()
        self._outputs_cache = None
        self._needs_init = True
        self.system.rhs_count = self.system.jacobian_count = 0
        self.integrator.steps = 0
        self._wall = 0.0

    @property
    def time(self):
        """The current time (s)."""
        return self._t

    @property
    def q(self):
        """The current DOFs (NDOF,) m, rad (a copy)."""
        return self._q_ref + self._y[: self.ndof]

    @property
    def q_ref(self):
        """The reference DOFs (NDOF,) m, rad the integrator's state is taken from (a copy)."""
        return self._q_ref.copy()

    def absolute(self, y):
        """States [q, qdot] (..., 2 NDOF) of integrator states [q - q_ref, qdot] (a copy)."""
        y = np.array(y, dtype=float)
        y[..., : self.ndof] += self._q_ref
        return y

    @property
    def qdot(self):
        """The current DOF velocities (NDOF,) m/s, rad/s (a copy)."""
        return self._y[self.ndof:].copy()

    @property
    def inputs(self):
        """The inputs held now (n_inputs,) N (a copy)."""
        return self._u.copy()

    def set_inputs(self, u):
        """Hold the inputs u (n_inputs,) N from now on; a change restarts the integrator."""
        u = np.array(u, dtype=float).reshape(-1)
        if u.size != self._u.size:
            raise SimulationError(f"t = {self._t:.9g} s: expected {self._u.size} inputs "
                                  f"({', '.join(self.input_names)}), got {u.size}")
        bad = np.flatnonzero(~np.isfinite(u))
        if bad.size:
            i = int(bad[0])
            raise SimulationError(f"t = {self._t:.9g} s: input {self.input_names[i]!r} is "
                                  f"not finite ({u[i]})")
        if not np.array_equal(u, self._u):
            self._u = u
            self._needs_init = True

    def get_state(self):
        """A picklable snapshot of the whole state; the next `advance` restarts from it."""
        self._needs_init = True
        return {"version": STATE_VERSION, "model": self.model.name, "t": self._t,
                "y": self._y.copy(), "q_ref": self._q_ref.copy(), "u": self._u.copy(),
                "x": self._x.copy()}

    def set_state(self, state):
        """Restore a snapshot of `get_state` (of a simulator of the same model).

        A version-1 snapshot (absolute y = [q, qdot]) is taken from the configuration it
        holds."""
        try:
            y = np.array(state["y"], dtype=float)
            q_ref = np.array(state["q_ref"] if state.get("version", 1) >= 2 else
                             y[: y.size // 2], dtype=float)
            u = np.array(state["u"], dtype=float)
            x = np.array(state["x"], dtype=float)
            t = float(state["t"])
        except (KeyError, TypeError, ValueError) as error:
            raise SimulationError(f"not a simulator state: {error}") from None
        if (state.get("model") != self.model.name or y.size != 2 * self.ndof
                or q_ref.size != self.ndof):
            raise SimulationError(f"the state is of model {state.get('model')!r} with "
                                  f"{y.size} states; expected {self.model.name!r} with "
                                  f"{2 * self.ndof}")
        if state.get("version", 1) < 2:
            y[: self.ndof] = 0.0
        self._t, self._y, self._u, self._x = t, y, u, x
        self._q_ref = q_ref
        self.system.q_ref = q_ref
        self._outputs_cache = None
        self._needs_init = True

    @property
    def statistics(self):
        """Cumulative solver statistics: steps, rhs and Jacobian evaluations, wall time (s)."""
        return {"steps": self.integrator.steps,
                "rhs_evaluations": self.system.rhs_count,
                "jacobian_evaluations": self._jacobian_count(),
                "wall_time_s": self._wall}

    def _jacobian_count(self):
        if self.jacobian == "analytic":
            return self.system.jacobian_count
        return self.integrator.fd_jacobians()

    # -- integration ----------------------------------------------------------------------
    def _inputs_at(self, t):
        if not self._input_functions:
            return self._u
        u = self._u.copy()
        for i, function in self._input_functions.items():
            u[i] = function(t)
            if not np.isfinite(u[i]):
                raise SimulationError(f"t = {t:.9g} s: input {self.input_names[i]!r} is not "
                                      f"finite ({u[i]})")
        return u

    def _restart(self):
        self.dynamics.reset_warm_start(self._x)
        self.integrator.reset(self._t, self._y)
        self._needs_init = False

    def advance(self, t_end, *, _record=None):
        """Integrate from `time` to t_end (s), stopping exactly there.

        Raises SimulationError (naming the time and the cause) on failure; the simulator
        then stays at its last good state.
        """
        t_end = float(t_end)
        if not np.isfinite(t_end) or t_end <= self._t:
            raise SimulationError(f"t = {self._t:.9g} s: advance to t_end = {t_end!r}: expected "
                                  "a finite time after the current one")
        start = _time.perf_counter()
        retried_at = None
        try:
            while self._t < t_end:
                try:
                    if self._needs_init:
                        self._restart()
                    t, y = self.integrator.step(t_end)
                except (FlexureError, ArithmeticError, np.linalg.LinAlgError) as error:
                    self._needs_init = True
                    if retried_at == self._t:  # failed again from the same good state
                        raise SimulationError(
                            f"simulation of {self.model.name!r} stopped at t = {self._t:.9g} s "
                            f"(last good state): {error}") from None
                    retried_at = self._t
                    continue
                self._t = t
                self._y = np.array(y, dtype=float)
                self._x = self.dynamics._x.copy()
                self._outputs_cache = None
                if _record is not None:
                    _record(t, self._y)
        finally:
            self._wall += _time.perf_counter() - start

    def outputs(self):
        """The declared outputs at the current state (n_outputs,): positions m, velocities m/s.

        Computed once per state (`advance`, `reset` and `set_state` start a new one), from the
        kinematics of the integrator's last evaluation: chord iterations on its constraint
        Jacobian, positions only unless a velocity is asked for."""
        if self._outputs_cache is None:
            self._outputs_cache = self._outputs_now()
        return self._outputs_cache.copy()

    def _outputs_now(self):
        dyn, source = self._output_dynamics, self.dynamics
        if source._DF is not None:  # share the last evaluation's kinematics as warm start
            dyn._x, dyn._q, dyn._DF, dyn._lu = source._x, source._q, source._DF, source._lu
            dyn._hessians = None
        else:
            dyn.reset_warm_start(self._x)
        ports = self.model.outputs
        try:
            x = dyn.positions(self.q)
            if any(p.quantity == "velocity" for p in ports):
                config = dyn.kin.configuration(self.q, x.copy())
                xdot = config.DF @ self._y[self.ndof:]
                return np.array([xdot[p.coordinate] if p.quantity == "velocity" else
                                 x[p.coordinate] for p in ports])
        except ConvergenceError as error:
            raise SimulationError(f"t = {self._t:.9g} s: outputs: {error}") from None
        return x[[p.coordinate for p in ports]]


@dataclass
class SimulationResult:
    """A simulated trajectory, SI units.

    times (n,) s; q, qdot (n, NDOF); outputs {name: (n,)}; output_array (n, n_outputs).
    """

    model_name: str
    method: str
    rtol: float
    times: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    dof_names: list
    output_names: list
    output_units: list
    output_array: np.ndarray
    statistics: dict
    inputs: np.ndarray = field(default=None)  # (n, n_inputs) N
    input_names: list = field(default_factory=list)

    @property
    def outputs(self):
        """{output name: (n,) array}."""
        return {name: self.output_array[:, i] for i, name in enumerate(self.output_names)}

    def to_csv(self, path):
        """Write `time` and one column per output (units in the header) to a CSV file."""
        header = ",".join(["time [s]"] + [f"{n} [{u}]" for n, u in
                                          zip(self.output_names, self.output_units,
                                              strict=True)])
        data = np.column_stack([self.times, self.output_array])
        np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.12g")

    def plot(self, path):
        """Plot every output against time to a PNG file."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        n = max(1, len(self.output_names))
        fig, axes = plt.subplots(n, 1, sharex=True, figsize=(7, 2.2 * n + 0.8), squeeze=False)
        for i, (name, unit) in enumerate(zip(self.output_names, self.output_units, strict=True)):
            axes[i, 0].plot(self.times, self.output_array[:, i])
            axes[i, 0].set_ylabel(f"{name} [{unit}]")
            axes[i, 0].grid(True, alpha=0.3)
        axes[-1, 0].set_xlabel("time [s]")
        fig.suptitle(f"{self.model_name}: {self.method}, rtol {self.rtol:g}")
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)


def simulate(model, t_end, *, inputs=None, method="cvode-bdf", rtol=1e-8, atol=None,
             max_step=None, output_times=None, jacobian="analytic", max_order=None, q0=None,
             qdot0=None, deadline=None, progress=None):
    """Simulate `model` from rest (or q0, qdot0) at t = 0 to t_end (s).

    Parameters
    ----------
    inputs : dict, optional
        {input name: constant N | callable(t) -> N | (times, values) held constant from each
        sample time to the next (zero-order hold; values[0] before the first sample)}.
        Unnamed inputs are zero.
    output_times : array, optional
        Times (s) at which to record; default every accepted integrator step.
    deadline : float, optional
        A `time.perf_counter()` value after which the run stops with a SimulationError.
    progress : callable, optional
        Called with the fraction of t_end reached (0 to 1) after every accepted step, e.g. a
        `flexure.core.progress.Progress`.

    Returns
    -------
    SimulationResult
    """
    if not (np.isfinite(t_end) and t_end > 0):
        raise SimulationError(f"t_end must be a positive time (s), got {t_end!r}")
    sim = Simulator(model, method=method, rtol=rtol, atol=atol, max_step=max_step,
                    jacobian=jacobian, max_order=max_order)
    sim.reset(q0=q0, qdot0=qdot0)
    sim.system.deadline = deadline
    constants, functions, samples = _classify_inputs(sim, inputs or {})
    u0 = np.zeros(len(sim.input_names))
    for i, value in constants.items():
        u0[i] = value
    for i, (_, values) in samples.items():
        u0[i] = values[0]
    sim.set_inputs(u0)
    sim._input_functions = functions
    breaks = sorted({float(t) for times, _ in samples.values() for t in times
                     if 0.0 < t < t_end})
    if output_times is None:
        grid = None
    else:
        grid = np.asarray(output_times, dtype=float)
        if grid.ndim != 1 or np.any(np.diff(grid) <= 0) or grid[0] < 0 or grid[-1] > t_end:
            raise SimulationError("output_times must increase strictly within [0, t_end]")
    times, states, held = [0.0], [sim.absolute(sim._y)], [sim._inputs_at(0.0).copy()]

    def record(t, y):
        times.append(t)
        states.append(sim.absolute(y))
        held.append(sim._inputs_at(t).copy())

    def on_step(t, y):
        if grid is None:
            record(t, y)
        if progress is not None:
            progress(t / t_end)

    stops = sorted(set(breaks) | {float(t_end)} | (set(grid.tolist()) if grid is not None
                                                    else set()))
    for stop in stops:
        if stop <= sim.time:
            continue
        sim.advance(stop, _record=on_step if grid is None or progress is not None else None)
        if grid is not None and np.any(grid == stop):
            record(stop, sim._y)
        if stop in breaks:
            u = sim.inputs
            for i, (t_samples, values) in samples.items():
                u[i] = values[np.searchsorted(t_samples, stop, side="right") - 1]
            sim.set_inputs(u)
    times = np.array(times)
    states = np.array(states)
    if grid is not None:  # keep exactly the requested times
        keep = np.isin(times, grid)
        if grid[0] == 0.0:
            keep[0] = True
        else:
            keep[0] = False
        times, states, held = times[keep], states[keep], np.array(held)[keep]
    outputs = _outputs_along(sim, states)
    n = sim.ndof
    return SimulationResult(model_name=model.name, method=method, rtol=rtol, times=times,
                            q=states[:, :n], qdot=states[:, n:], dof_names=sim.dof_names,
                            output_names=sim.output_names, output_units=sim.output_units,
                            output_array=outputs, statistics=sim.statistics,
                            inputs=np.array(held), input_names=sim.input_names)


def _outputs_along(sim, states):
    """Outputs (n, n_outputs) along a trajectory of absolute states [q, qdot], solving the
    kinematics point by point."""
    dyn = sim._output_dynamics
    dyn.reset_warm_start()
    ports = sim.model.outputs
    result = np.zeros((len(states), len(ports)))
    n = sim.ndof
    if all(p.quantity == "position" for p in ports):
        index = [p.coordinate for p in ports]
        for k, y in enumerate(states):
            result[k] = dyn.positions(y[:n])[index]
        return result
    for k, y in enumerate(states):
        config = dyn.configuration(y[:n])
        xdot = config.DF @ y[n:]
        for j, p in enumerate(ports):
            result[k, j] = xdot[p.coordinate] if p.quantity == "velocity" else config.x[
                p.coordinate]
    return result


def _classify_inputs(sim, inputs):
    constants, functions, samples = {}, {}, {}
    for name, spec in inputs.items():
        if name not in sim.input_names:
            raise SimulationError(f"unknown input {name!r}; the model {sim.model.name!r} has "
                                  f"inputs: {', '.join(sim.input_names) or '(none)'}")
        i = sim.input_names.index(name)
        if callable(spec):
            functions[i] = spec
        elif isinstance(spec, (tuple, list)) and len(spec) == 2:
            times = np.asarray(spec[0], dtype=float)
            values = np.asarray(spec[1], dtype=float)
            if times.ndim != 1 or times.shape != values.shape or times.size == 0 or np.any(
                    np.diff(times) <= 0):
                raise SimulationError(f"input {name!r}: expected (times, values) of equal "
                                      "length with strictly increasing times")
            bad = np.flatnonzero(~np.isfinite(values) | ~np.isfinite(times))
            if bad.size:
                k = int(bad[0])
                raise SimulationError(f"t = {times[k]:.9g} s: input {name!r} is not finite "
                                      f"({values[k]})")
            samples[i] = (times, values)
        else:
            try:
                value = float(spec)
            except (TypeError, ValueError):
                raise SimulationError(f"input {name!r}: expected a number, a callable or "
                                      f"(times, values), got {spec!r}") from None
            if not np.isfinite(value):
                raise SimulationError(f"t = 0 s: input {name!r} is not finite ({value})")
            constants[i] = value
    return constants, functions, samples


def _vector(value, size, name):
    v = np.array(value, dtype=float).reshape(-1)
    if v.size != size or not np.all(np.isfinite(v)):
        raise SimulationError(f"{name}: expected {size} finite values, got {value!r}")
    return v


# the smallest motion, as a fraction of the model's length scale, that rtol controls
MOTION_FRACTION = 1e-3


def default_atol(model, rtol, *, dynamics=None):
    """Per-state absolute tolerance (2 NDOF,) from rtol and the model's scales.

    The integrator's state is the deviation from the start configuration, and its local
    error test is |err_i| <= rtol |y_i| + atol_i: rtol controls the error of a motion
    larger than atol_i / rtol, atol the error of smaller ones. The default makes rtol the
    controlling tolerance for any motion larger than `MOTION_FRACTION` (1e-3) of the model's
    length scale L (0.1 mm on a 0.1 m leaf spring; flexure strokes are 1e-3 L to 0.1 L):
    lengths rtol 1e-3 L (m), rotations rtol 1e-3 (rad). Velocities: those times a reference
    angular frequency, the lowest natural frequency of the initial configuration (or
    sqrt(g / L) for a structure that only gravity holds, or 1 rad/s), the velocity of that
    smallest motion in the slowest mode. (Until 2026-11 the default was rtol L on the
    absolute DOFs: 1e-7 m at rtol 1e-6, 50 times rtol times a 2 mm stroke.)
    """
    dyn = dynamics or Dynamics(model)
    L = dyn.kin.length_scale
    names = model.dof_names
    position = MOTION_FRACTION * np.array([rtol if name.endswith(".phi") else rtol * L
                                           for name in names])
    return np.concatenate([position, position * _reference_frequency(dyn)])


def _reference_frequency(dyn):
    import scipy.linalg

    mech = dyn.mech
    config = mech.initial_configuration()
    M0, K0 = mech.mass_matrix(config), mech.structural_stiffness(config)
    try:
        eig = scipy.linalg.eigh(K0, M0, eigvals_only=True)
        positive = eig[eig > 1e-9 * max(1.0, np.max(np.abs(eig)))]
        if positive.size:
            return float(np.sqrt(positive.min()))
    except (np.linalg.LinAlgError, ValueError):
        pass
    g = np.linalg.norm(dyn.model.gravity)
    return float(np.sqrt(g / dyn.kin.length_scale)) if g > 0 else 1.0


def _atol_vector(model, rtol, atol, ndof):
    if atol is None:
        return default_atol(model, rtol)
    a = np.array(atol, dtype=float).reshape(-1)
    if a.size == 1:
        a = np.full(2 * ndof, a[0])
    if a.size != 2 * ndof or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise SimulationError(f"atol: expected a positive number or {2 * ndof} positive "
                              f"values, got {atol!r}")
    return a
