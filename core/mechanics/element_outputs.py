"""Outputs on elements (SPACAR's OUTE and OUTF): a deformation e_d (m) or its stress
resultant sigma_d (N; a bending or torsion resultant is the moment over l0).

Values: e_d from the coordinates; sigma_d from a solution's stress resultants, which hold
S e + D edot on a released or DOF deformation and the multiplier (the reaction) on a
prescribed one, a kinematic input's included.

Linearised (a state space): de_d = De_d DF dq, one row per unit q. A stress resultant is
linear in the state only where it is constitutive, sigma_d = S_d e + D_d edot, so
d sigma_d = S_d De_s DF dq + D_d De_s DF dq' (S_d, D_d its rows of the stressed deformations'
stiffness and damping); a reaction's linearisation needs the accelerations and the inputs'
forces and is refused there, naming the output.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SceneError

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model
    from .kinematics import Configuration
    from .mechanics import Mechanics


def element_output_values(model: Model, e: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """The element outputs' values at deformations e and stress resultants sigma.

    Parameters
    ----------
    model : Model
    e : ndarray (NE,) or (n, NE)
        Deformations, m.
    sigma : ndarray (NE,) or (n, NE)
        Stress resultants, N.

    Returns
    -------
    ndarray (n_element_outputs,) or (n, n_element_outputs)
        m for a deformation output, N for a stress output.
    """
    e, sigma = np.asarray(e), np.asarray(sigma)
    columns = [(e if port.quantity == "deformation" else sigma)[..., port.deformation]
               for port in model.element_outputs]
    return np.stack(columns, axis=-1) if columns else np.zeros(e.shape[:-1] + (0,))


def element_output_rows(model: Model, mechanics: Mechanics,
                        config: Configuration) -> tuple[np.ndarray, np.ndarray]:
    """The element outputs' rows on dq and dq' at a configuration (module docstring).

    Parameters
    ----------
    model : Model
    mechanics : Mechanics
        The model's (its stressed deformations' S and D).
    config : Configuration

    Returns
    -------
    on_q, on_qdot : ndarray (n_element_outputs, NDOF)
        Per unit q and q': m/m, m/rad for a deformation; N/m, N s/m for a stress resultant.

    Raises
    ------
    SceneError
        A stress output of a prescribed deformation (a reaction), which has no such rows.
    """
    DeF = config.De @ config.DF
    on_q = np.zeros((len(model.element_outputs), DeF.shape[1]))
    on_qdot = np.zeros_like(on_q)
    stressed = list(mechanics.stressed)
    for row, port in enumerate(model.element_outputs):
        d = port.deformation
        if port.quantity == "deformation":
            on_q[row] = DeF[d]
            continue
        if d not in stressed:
            raise SceneError(f"{model.source}: outputs.{port.name}: the stress resultant of "
                             f"{model.deformation_names[d]} is a reaction (it is prescribed): "
                             "a linear model has no row for it; read it from a static "
                             "solution or inverse dynamics")
        k = stressed.index(d)
        on_q[row] = mechanics.S[k] @ DeF[mechanics.stressed]
        on_qdot[row] = mechanics.D[k] @ DeF[mechanics.stressed]
    return on_q, on_qdot


__all__ = ["element_output_rows", "element_output_values"]
