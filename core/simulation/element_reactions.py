"""The stress resultants of rigid deformations in a simulation: the reactions (the
multipliers of the full dynamic balance) at a state the compiled engine has just evaluated.

A rigid deformation (held zero) carries no constitutive stress; its stress resultant is the
multiplier lambda of its constraint row in

    J^T lambda = r = f + f_in - M xddot - h(x, xdot) - De^T sigma_c

(`flexure.core.mechanics.mechanics`). The engine's evaluation solves the accelerations
without forming the multipliers (the reduced form never has them), so they come from the
numpy mechanics (`flexure.core.analysis.stresses.dynamic_stress_resultants`, the function
inverse dynamics uses) at the engine's own coordinates x and accelerations qddot: the same
state, one factorisation of J and one mass matrix, no second solve of the motion. The force
inputs are the values the engine put on their ports (an actuator's force from its drive or
current); a kinematic input's effort acts on its own DOF row only, whose multiplier is not a
rigid deformation's, so it is left out (as in inverse dynamics).

Measured on a loaded 2-core machine, one BLAS thread: `output_values` 0.83 ms on
stage_planar_3dof with the bar's two reactions (0.12 ms without), 2.8 ms on
stage_spatial_1dof with the left leaf's two (numpy's J and mass matrix over 24
coordinates), against 0.2 ms for a 1 ms esdirk step: the price of a reaction, paid only by
a model that asks for one (an FMU's doStep then costs 5 to 15 times as much).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import FlexureError, SimulationError
from ..numerics.blas import blas_threads

if TYPE_CHECKING:  # names for the annotations only
    from ..engine.data import EngineData
    from ..model import Model


class RigidReactions:
    """The stress resultants of every deformation at an evaluated state, the rigid ones'
    the reactions (module docstring); the numpy mechanics made on first use.

    Parameters
    ----------
    model : Model
    """

    def __init__(self, model: Model) -> None:
        self.model = model
        self._mechanics = None

    def stress_resultants(self, data: EngineData, q: np.ndarray, qdot: np.ndarray,
                          port_values: np.ndarray) -> np.ndarray:
        """sigma of every deformation at the state the engine evaluated last.

        Parameters
        ----------
        data : EngineData
            The packed model just evaluated at q, qdot: its slots x (the coordinates, m,
            rad) and qddot (the accelerations, m/s^2, rad/s^2) are read.
        q, qdot : ndarray (NDOF,)
            The DOFs (m, rad) and their rates (m/s, rad/s) it evaluated (a kinematic input's
            entries on its path).
        port_values : ndarray (n_inputs,)
            The force or moment each input put on its port, N or N m.

        Returns
        -------
        ndarray (NE,)
            N: S e + D edot on the stressed deformations, the reactions on the rigid ones.

        Raises
        ------
        SimulationError
            The numpy mechanics cannot factor the constraints at the engine's coordinates.
        """
        from ..analysis.stresses import dynamic_stress_resultants
        from ..mechanics.mechanics import Mechanics
        from ..mechanics.ports import input_forces

        if self._mechanics is None:
            self._mechanics = Mechanics(self.model)
        mechanics = self._mechanics
        x = data.float_array("x").copy()
        qddot = data.float_array("qddot").copy()
        # one BLAS thread on these small matrices (`blas`: many times faster on a busy machine)
        with blas_threads():
            try:
                config = mechanics.kinematics.configuration(np.array(q, float), x)
                force = input_forces(self.model, x, np.asarray(port_values, float))
                return dynamic_stress_resultants(mechanics, config, np.array(qdot, float),
                                                 qddot, force)
            except (FlexureError, np.linalg.LinAlgError) as error:
                raise SimulationError("the reactions of the rigid deformations: "
                                      f"{error}") from None


__all__ = ["RigidReactions"]
