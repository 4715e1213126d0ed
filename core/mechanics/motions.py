"""Kinematic inputs (SPACAR's INPUTX / INPUTE): prescribed coordinates and deformations.

A kinematic input is a coordinate (m, or rad on a planar angle) or a deformation (m) whose
value is prescribed ([inputs.NAME] kind = "motion", `flexure.core.scene.scene_ports`). It has
the status DOF, so the kinematics solve it like a DOF (x = F(q) with q = [q_f, q_k], the DOFs
proper q_f and the prescribed values q_k at `Model.prescribed_dofs`), and the exact-constraint
check counts it as one: NDOF = NX - NXO - NEO - NKI DOFs remain for the motion.

What it costs. With the generalised force on q of everything but the input,

    Q = DF^T (f - M xddot - h(x, xdot) - De^T sigma_c)        (N, N m; N on a deformation)

the balance on the DOFs proper is Q_f = 0 and the input must supply F = -Q_k: the generalised
force that realises it, in the unit conjugate to its value (N on a translation or a
deformation, N m on an angle). A force input of that value on the same coordinate, with the
coordinate a DOF, gives the same equilibrium (for a deformation: the stress resultant that a
released deformation with that resultant would carry). At rest xddot = 0 and h = 0.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from .ports import named_values

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..model import Model


def motion_values(model: Model, motions: Mapping[str, float] | ArrayLike | None) -> np.ndarray:
    """The values of the kinematic inputs, from a dict by name or a sequence.

    Parameters
    ----------
    model : Model
    motions : dict of str to float or array_like (n_kinematic,), optional
        {name: value} (the others at the scene's `value`) or every value in the model's
        order; m on a translation or a deformation, rad on a planar angle. None: the scene's
        values (`Model.motion_values`).

    Returns
    -------
    ndarray (n_kinematic,)
        m or rad, in the order of `Model.kinematic_inputs`.

    Raises
    ------
    SceneError
        An unknown name (the message lists the kinematic inputs), a wrong length, or a value
        that is not finite.
    """
    names = [port.name for port in model.kinematic_inputs]
    values = np.array(model.motion_values if model.motion_values is not None else [], float)
    if motions is None:
        return values
    return named_values(model, motions, names, "kinematic input", values)


def input_effort(model: Model, Q: np.ndarray) -> np.ndarray:
    """The generalised force that realises each kinematic input, F = -Q_k.

    Parameters
    ----------
    model : Model
    Q : ndarray (NDOF,) or (n, NDOF)
        The generalised force on q of everything but the inputs (N, N m), at rest or with
        the inertia forces (module docstring).

    Returns
    -------
    ndarray (n_kinematic,) or (n, n_kinematic)
        N on a translation or a deformation, N m on a planar angle.
    """
    return -np.asarray(Q)[..., model.prescribed_dofs]


def held(model: Model, matrix: np.ndarray) -> np.ndarray:
    """A matrix on q with the kinematic inputs held: its rows and columns of the DOFs proper.

    Parameters
    ----------
    model : Model
    matrix : ndarray (NDOF, NDOF)
        On q (stiffness, mass, damping; any unit).

    Returns
    -------
    ndarray
        (NDOF - NKI, NDOF - NKI); the matrix itself in a model without kinematic inputs.
    """
    if not model.kinematic_inputs:
        return matrix
    return matrix[np.ix_(model.free_dofs, model.free_dofs)]


__all__ = ["held", "input_effort", "motion_values"]
