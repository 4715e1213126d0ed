"""Nonlinear time-domain simulation in one call: `simulate` and its result. The stepping
`Simulator` (`flexure.core.simulation.simulator`) does the integration; the default tolerances
are in `flexure.core.simulation.tolerances`.

    result = simulate(model, 1.0, inputs={"F": 1.0}, rtol=1e-6)
    result.outputs["x"]              # m, at every accepted step (or at output_times)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from os import PathLike
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SimulationError
from .simulator import STATE_VERSION, Simulator
from .tolerances import default_atol

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..model import Model

__all__ = ["STATE_VERSION", "SimulationResult", "Simulator", "default_atol", "effort_unit",
           "simulate", "split_inputs"]


@dataclass
class SimulationResult:
    """A simulated trajectory, SI units.

    times (n,) s; q, qdot (n, NDOF); outputs {name: (n,)}; output_array (n, n_outputs);
    currents (n, n_coils) A, the coil currents of the voltage-driven actuators
    (`Model.coil_actuators`; no columns without them).
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
    inputs: np.ndarray = field(default=None)  # (n, n_inputs) N, or V for a drive signal
    input_names: list = field(default_factory=list)
    warnings: list = field(default_factory=list)  # states beyond the range of validity
    currents: np.ndarray = field(default=None)  # (n, n_coils) A

    @property
    def outputs(self) -> dict[str, np.ndarray]:
        """{output name: (n,) array}, in the output's unit (`output_units`)."""
        return {name: self.output_array[:, i] for i, name in enumerate(self.output_names)}

    def to_csv(self, path: str | PathLike) -> None:
        """Write the time and one column per output to a CSV file.

        Parameters
        ----------
        path : str or path-like
            The file; its header names each column with its unit ("time [s]", "x [m]").
        """
        header = ",".join(["time [s]"] + [f"{n} [{u}]" for n, u in
                                          zip(self.output_names, self.output_units,
                                              strict=True)])
        data = np.column_stack([self.times, self.output_array])
        np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.12g")

    def plot(self, path: str | PathLike) -> None:
        """Plot every output against time (s) to a PNG file (an output that stays put to
        round-off is drawn flat: `flexure.core.reporting.axes`).

        Parameters
        ----------
        path : str or path-like
            The image file.
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from ..reporting.axes import hold_round_off, unit_scales

        n = max(1, len(self.output_names))
        fig, axes = plt.subplots(n, 1, sharex=True, figsize=(7, 2.2 * n + 0.8), squeeze=False)
        scales = unit_scales(self.output_array, self.output_units)
        for i, (name, unit) in enumerate(zip(self.output_names, self.output_units, strict=True)):
            axes[i, 0].plot(self.times, self.output_array[:, i])
            hold_round_off(axes[i, 0], self.output_array[:, i], scales[unit])
            axes[i, 0].set_ylabel(f"{name} [{unit}]")
            axes[i, 0].grid(True, alpha=0.3)
        axes[-1, 0].set_xlabel("time [s]")
        fig.suptitle(f"{self.model_name}: {self.method}, rtol {self.rtol:g}")
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)


def simulate(model: Model, t_end: float, *, inputs: Mapping[str, object] | None = None,
             method: str = "cvode-bdf", rtol: float = 1e-8,
             atol: float | ArrayLike | None = None, max_step: float | None = None,
             output_times: ArrayLike | None = None, jacobian: str = "analytic",
             max_order: int | None = None, q0: ArrayLike | None = None,
             qdot0: ArrayLike | None = None, deadline: float | None = None,
             progress: Callable[[float], None] | None = None,
             i0: ArrayLike | None = None,
             motion_duration: float | None = None) -> SimulationResult:
    """Simulate `model` from rest (or q0, qdot0 and the coil currents i0) at t = 0 to t_end.

    Parameters
    ----------
    model : Model
    t_end : float
        The end time, s, > 0.
    inputs : dict, optional
        {input name: constant N (N m; V for an actuator's drive signal) | callable(t) -> N |
        (times, values) held constant from each sample time to the next (zero-order hold;
        values[0] before the first sample)}. Unnamed inputs are zero.
    method, rtol, atol, max_step, jacobian, max_order
        As `Simulator` (rtol relative; atol in the states' units; max_step s).
    output_times : array_like, optional
        Times (s) at which to record, strictly increasing within [0, t_end]; default every
        accepted integrator step.
    q0 : array_like (NDOF,), optional
        The initial DOFs, m or rad (default: the scene's configuration).
    qdot0 : array_like (NDOF,), optional
        The initial DOF velocities, m/s or rad/s (default zero).
    deadline : float, optional
        A `time.perf_counter()` value (s) after which the run stops with a SimulationError.
    progress : callable, optional
        Called with the fraction of t_end reached (0 to 1) after every accepted step, e.g. a
        `flexure.core.reporting.progress.Progress`.
    i0 : array_like (n_coils,), optional
        The initial coil currents of the voltage-driven actuators, A (default zero).
    motion_duration : float, optional
        s: a model with kinematic inputs moves each from its `start` to its `value` by the
        rest-to-rest quintic over this time from t = 0 (default t_end); q and qdot of the
        inputs are the path's, and each input's effort (N, N m) is an output "NAME.effort"
        after the scene's outputs. Refused for a model without kinematic inputs.

    Returns
    -------
    SimulationResult
        Times (s), DOFs, velocities, coil currents (A), the outputs in their units and the
        held inputs at each recorded time.

    Raises
    ------
    SimulationError
        A bad t_end, output_times or input specification (naming the input), a bad option
        (`Simulator`), or a failure of the integration (naming the time).
    """
    if not (np.isfinite(t_end) and t_end > 0):
        raise SimulationError(f"t_end must be a positive time (s), got {t_end!r}")
    constants, functions, samples = split_inputs(model, inputs or {})
    if model.kinematic_inputs and motion_duration is None:
        motion_duration = t_end  # the move takes the run
    with Simulator(model, method=method, rtol=rtol, atol=atol, max_step=max_step,
                   jacobian=jacobian, max_order=max_order, input_functions=functions,
                   motion_duration=motion_duration) as sim:
        # closed when the run ends or fails: the solver's memory freed now, not by the
        # collector at some later time
        sim.reset(q0=q0, qdot0=qdot0, i0=i0)
        sim.deadline = deadline
        u0 = np.zeros(len(sim.input_names))
        for i, value in constants.items():
            u0[i] = value
        for i, (_, values) in samples.items():
            u0[i] = values[0]
        sim.set_inputs(u0)
        breaks = sorted({float(t) for times, _ in samples.values() for t in times
                         if 0.0 < t < t_end})
        if output_times is None:
            grid = None
        else:
            grid = np.asarray(output_times, dtype=float)
            if grid.ndim != 1 or np.any(np.diff(grid) <= 0) or grid[0] < 0 or grid[-1] > t_end:
                raise SimulationError("output_times must increase strictly within [0, t_end]")
        times, states, held = [0.0], [sim.absolute(sim.state)], [_held(sim, functions, 0.0)]

        def record(t, y):
            times.append(t)
            states.append(sim.absolute(y))
            held.append(_held(sim, functions, t))

        def report(t):
            progress(t / t_end)

        stops = sorted(set(breaks) | {float(t_end)} | (set(grid.tolist()) if grid is not None
                                                        else set()))
        for stop in stops:
            if stop <= sim.time:
                continue
            sim.advance_to(stop, _record=record if grid is None else None,
                        _progress=report if progress is not None else None)
            if grid is not None and np.any(grid == stop):
                record(stop, sim.state)
            if stop in breaks:
                u = sim.inputs
                for i, (t_samples, values) in samples.items():
                    u[i] = values[np.searchsorted(t_samples, stop, side="right") - 1]
                sim.set_inputs(u)
        times = np.array(times)
        states = np.array(states)
        if grid is not None:  # keep exactly the requested times
            keep = np.isin(times, grid)
            keep[0] = grid[0] == 0.0  # the start only where the grid asks for it
            times, states, held = times[keep], states[keep], np.array(held)[keep]
        states = sim.on_path(times, states)  # the kinematic inputs' entries exactly the path's
        held = np.array(held, dtype=float).reshape(len(times), len(sim.input_names))
        outputs, warnings = sim.outputs_and_warnings(states, times=times, inputs=held)
        names, units = sim.output_names, sim.output_units
        if model.kinematic_inputs:  # their efforts as outputs after the scene's
            outputs = np.column_stack([outputs, sim.efforts_along(times, states, inputs=held)])
            names = names + [f"{port.name}.effort" for port in model.kinematic_inputs]
            units = units + [effort_unit(port) for port in model.kinematic_inputs]
        n = sim.ndof
        return SimulationResult(model_name=model.name, method=method, rtol=rtol, times=times,
                                q=states[:, :n], qdot=states[:, n: 2 * n],
                                currents=states[:, 2 * n:], dof_names=sim.dof_names,
                                output_names=names, output_units=units,
                                output_array=outputs, statistics=sim.statistics,
                                inputs=held, input_names=sim.input_names,
                                warnings=warnings)


def effort_unit(port):
    """The unit of the effort that realises a kinematic input: N on a length, N m on an
    angle."""
    return "N m" if port.unit == "rad" else "N"


def _held(sim, functions, t):
    """The inputs (N) acting at time t: the held ones with the input functions' values."""
    u = sim.inputs
    for i, function in functions.items():
        u[i] = function(t)
    return u


def split_inputs(model, inputs):
    """({index: N}, {index: callable(t)}, {index: (times, values)}): the input
    specifications of `simulate` by kind, checked (a SimulationError names the input)."""
    names = [port.name for port in model.inputs]
    constants, functions, samples = {}, {}, {}
    for name, spec in inputs.items():
        if name not in names:
            raise SimulationError(f"unknown input {name!r}; the model {model.name!r} has "
                                  f"inputs: {', '.join(names) or '(none)'}")
        i = names.index(name)
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
