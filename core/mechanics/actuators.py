"""Voice-coil actuators (VCM): the force or moment an actuated input puts on its port.

A scene's [actuators.NAME] (`flexure.core.model.Actuator`) drives one input; the input's
value u (V) is then the drive signal of the actuator's amplifier, whose output is clipped at
its saturation s (V or A; none: s = inf),

    a(u) = sat(G u) = min(max(G u, -s), s)

(a clip: its derivative is G inside the limits and zero where it saturates). The actuator's
force F is the value its port carries, as an input's force or moment does without an actuator
(`flexure.core.mechanics.ports`): on one coordinate F acts on it (N; N m on a planar angle);
about a global axis k of a 3-D rotational node it is a moment (a rotary voice coil, N m),
whose generalised force on the Euler parameters is F 2 E_k(lambda)^T. With Km the force
constant (N/A, equal to the back-EMF constant in V s/m; N m/A = V s/rad for a moment), R the
coil's resistance (ohm), L its inductance (H) and v the port's velocity, the power conjugate
of its force (m/s: xdot of the coordinate, dependent or a DOF; rad/s: the angular velocity
omega_k = 2 E_k lambda_dot about the axis):

- current drive (a current amplifier, gain A/V; an ideal one absorbs the back-EMF, so the
  coil adds no state):                 F = Km a(u)
- voltage drive (a voltage amplifier, gain V/V): the coil current i (A) is a state,

      L di/dt = a(u) - R i - Km v,     F = Km i

  so the back-EMF Km v damps the actuated motion (Km^2 / R, N s/m or N m s/rad, for slow
  motion), and the steady state at rest is i = a(u) / R, F = Km a(u) / R.

The electrical power balance of a voltage-driven coil, u_c = a(u) its voltage:

    u_c i = R i^2 + d(L i^2 / 2)/dt + F v        (W)

An input without an actuator is a force or moment (N, N m) on its port, as without
[actuators]. SI units throughout. This is the plain-numpy twin of the compiled engine's
actuator part (`flexure.core.engine.actuators`), used by the static and linear analyses.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..model import CURRENT, VOLTAGE

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..model import Model


def amplifier_output(actuator, u):
    """a(u) = sat(G u): the amplifier's output (V or A) for the drive signal u (V)."""
    s = actuator.saturation
    return float(min(max(actuator.amplifier_gain * float(u), -s), s))


def amplifier_slope(actuator, u):
    """d a / d u at the drive signal u: G inside the limits, 0 where it saturates (V/V or
    A/V)."""
    inside = abs(actuator.amplifier_gain * float(u)) < actuator.saturation
    return actuator.amplifier_gain if inside else 0.0


def port_values(model, u, currents=None):
    """The value (n_inputs,) each input puts on its port (N, N m: `ports.input_forces` makes
    them the generalised force) for the held inputs u (n_inputs,: N, N m for a force or
    moment, V for a drive signal) and the coil currents (A, one per voltage-driven actuator,
    `Model.coil_actuators`; default zero): u itself, Km a(u) or Km i. Without actuators, u
    itself (the same array values)."""
    u = np.asarray(u, dtype=float).reshape(-1)
    values = u.copy()
    currents = (np.zeros(len(model.coil_actuators)) if currents is None
                else np.asarray(currents, dtype=float).reshape(-1))
    k = 0
    for actuator in model.actuators:
        if actuator.drive == VOLTAGE:
            values[actuator.input] = actuator.force_constant * currents[k]
            k += 1
        else:
            values[actuator.input] = actuator.force_constant * amplifier_output(
                actuator, u[actuator.input])
    return values


def steady_port_values(model: Model, u: ArrayLike) -> np.ndarray:
    """The value each port carries at rest under held inputs u: u itself for a force or
    moment, Km a(u) for a current drive, Km a(u) / R for a voltage drive (i = a(u) / R).

    Parameters
    ----------
    model : Model
    u : array_like (n_inputs,)
        The held inputs: N, N m for a force or moment, V for an actuator's drive signal.

    Returns
    -------
    ndarray (n_inputs,)
        The forces and moments on the ports, N or N m (`ports.input_forces` makes them the
        generalised force).
    """
    return port_values(model, u, steady_currents(model, u))


def steady_slopes(model: Model, u: ArrayLike) -> np.ndarray:
    """d (steady port value) / d u at held inputs u: 1 for a force or moment input,
    Km a'(u) for a current drive, Km a'(u) / R for a voltage drive; a' the amplifier's slope
    (`amplifier_slope`). Times an input's unit generalised force (`ports.input_columns`),
    the static generalised force per unit of the input (per V for a drive signal).

    Parameters
    ----------
    model : Model
    u : array_like (n_inputs,)
        The held inputs, as in `steady_port_values`.

    Returns
    -------
    ndarray (n_inputs,)
        1 (unitless) for a force or moment input; N/V or N m/V for a drive signal.
    """
    u = np.asarray(u, dtype=float).reshape(-1)
    slopes = np.ones(len(model.inputs))
    for actuator in model.actuators:
        slope = actuator.force_constant * amplifier_slope(actuator, u[actuator.input])
        slopes[actuator.input] = slope / actuator.resistance if (
            actuator.drive == VOLTAGE) else slope
    return slopes


def steady_currents(model, u):
    """The coil currents at rest (A, one per voltage-driven actuator): a(u) / R."""
    u = np.asarray(u, dtype=float).reshape(-1)
    return np.array([amplifier_output(a, u[a.input]) / a.resistance
                     for a in model.coil_actuators])


def current_rates(model, u, currents, velocities):
    """di/dt (A/s) of the coil currents, L di/dt = a(u) - R i - Km v, with v the velocities
    of the actuated ports (one per voltage-driven actuator: m/s, or rad/s about an axis)."""
    u = np.asarray(u, dtype=float).reshape(-1)
    return np.array([(amplifier_output(a, u[a.input]) - a.resistance * i
                      - a.force_constant * v) / a.inductance
                     for a, i, v in zip(model.coil_actuators, currents, velocities,
                                        strict=True)])


__all__ = ["CURRENT", "VOLTAGE", "amplifier_output", "amplifier_slope", "current_rates",
           "port_values", "steady_currents", "steady_port_values", "steady_slopes"]
