"""The stress resultants of rigid deformations in a simulation: the reactions (the
multipliers of the full dynamic balance) at a state the compiled engine has just evaluated.

A rigid deformation (held zero) carries no constitutive stress; its stress resultant is the
multiplier lambda of its constraint row in

    J^T lambda = r = f + f_in - M xddot - h(x, xdot) - De^T sigma_c

(`flexure.core.mechanics.mechanics`; numpy's `analysis.stresses.dynamic_stress_resultants`
is the reference the tests compare with). The engine's operation OP_STRESS_RESULTANTS
(`flexure.core.engine.reactions`) forms them from the evaluation just made: one J^-T solve
with its factors, at its own coordinates, forces and accelerations, so that reading the
reactions at a state is that one evaluation. The force inputs are those the evaluation put
on their ports (an actuator's force from its drive or current).

A model packed with rigid clusters gets no reactions from that operation (a cluster
eliminates its rigid beams' rows, whose reactions its masters' normalisation rows then carry:
`engine.reactions`): such a model gets a second packed model without clusters
(`EngineData(model, rigid=False)`, made on first use), evaluated at the same state.

Measured (CPU, loaded 2-core machine, docs/benchmarks.md 2026-11-29): the element outputs of
one state with reactions 46 us on stage_planar_3dof and 61 us on stage_spatial_1dof, against
352 and 967 us through the numpy mechanics.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..engine import data as ed
from ..engine import engine
from ..engine.status import status_message
from ..errors import SimulationError

if TYPE_CHECKING:  # names for the annotations only
    from ..engine.data import EngineData
    from ..model import Model


class RigidReactions:
    """The stress resultants of every deformation at an evaluated state, the rigid ones'
    the reactions (module docstring).

    Parameters
    ----------
    model : Model
    """

    def __init__(self, model: Model) -> None:
        self.model = model
        self._unclustered: EngineData | None = None

    def stress_resultants(self, data: EngineData, y: np.ndarray, inputs: np.ndarray,
                          t: float) -> np.ndarray:
        """sigma of every deformation at the state the engine evaluated last.

        Parameters
        ----------
        data : EngineData
            The packed model just evaluated (OP_RHS) at the state y on its q_ref, with the
            held inputs `inputs`, at time t.
        y : ndarray (2 NDOF + n_coils,)
            The state it evaluated: [q - q_ref, qdot(, i)] (m, rad; m/s, rad/s; A).
        inputs : ndarray (n_inputs,)
            The inputs held: N, N m, V.
        t : float
            The time, s (the kinematic inputs' path).

        Returns
        -------
        ndarray (NE,)
            N: S e + D edot on the stressed deformations, the reactions on the rigid ones.

        Raises
        ------
        SimulationError
            The engine could not evaluate the state or solve for the multipliers.
        """
        if data.int_array("dims")[ed.NSLAVES] > 0:
            data = self._evaluated_without_clusters(data, y, inputs, t)
        out = np.empty(data.int_array("dims")[ed.NE])
        status = engine.call(data, engine.OP_STRESS_RESULTANTS,
                             data.float_array("qddot").copy(), out)
        if status == ed.NONFINITE_RESULT:
            raise SimulationError("the reactions of the rigid deformations: non-finite "
                                  "multipliers (a singular configuration)")
        if status != ed.OK:
            raise SimulationError(f"the reactions of the rigid deformations: "
                                  f"{status_message(status)}")
        return out

    def _evaluated_without_clusters(self, data, y, inputs, t):
        """The packed model without rigid clusters, evaluated at the state `data` was."""
        from ..engine.data import EngineData

        if self._unclustered is None:
            self._unclustered = EngineData(self.model, rigid=False)
        own = self._unclustered
        own.float_array("q_ref")[:] = data.float_array("q_ref")
        own.float_array("inputs")[:] = inputs
        status = engine.call(own, engine.OP_RHS, np.array(y, dtype=float), t=t)
        if status != ed.OK:
            raise SimulationError(f"the reactions of the rigid deformations: "
                                  f"{status_message(status)}")
        return own


__all__ = ["RigidReactions"]
