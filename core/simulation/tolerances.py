"""The default absolute tolerances of the integrators, from rtol and the model's scales."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SimulationError
from ..numerics.blas import blas_threads

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

# the smallest motion, as a fraction of the model's length scale, that rtol controls
MOTION_FRACTION = 1e-3


@blas_threads()
def default_atol(model: Model, rtol: float) -> np.ndarray:
    """Per-state absolute tolerance (2 NDOF,) from rtol and the model's scales.

    The integrator's state is the deviation from the start configuration, and its local
    error test is |err_i| <= rtol |y_i| + atol_i: rtol controls the error of a motion
    larger than atol_i / rtol, atol the error of smaller ones. The default makes rtol the
    controlling tolerance for any motion larger than `MOTION_FRACTION` (1e-3) of the model's
    length scale L (0.1 mm on a 0.1 m leaf spring; flexure strokes are 1e-3 L to 0.1 L):
    lengths rtol 1e-3 L (m), rotations rtol 1e-3 (rad). Velocities: those times a reference
    angular frequency, the lowest natural frequency of the initial configuration (or
    sqrt(g / L) for a structure that only gravity holds, or 1 rad/s), the velocity of that
    smallest motion in the slowest mode.
    """
    from ..mechanics.kinematics import length_scale
    from ..mechanics.mechanics import Mechanics

    L = length_scale(model)
    names = model.dof_names
    position = MOTION_FRACTION * np.array([rtol if name.endswith(".phi") else rtol * L
                                           for name in names])
    return np.concatenate([position, position * _reference_frequency(Mechanics(model), L)])


def _reference_frequency(mech, L):
    import scipy.linalg

    config = mech.initial_configuration()
    M0, K0 = mech.mass_matrix(config), mech.structural_stiffness(config)
    try:
        eig = scipy.linalg.eigh(K0, M0, eigvals_only=True)
        positive = eig[eig > 1e-9 * max(1.0, np.max(np.abs(eig)))]
        if positive.size:
            return float(np.sqrt(positive.min()))
    except (np.linalg.LinAlgError, ValueError):
        pass
    g = np.linalg.norm(mech.model.gravity)
    return float(np.sqrt(g / L)) if g > 0 else 1.0


def atol_vector(model, rtol, atol, ndof):
    """The absolute tolerances (2 NDOF,): `default_atol` for None, a number for every state,
    or one per state; a SimulationError for anything not positive and finite."""
    if atol is None:
        return default_atol(model, rtol)
    a = np.array(atol, dtype=float).reshape(-1)
    if a.size == 1:
        a = np.full(2 * ndof, a[0])
    if a.size != 2 * ndof or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise SimulationError(f"atol: expected a positive number or {2 * ndof} positive "
                              f"values, got {atol!r}")
    return a
