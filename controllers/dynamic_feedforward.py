"""Feedforward from the nonlinear inverse dynamics, for a move of other coordinates.

A move of the manipulator's end effector asks for as many target coordinates as there are
loops (`move_path`'s targets: E.x, E.y, ... with the held ones at 0). `move_path` turns them
into the loops' strokes by statics (the inverse statics, or its linearisation) and the
feedforward adds the low-frequency model's m y'' + c y'. Here the nonlinear model with its
inertia and its flexible DOFs gives both:

- the targets follow t_i(t) = t_i(0) + s(t) delta_i, s the third-order profile of stroke 1
  over `duration` (the progress of a MovePath's move), held for `settle` after it;
- `flexure.core.free_inverse_dynamics` integrates the model along them (Radau IIA, the other
  DOFs free, from rest) and gives the input forces w(t) (N, N m) and the motion. Its steps
  are the largest at most `step` that divide duration / 8: the profile's knots (its jerk's
  jumps, at multiples of duration / 8) are steps' ends, so that the method keeps its order;
- the loops' references are their outputs (the encoders) along that motion at the samples
  k / fs, k = 0 .. N+1, from the cubic through each step's four nodes (its start, its two
  inner stages and its end), and their feedforward the forces' means over each sample
  interval [k / fs, (k+1) / fs), the exact integrals of the same piecewise cubic through the
  forces (`FreeInverseDynamics.force_polynomial`): what a zero-order hold must send for the
  mean force to be right (feedforward.py).

The forces carry O(step^4) between the steps and O(step^5) at them (the module docstring of
core/analysis/inverse_dynamics_free.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .feedback import ControlDesignError
from .move_path import move_targets, target_port
from .profiles import ThirdOrderProfile

if TYPE_CHECKING:  # names for the annotations only
    from flexure.core import Model
    from flexure.core.analysis.inverse_dynamics_free import FreeInverseDynamics


@dataclass(frozen=True)
class DynamicFeedforward:
    """The loops' references (m, rad) at the samples k = 0 .. N (`reference`, (N+1, n_loops))
    and feedforward forces (N, N m) held from k = 0 .. N+1 (`forces`, (N+2, n_loops)), for
    `run_loop(reference=..., feedforward_forces=...)`; `inverse` the inverse dynamics along
    the move (its times, forces and motion); `targets` the move {coordinate: displacement};
    fs in Hz."""

    reference: np.ndarray
    forces: np.ndarray
    inverse: FreeInverseDynamics
    targets: dict
    fs: float


def dynamic_feedforward(model: Model, targets: dict, *, duration: float = 1.0,
                        settle: float = 0.25, fs: float = 4000.0, step: float = 2e-3,
                        tolerance: float = 1e-12) -> DynamicFeedforward:
    """The references and forces that move `targets` along the nonlinear model (module
    docstring).

    Parameters
    ----------
    model : Model
        Force inputs with colocated outputs (`colocated_pairs`), no kinematic inputs.
    targets : dict
        {"NODE.AXIS": displacement (m, or rad for a rotational node's "rx", "ry", "rz")}, one
        per loop: the coordinates to move (a held one at 0).
    duration, settle : float
        s: the move's third-order profile, and the time after it.
    fs : float
        Hz: the loops' sample rate.
    step : float
        s: the inverse dynamics' largest step (the forces' error is O(step^4)); the steps
        taken divide duration / 8.
    tolerance : float
        The inverse dynamics' Newton tolerance, relative to each DOF's unit (what each
        step's Newton leaves adds up over the steps: at 1e-10 it was the forces' largest
        error on the manipulator, docs/manipulator.md).

    Returns
    -------
    DynamicFeedforward

    Raises
    ------
    ControlDesignError
        Not one target per loop, or a non-positive duration, settle below zero, fs or step.
    flexure.core.SceneError, ConstraintError, ConvergenceError
        From the inverse dynamics (a target that is no coordinate, targets the inputs do not
        reach, a position beyond the mechanism's reach).
    """
    from flexure.core import output_value
    from flexure.core.analysis.inverse_dynamics_free import node_polynomial

    if not (np.isfinite(fs) and fs > 0):
        raise ControlDesignError(f"dynamic feedforward: fs must be a finite number > 0, got "
                                 f"{fs!r}")
    if not (np.isfinite(settle) and settle >= 0):
        raise ControlDesignError(f"dynamic feedforward: settle must be a finite number >= 0 "
                                 f"(s), got {settle!r}")
    samples = int(round((duration + settle) * fs)) if np.isfinite(duration) else 0
    inverse = move_inverse_dynamics(model, targets, duration=duration,
                                    end=(samples + 2) / fs,  # the last sample interval's end
                                    step=step, tolerance=tolerance)
    times = inverse.times
    pairs = move_targets(model, targets)[0]
    loop_ports = [model.outputs[pair.output_index] for pair in pairs]
    positions = np.array([[output_value(model, port, x) for port in loop_ports]
                          for x in inverse.node_x])
    k = np.arange(samples + 2)
    reference = node_polynomial(times, positions)(k[:-1] / fs)
    integral = inverse.force_polynomial().antiderivative()
    forces = (integral((k + 1) / fs) - integral(k / fs)) * fs
    return DynamicFeedforward(reference, forces, inverse, dict(targets), float(fs))


def move_inverse_dynamics(model: Model, targets: dict, *, duration: float = 1.0,
                          end: float | None = None, step: float = 2e-3,
                          tolerance: float = 1e-12) -> FreeInverseDynamics:
    """The nonlinear inverse dynamics along a move of `targets` from rest (module docstring),
    from t = 0 to `end`: the forces and the motion of `dynamic_feedforward`.

    Parameters
    ----------
    model : Model
        Force inputs with colocated outputs (`colocated_pairs`), no kinematic inputs.
    targets : dict
        {"NODE.AXIS": displacement (m, or rad)}, one per loop, as `dynamic_feedforward`'s.
    duration : float
        s: the move's third-order profile.
    end : float, optional
        s: the last time (default `duration`); a later one holds the end of the move. The
        steps run to the first step's end at or after it.
    step : float
        s: the largest step; the steps taken divide duration / 8.
    tolerance : float
        The Newton tolerance, relative to each DOF's unit.

    Returns
    -------
    FreeInverseDynamics
        The forces (N, N m) in the loops' order and the motion, at the steps' ends.

    Raises
    ------
    ControlDesignError
        Not one target per loop, or a duration, end or step that is not a finite number > 0.
    flexure.core.SceneError, ConstraintError, ConvergenceError
        From the inverse dynamics.
    """
    from flexure.core import free_inverse_dynamics, output_value, static_equilibrium

    end = duration if end is None else end
    for name, value in (("duration", duration), ("end", end), ("step", step)):
        if not (np.isfinite(value) and value > 0):
            raise ControlDesignError(f"dynamic feedforward: {name} must be a finite number "
                                     f"> 0, got {value!r}")
    pairs, names, delta = move_targets(model, targets)
    rest = static_equilibrium(model)
    own = {port.name: port for port in model.outputs}
    start = np.array([output_value(model, own.get(name) or target_port(model, name), rest.x)
                      for name in names])
    profile = ThirdOrderProfile(1.0, duration)

    def path(t):
        s, rate, acceleration, _ = profile.evaluate(t)
        return start + delta * s, delta * rate, delta * acceleration

    # the profile's knots lie at multiples of duration / 8 (its default segments)
    h = duration / 8 / np.ceil(duration / 8 / step * (1 - 1e-12))
    times = h * np.arange(np.ceil(end / h * (1 - 1e-12)) + 1)
    return free_inverse_dynamics(model, times, path, outputs=names,
                                 inputs=[pair.input_name for pair in pairs],
                                 tolerance=tolerance)


__all__ = ["DynamicFeedforward", "dynamic_feedforward", "move_inverse_dynamics"]
