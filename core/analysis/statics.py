"""Static equilibrium: load steps and Newton's method on the DOFs.

The load (nodal forces and gravity) is applied in `load_steps` equal increments (one, when
there is no load); in each the generalised force Q(q) = DF^T (f - De^T sigma) is driven to
zero by Newton's method with the full tangent stiffness K0 + G0 (quadratic convergence). A
step that does not converge is halved up to four times; then ConvergenceError names the load
step and the load factor.
Convergence: |dq| <= `tolerance` times the model's length scale (rotations count as lengths
through that scale).

Held inputs (`inputs`) add their steady forces to the load: a force input its value (N, N m);
an input a voice-coil actuator drives its actuator's force at rest
(`flexure.core.mechanics.actuators.steady_forces`): Km sat(G u) for a current drive,
Km sat(G u) / R for a voltage drive, whose coil current settles at sat(G u) / R.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError, SceneError
from ..mechanics.actuators import input_vector, steady_forces
from ..mechanics.mechanics import Mechanics
from ..numerics.blas import blas_threads

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model


@dataclass
class StaticSolution:
    """A static equilibrium: DOFs q, coordinates x, deformations e and stress resultants."""

    model: object
    config: object  # the kinematics Configuration
    stress_resultants: np.ndarray  # (NE,) N (truss, elongation), N (bending, as e2, e3 are m)
    load_factor: float
    iterations: int
    inputs: np.ndarray | None = None  # the held inputs (n_inputs,) N or V; None: zero

    @property
    def q(self):
        return self.config.q

    @property
    def x(self):
        return self.config.x

    def coordinates(self):
        """{"NODE.COORD": value} in m and rad."""
        return dict(zip(self.model.coordinate_names, self.config.x.tolist(), strict=True))

    def stresses(self):
        """{"ELEMENT.eK": stress resultant} in N."""
        return dict(zip(self.model.deformation_names, self.stress_resultants.tolist(),
                        strict=True))


@blas_threads()
def static_equilibrium(model: Model, *, loads: np.ndarray | None = None, load_steps: int = 10,
                       tolerance: float = 1e-11, max_iterations: int = 30,
                       mechanics: Mechanics | None = None,
                       inputs=None) -> StaticSolution:
    """Solve the static equilibrium of `model` under its loads (or `loads`, (NX,) N).

    inputs: held inputs, {input name: value} or (n_inputs,), N for a force, V for an
    actuator's drive signal; their steady forces are added to the loads (module docstring).
    Returns a StaticSolution; raises ConvergenceError naming the load step that failed, and
    SceneError for an unknown input.
    """
    mech = mechanics or Mechanics(model)
    held = None
    if inputs is not None:
        held, loads = _with_inputs(model, loads, inputs)
    kin = mech.kinematics
    config = mech.initial_configuration()
    scale = kin.length_scale
    total_iterations = 0
    # Without loads and gravity there is nothing to step: the reference configuration (all
    # deformations zero) balances, and one Newton step at full load confirms it.
    unloaded = not np.any(mech.external_force(config.x, 1.0, loads))
    factor, step = 0.0, 1.0 if unloaded else 1.0 / load_steps
    halvings = 0
    step_number = 0
    while factor < 1.0 - 1e-12:
        target = min(1.0, factor + step)
        try:
            config, iterations = _newton(mech, config, target, loads, tolerance * scale,
                                         max_iterations)
        except ConvergenceError as error:
            if halvings == 4:
                raise ConvergenceError(
                    f"{model.source}: static equilibrium of {model.name!r} did not converge in "
                    f"load step {step_number + 1} (load factor {factor:.4g} -> {target:.4g}, "
                    f"after {halvings} step halvings): {error}"
                ) from None
            step *= 0.5
            halvings += 1
            continue
        total_iterations += iterations
        factor = target
        step_number += 1
    _, _, sigma = mech.static_balance(config, 1.0, loads)
    return StaticSolution(model, config, sigma, 1.0, total_iterations, held)


def _with_inputs(model, loads, inputs):
    """(held inputs (n_inputs,), loads (NX,) N with their steady forces added)."""
    try:
        u = input_vector(model, inputs)
    except ValueError as error:
        raise SceneError(f"{model.source}: static equilibrium: {error}") from None
    if not np.all(np.isfinite(u)):
        raise SceneError(f"{model.source}: static equilibrium: the inputs must be finite, "
                         f"got {u.tolist()}")
    total = np.array(model.loads if loads is None else loads, dtype=float)
    for port, force in zip(model.inputs, steady_forces(model, u), strict=True):
        total[port.coordinate] += force
    return u, total


def _newton(mech, config, load_factor, loads, step_tolerance, max_iterations):
    kin = mech.kinematics
    for iteration in range(1, max_iterations + 1):
        Q, _, sigma = mech.static_balance(config, load_factor, loads)
        K = mech.structural_stiffness(config) + mech.geometric_stiffness(
            config, sigma, load_factor)
        try:
            dq = np.linalg.solve(K, Q)
        except np.linalg.LinAlgError:
            raise ConvergenceError("the tangent stiffness is singular") from None
        if not np.all(np.isfinite(dq)):
            raise ConvergenceError("the tangent stiffness is singular")
        config = kin.solve(config.q + dq, config.x)
        if np.max(np.abs(dq), initial=0.0) <= step_tolerance:
            return config, iteration
    raise ConvergenceError(f"Newton did not converge in {max_iterations} iterations "
                           f"(last |dq| = {np.max(np.abs(dq)):.3e})")
