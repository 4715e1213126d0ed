"""The outputs on elements (SPACAR's OUTE and OUTF) in a simulation: each at a state, read
from the compiled engine on the simulator's second packed model (`_output_data`), so that
reading them never disturbs the integrator's own evaluations.

- A deformation output is e_d (m) of the kinematics solved at the state's DOFs: the solve the
  coordinate outputs already made.
- A stress output of a stressed deformation (released, or a DOF) is the engine's stress
  resultant sigma_d = S e + D edot (N; a bending or torsion resultant is the moment over l0),
  elastic plus the element's viscous term, from one evaluation of the equations of motion at
  the state. Why the viscous term: sigma is what the element puts on its nodes (the force
  De^T sigma of the equations of motion), the quantity SPACAR's stress resultants and
  flexure's inverse dynamics report along a motion; at rest (edot = 0) it is the static
  solution's S e. The elastic part alone is the deformation output times the stiffness.
- A stress output of a prescribed deformation (a kinematic input's) is a reaction: minus the
  input's effort, sigma_d = -F = Q_k - M_k. qddot (`flexure.core.engine.prescribed`), which the
  same evaluation gives at the state's time with the held inputs.
- A stress output of a rigid deformation (held zero) is a reaction too: the multiplier of
  its constraint row in the full dynamic balance, which the engine forms from the same
  evaluation (OP_STRESS_RESULTANTS: one J^-T solve), or on a model with rigid clusters from
  one evaluation more on a packing without them (`element_reactions`).

The engine's evaluation is the one the integrator makes, so no second physics path is
involved; the numpy mechanics (the tests' reference: its kinematics, De and S e + D edot)
cost 1.5 to 7 ms per state on the stages against about 0.05 ms here. Measured on
stage_planar_3dof (esdirk, 1 ms steps of about 0.1 to 0.17 ms on a shared 2-core machine):
`output_values` 0.6 us with its coordinate outputs alone (read from q), 45 us with
deformation outputs (a kinematic solve through Python), 93 us with stress outputs too (one
evaluation more); stage_spatial_1dof 17, 48 and 95 us.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..engine import data as ed
from ..engine import engine
from ..engine.status import status_message
from ..errors import SimulationError
from .element_reactions import RigidReactions

if TYPE_CHECKING:  # names for the annotations only
    from ..engine.data import EngineData
    from ..model import Model

# what an output on an element reads (`ElementReadings.kinds`): a deformation, a
# constitutive stress resultant, minus a kinematic input's effort, a rigid one's reaction
DEFORMATION, STRESS, REACTION, RIGID = 0, 1, 2, 3


class ElementReadings:
    """How a simulator reads its model's outputs on elements from a packed model.

    Parameters
    ----------
    model : Model
    """

    def __init__(self, model: Model) -> None:
        self.model = model
        self.ndof = model.declared_dof_count
        self.nstate = 2 * self.ndof + len(model.coil_actuators)
        prescribed = {port.deformation: k for k, port in enumerate(model.kinematic_inputs)
                      if port.deformation is not None}
        ports = model.element_outputs
        self.deformations = [int(port.deformation) for port in ports]
        rigid = set(np.asarray(model.rigid_deformations).tolist())
        self.kinds = [DEFORMATION if port.quantity == "deformation"
                      else REACTION if port.deformation in prescribed
                      else RIGID if port.deformation in rigid else STRESS
                      for port in ports]
        self.reactions = RigidReactions(model) if RIGID in self.kinds else None
        # a reaction's place in the efforts (unused for the other kinds)
        self.efforts = [prescribed.get(port.deformation, -1) for port in ports]
        self.evaluates = any(kind != DEFORMATION for kind in self.kinds)
        # with kinematic inputs an evaluation puts their path at its time into q: it needs t
        self.needs_time = self.evaluates and bool(model.kinematic_inputs)

    def __len__(self) -> int:
        return len(self.kinds)

    def values(self, data: EngineData, state: np.ndarray, inputs: np.ndarray,
               t: float | None) -> np.ndarray:
        """The outputs on elements at a state whose kinematics `data` has just solved.

        Parameters
        ----------
        data : EngineData
            The packed model, its slot e the deformations at the state's DOFs.
        state : ndarray (2 NDOF + n_coils,)
            The absolute state [q, qdot(, i)]: m, rad; m/s, rad/s; A.
        inputs : ndarray (n_inputs,)
            The inputs held at the state: N, N m, V (what an effort carries).
        t : float or None
            The state's time (s): the kinematic inputs' path at it (needed with kinematic
            inputs and a stress output, `needs_time`).

        Returns
        -------
        ndarray (n_element_outputs,)
            m for a deformation, N for a stress resultant.

        Raises
        ------
        SimulationError
            The evaluation failed at the state (the caller names the state), or no time
            where one is needed.
        """
        e = data.float_array("e")
        values = np.array([e[d] for d in self.deformations], dtype=float)
        if not self.evaluates:
            return values
        if self.needs_time and t is None:
            raise SimulationError("the stress outputs of a model with kinematic inputs need "
                                  "the time of each state (the inputs' path at it)")
        n = self.ndof
        # y = [0, qdot(, i)] on q_ref = q: the evaluation of this state, as the integrator's
        data.float_array("q_ref")[:] = state[:n]
        data.float_array("inputs")[:] = inputs
        # the engine reads a whole state: coil currents left out of `state` are zero
        y = np.zeros(self.nstate)
        rates = state[n: self.nstate]
        y[n: n + rates.size] = rates
        t = 0.0 if t is None else float(t)
        status = engine.call(data, engine.OP_RHS, y, t=t)
        if status != ed.OK:
            raise SimulationError(f"the stress outputs: {status_message(status)}")
        sigma, efforts = data.float_array("sigma"), data.float_array("efforts")
        reactions = (None if self.reactions is None
                     else self.reactions.stress_resultants(data, y, inputs, t))
        for j, (kind, d, k) in enumerate(zip(self.kinds, self.deformations, self.efforts,
                                             strict=True)):
            if kind == STRESS:
                values[j] = sigma[d]
            elif kind == RIGID:
                values[j] = reactions[d]
            elif kind == REACTION:  # the effort does work on the deformation's increase
                values[j] = -efforts[k]
        return values


__all__ = ["DEFORMATION", "REACTION", "RIGID", "STRESS", "ElementReadings"]
