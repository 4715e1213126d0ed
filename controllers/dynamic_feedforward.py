"""Feedforward from the nonlinear inverse dynamics, for a move of other coordinates.

A move of the manipulator's end effector asks for as many target coordinates as there are
loops (`move_path`'s targets: E.x, E.y, ... with the held ones at 0). `move_path` turns them
into the loops' strokes by statics (the inverse statics, or its linearisation) and the
feedforward adds the low-frequency model's m y'' + c y'. Here the nonlinear model with its
inertia and its flexible DOFs gives both:

- the targets follow t_i(t) = t_i(0) + s(t) delta_i, s the third-order profile of stroke 1
  over `duration` (the progress of a MovePath's move), held for `settle` after it;
- `flexure.core.free_inverse_dynamics` integrates the model along them (BDF2 at `step`, the
  other DOFs free, from rest) and gives the input forces w(t) (N, N m) and the motion;
- the loops' references are their outputs (the encoders) along that motion at the samples
  k / fs, k = 0 .. N+1, through a cubic spline over the steps, and their feedforward the
  forces' means over each sample interval [k / fs, (k+1) / fs), by 4-point Gauss-Legendre on
  the cubic spline through the steps' forces: what a zero-order hold must send for the mean
  force to be right (feedforward.py).

The spline adds O(step^4) to BDF2's O(step^2): the forces' error is the integration's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .feedback import ControlDesignError
from .move_path import move_targets, target_port
from .profiles import ThirdOrderProfile

if TYPE_CHECKING:  # names for the annotations only
    from flexure.core import InverseDynamics, Model

_GAUSS_POINTS, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(4)


@dataclass(frozen=True)
class DynamicFeedforward:
    """The loops' references (m, rad) at the samples k = 0 .. N (`reference`, (N+1, n_loops))
    and feedforward forces (N, N m) held from k = 0 .. N+1 (`forces`, (N+2, n_loops)), for
    `run_loop(reference=..., feedforward_forces=...)`; `inverse` the inverse dynamics along
    the move (its times, forces and motion); `targets` the move {coordinate: displacement};
    fs in Hz."""

    reference: np.ndarray
    forces: np.ndarray
    inverse: InverseDynamics
    targets: dict
    fs: float


def dynamic_feedforward(model: Model, targets: dict, *, duration: float = 1.0,
                        settle: float = 0.25, fs: float = 4000.0, step: float = 2e-3,
                        tolerance: float = 1e-10) -> DynamicFeedforward:
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
        s: the inverse dynamics' BDF2 step (its error is O(step^2)).
    tolerance : float
        The inverse dynamics' Newton tolerance, relative to each DOF's unit.

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
    from scipy.interpolate import CubicSpline

    from flexure.core import (
        free_inverse_dynamics,
        output_value,
        static_equilibrium,
    )

    for name, value in (("duration", duration), ("fs", fs), ("step", step)):
        if not (np.isfinite(value) and value > 0):
            raise ControlDesignError(f"dynamic feedforward: {name} must be a finite number "
                                     f"> 0, got {value!r}")
    if not (np.isfinite(settle) and settle >= 0):
        raise ControlDesignError(f"dynamic feedforward: settle must be a finite number >= 0 "
                                 f"(s), got {settle!r}")
    pairs, names, delta = move_targets(model, targets)
    rest = static_equilibrium(model)
    own = {port.name: port for port in model.outputs}
    start = np.array([output_value(model, own.get(name) or target_port(model, name), rest.x)
                      for name in names])
    profile = ThirdOrderProfile(1.0, duration)

    def path(t):
        s, rate, acceleration, _ = profile.evaluate(t)
        return start + delta * s, delta * rate, delta * acceleration

    samples = int(round((duration + settle) * fs))
    end = (samples + 2) / fs  # the last sample interval's end
    times = np.arange(0.0, end + step, step)
    inverse = free_inverse_dynamics(model, times, path, outputs=names,
                                    inputs=[pair.input_name for pair in pairs],
                                    tolerance=tolerance)
    loop_ports = [model.outputs[pair.output_index] for pair in pairs]
    positions = np.array([[output_value(model, port, x) for port in loop_ports]
                          for x in inverse.x])
    k = np.arange(samples + 2)
    reference = CubicSpline(times, positions, axis=0)(k[:-1] / fs)
    force_spline = CubicSpline(times, inverse.forces, axis=0)
    forces = np.zeros((k.size, len(pairs)))
    for point, weight in zip(_GAUSS_POINTS, _GAUSS_WEIGHTS, strict=True):
        forces += weight / 2.0 * force_spline((k + (point + 1.0) / 2.0) / fs)
    return DynamicFeedforward(reference, forces, inverse, dict(targets), float(fs))


__all__ = ["DynamicFeedforward", "dynamic_feedforward"]
