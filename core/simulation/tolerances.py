"""The default absolute tolerances of the integrators, from rtol and the model's scales."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SimulationError
from ..mechanics.ports import input_direction
from ..numerics.blas import blas_threads

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

# the smallest motion, as a fraction of the model's length scale, that rtol controls
MOTION_FRACTION = 1e-3


@blas_threads()
def default_atol(model: Model, rtol: float) -> np.ndarray:
    """Per-state absolute tolerance (2 NDOF + coil currents,) from rtol and the model's scales.

    The integrator's state is the deviation from the start configuration, and its local
    error test is |err_i| <= rtol |y_i| + atol_i: rtol controls the error of a motion
    larger than atol_i / rtol, atol the error of smaller ones. The default makes rtol the
    controlling tolerance for any motion larger than `MOTION_FRACTION` (1e-3) of the model's
    length scale L (0.1 mm on a 0.1 m leaf spring; flexure strokes are 1e-3 L to 0.1 L):
    lengths rtol 1e-3 L (m), rotations rtol 1e-3 (rad). Velocities: those times a reference
    angular frequency, the lowest natural frequency of the initial configuration (or
    sqrt(g / L) for a structure that only gravity holds, or 1 rad/s), the velocity of that
    smallest motion in the slowest mode. Coil currents (A, of voltage-driven actuators): rtol
    times the current whose steady force Km i moves the actuated coordinate by that smallest
    motion, through the static compliance c = b^T DF K0^-1 DF^T b of the port (b its unit
    generalised force, `ports.input_direction`) in the initial configuration (where K0 is
    singular, through M0 times the reference frequency squared).

    Parameters
    ----------
    model : Model
    rtol : float
        The integrator's relative tolerance.

    Returns
    -------
    ndarray (2 NDOF + n_coils,)
        atol per state: m or rad on the DOF deviations, m/s or rad/s on the velocities, A on
        the coil currents.
    """
    from ..mechanics.kinematics import length_scale
    from ..mechanics.mechanics import Mechanics

    L = length_scale(model)
    names = model.dof_names
    position = MOTION_FRACTION * np.array([rtol if name.endswith(".phi") else rtol * L
                                           for name in names])
    mech = Mechanics(model)
    config = mech.initial_configuration()
    M0, K0 = mech.mass_matrix(config), mech.structural_stiffness(config)
    omega = _reference_frequency(mech, M0, K0, L)
    currents = [rtol * _current_scale(model, actuator, config, M0, K0, omega, L)
                for actuator in model.coil_actuators]
    return np.concatenate([position, position * omega, currents])


def _current_scale(model, actuator, config, M0, K0, omega, L):
    """The coil current (A) whose steady force moves the actuated port by MOTION_FRACTION of
    its scale (L on a translation, 1 rad on an angle or about a global axis)."""
    port = model.inputs[actuator.input]
    row = input_direction(model, port, config.x) @ config.DF  # the port per DOF
    translation = not port.about_axis and port.coordinate in model.translations
    motion = MOTION_FRACTION * (L if translation else 1.0)
    compliance = 0.0
    for stiffness in (K0, M0 * omega ** 2):
        try:
            compliance = float(row @ np.linalg.solve(stiffness, row))
        except np.linalg.LinAlgError:
            continue
        if np.isfinite(compliance) and compliance > 0.0:
            break
    if not (np.isfinite(compliance) and compliance > 0.0):
        return 1.0  # the port does not move with the DOFs: no motion sets a scale
    return motion / (compliance * actuator.force_constant)


def _reference_frequency(mech, M0, K0, L):
    import scipy.linalg

    try:
        eig = scipy.linalg.eigh(K0, M0, eigvals_only=True)
        positive = eig[eig > 1e-9 * max(1.0, np.max(np.abs(eig)))]
        if positive.size:
            return float(np.sqrt(positive.min()))
    except (np.linalg.LinAlgError, ValueError):
        pass
    g = np.linalg.norm(mech.model.gravity)
    return float(np.sqrt(g / L)) if g > 0 else 1.0


def atol_vector(model, rtol, atol, size):
    """The absolute tolerances (size,: the integrator's states, 2 NDOF plus the coil
    currents): `default_atol` for None, a number for every state, or one per state; a
    SimulationError for anything not positive and finite."""
    if atol is None:
        return default_atol(model, rtol)
    a = np.array(atol, dtype=float).reshape(-1)
    if a.size == 1:
        a = np.full(size, a[0])
    if a.size != size or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise SimulationError(f"atol: expected a positive number or {size} positive "
                              f"values, got {atol!r}")
    return a
