"""Voice-coil actuators (VCM): the force an actuated input puts on its coordinate.

A scene's [actuators.NAME] (`flexure.core.model.Actuator`) drives one input; the input's
value u (V) is then the drive signal of the actuator's amplifier, whose output is clipped at
its saturation s (V or A; none: s = inf),

    a(u) = sat(G u) = min(max(G u, -s), s)

(a clip: its derivative is G inside the limits and zero where it saturates). With Km the
force constant (N/A, equal to the back-EMF constant in V s/m), R the coil's resistance (ohm),
L its inductance (H) and v the velocity of the actuated coordinate (m/s; xdot of that
coordinate, dependent or a DOF):

- current drive (a current amplifier, gain A/V; an ideal one absorbs the back-EMF, so the
  coil adds no state):                 F = Km a(u)
- voltage drive (a voltage amplifier, gain V/V): the coil current i (A) is a state,

      L di/dt = a(u) - R i - Km v,     F = Km i

  so the back-EMF Km v damps the actuated motion (Km^2 / R, N s/m, for slow motion), and the
  steady state at rest is i = a(u) / R, F = Km a(u) / R.

The electrical power balance of a voltage-driven coil, u_c = a(u) its voltage:

    u_c i = R i^2 + d(L i^2 / 2)/dt + F v        (W)

An input without an actuator is a force (N, N m) on its coordinate, as without [actuators].
SI units throughout. This is the plain-numpy twin of the compiled engine's actuator part
(`flexure.core.engine.actuators`), used by the static and linear analyses.
"""

import numpy as np

from ..model import CURRENT, VOLTAGE


def amplifier_output(actuator, u):
    """a(u) = sat(G u): the amplifier's output (V or A) for the drive signal u (V)."""
    s = actuator.saturation
    return float(min(max(actuator.amplifier_gain * float(u), -s), s))


def amplifier_slope(actuator, u):
    """d a / d u at the drive signal u: G inside the limits, 0 where it saturates (V/V or
    A/V)."""
    inside = abs(actuator.amplifier_gain * float(u)) < actuator.saturation
    return actuator.amplifier_gain if inside else 0.0


def input_forces(model, u, currents=None):
    """The force (N, N m) of each input (n_inputs,) for the held inputs u (n_inputs,: N for a
    force, V for a drive signal) and the coil currents (A, one per voltage-driven actuator,
    `Model.coil_actuators`; default zero)."""
    u = np.asarray(u, dtype=float).reshape(-1)
    force = u.copy()
    currents = (np.zeros(len(model.coil_actuators)) if currents is None
                else np.asarray(currents, dtype=float).reshape(-1))
    k = 0
    for actuator in model.actuators:
        if actuator.drive == VOLTAGE:
            force[actuator.input] = actuator.force_constant * currents[k]
            k += 1
        else:
            force[actuator.input] = actuator.force_constant * amplifier_output(
                actuator, u[actuator.input])
    return force


def steady_forces(model, u):
    """The force (N, N m) of each input at rest under held inputs u (n_inputs,): u itself for
    a force, Km a(u) for a current drive, Km a(u) / R for a voltage drive (i = a(u) / R)."""
    return input_forces(model, u, steady_currents(model, u))


def steady_currents(model, u):
    """The coil currents at rest (A, one per voltage-driven actuator): a(u) / R."""
    u = np.asarray(u, dtype=float).reshape(-1)
    return np.array([amplifier_output(a, u[a.input]) / a.resistance
                     for a in model.coil_actuators])


def current_rates(model, u, currents, velocities):
    """di/dt (A/s) of the coil currents, L di/dt = a(u) - R i - Km v, with v the velocities
    (m/s) of the actuated coordinates (one per voltage-driven actuator)."""
    u = np.asarray(u, dtype=float).reshape(-1)
    return np.array([(amplifier_output(a, u[a.input]) - a.resistance * i
                      - a.force_constant * v) / a.inductance
                     for a, i, v in zip(model.coil_actuators, currents, velocities,
                                        strict=True)])


def input_vector(model, inputs):
    """The held inputs (n_inputs,) from {input name: value} or a sequence (n_inputs,); a
    ValueError naming the input for an unknown name or a wrong count."""
    names = [port.name for port in model.inputs]
    u = np.zeros(len(names))
    if isinstance(inputs, dict):
        for name, value in inputs.items():
            if name not in names:
                raise ValueError(f"unknown input {name!r}; the model {model.name!r} has "
                                 f"inputs: {', '.join(names) or '(none)'}")
            u[names.index(name)] = float(value)
        return u
    values = np.asarray(inputs, dtype=float).reshape(-1)
    if values.size != u.size:
        raise ValueError(f"expected {u.size} inputs ({', '.join(names)}), got {values.size}")
    return values


__all__ = ["CURRENT", "VOLTAGE", "amplifier_output", "amplifier_slope", "current_rates",
           "input_forces", "input_vector", "steady_currents", "steady_forces"]
