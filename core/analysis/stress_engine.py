"""The stress resultants of a motion through the compiled engine, for `stresses.stresses_along`.

At a state [q, qdot(, i)] (m, rad; m/s, rad/s; A) with the inputs held (N, N m, V), one
evaluation of the equations of motion (OP_RHS: the kinematics, the forces, the accelerations
qddot of that state) and OP_STRESS_RESULTANTS (`engine.reactions`) give the stress resultants
of every deformation,

    sigma = S e + D edot  (+ J^-T (r - M xddot) on the constraint rows),

which the numpy reference `stresses.dynamic_stress_resultants` forms with its own
`Mechanics` (tests/test_engine_reactions.py compares the two). The force inputs are those the
evaluation puts on their ports: a force or moment input's value, an actuator's force from its
drive signal and the state's coil current.

The packed model is one per live model, kept between calls (packing takes 0.1 to 1 s; an
FMU reads the stresses once per step). It keeps its rigid clusters unless a beam with a
section has a rigid deformation, whose reaction the engine gives only without clusters
(`engine.reactions`): then it is packed without them. Each call starts the kinematics from
the model's initial coordinates and each state from the last one's, as the numpy path does.
A model with kinematic inputs is evaluated in the engine's prescribed form, which puts each
input's path at the evaluation's time into q and qdot and solves the DOFs proper with the
input's acceleration u'' given: the state gives u and u', the caller u'' (a state alone
does not), and the evaluation runs at t = 0 on a path whose record there is the quadratic
u + u' t + u'' t^2 / 2.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError
from ..live_models import PerLiveModel

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

_PACKED = PerLiveModel()  # model -> EngineStresses


def supports(model: Model) -> bool:
    """Whether the engine gives the stress resultants of `model`'s states: not with kinematic
    inputs and actuators together, which its packing refuses (the prescribed form has no
    coils)."""
    return not (model.kinematic_inputs and model.actuators)


def engine_stresses(model: Model) -> EngineStresses:
    """The `EngineStresses` of `model`, packed once per live model and reused."""
    return _PACKED.get(model) or _PACKED.put(model, EngineStresses(model))


def section_deformations(model: Model) -> np.ndarray:
    """The deformations of the elements whose von Mises stress `stresses.beam_stresses`
    gives (a module with `section_forces`, a section with A > 0), model indices."""
    found = [group.deformation_index[group.properties["A"] > 0].ravel()
             for group in model.groups
             if getattr(group.kind, "section_forces", None) is not None
             and np.any(group.properties.get("A", 0.0) > 0)]
    return np.concatenate(found) if found else np.zeros(0, dtype=np.int64)


class EngineStresses:
    """The stress resultants of one model's states through the engine (module docstring).

    Parameters
    ----------
    model : Model
        A model the engine takes (`supports`).
    """

    def __init__(self, model: Model):
        from ..engine import data as ed
        from ..engine.data import EngineData

        self._ed = ed
        self.model = model
        data = EngineData(model)
        reactions = np.isin(section_deformations(model), model.rigid_deformations)
        if data.int_array("dims")[ed.NSLAVES] > 0 and np.any(reactions):
            data = EngineData(model, rigid=False)
        self.data = data
        self.ndof = model.declared_dof_count
        self.nstate = 2 * self.ndof + len(model.coil_actuators)
        self._sigma = np.empty(data.int_array("dims")[ed.NE])

    def restart(self) -> None:
        """Start the next state's kinematics from the model's initial coordinates."""
        self.data.restart_kinematics(self.model.initial_coordinates)

    def stress_resultants(self, state: np.ndarray, held: np.ndarray | None,
                          prescribed_accelerations: np.ndarray | None = None,
                          ) -> tuple[np.ndarray, np.ndarray]:
        """The coordinates and the stress resultants at `state`.

        Parameters
        ----------
        state : ndarray (2 NDOF [+ n_coils],)
            [q, qdot(, i)]: m, rad; m/s, rad/s; A (coil currents left out are zero).
        held : ndarray (n_inputs,) or None
            The inputs held: N, N m, V (None: zero).
        prescribed_accelerations : ndarray (n_kinematic,), optional
            The kinematic inputs' accelerations u'' (m/s^2, rad/s^2), in the order of
            `Model.kinematic_inputs`; their u and u' are the state's entries. Needed for a
            model with kinematic inputs (`stresses.stresses_along` checks it).

        Returns
        -------
        x : ndarray (NX,)
            The coordinates, m and rad (Euler parameters unitless).
        sigma : ndarray (NE,)
            The stress resultants, N (a bending or torsion resultant is its moment over l0).

        Raises
        ------
        ConvergenceError
            The engine could not evaluate the state (its kinematics, a singular
            configuration).
        """
        from ..engine import engine

        ed, data, n = self._ed, self.data, self.ndof
        data.float_array("q_ref")[:] = state[:n]
        data.float_array("inputs")[:] = 0.0 if held is None else held
        y = np.zeros(self.nstate)
        rates = state[n: self.nstate]
        y[n: n + rates.size] = rates
        if self.model.kinematic_inputs:
            self._hold_path(state, prescribed_accelerations)
        status = engine.call(data, engine.OP_RHS, y, t=0.0)
        if status == ed.OK:
            status = engine.call(data, engine.OP_STRESS_RESULTANTS,
                                 data.float_array("qddot").copy(), self._sigma)
        if status != ed.OK:
            from ..engine.status import status_message

            raise ConvergenceError(f"the stress resultants of {self.model.name!r} at q = "
                                   f"{np.array2string(state[:n], precision=6)}: "
                                   f"{status_message(status)}")
        return data.float_array("x").copy(), self._sigma.copy()

    def _hold_path(self, state, accelerations):
        """Slot motion_path: each kinematic input on the quadratic through its u, u' (the
        state's) and u'' at t = 0, for an evaluation at t = 0 (module docstring)."""
        from ..engine.layout import PATH_WIDTH

        k, n = self.model.prescribed_dofs, self.ndof
        path = self.data.float_array("motion_path").reshape(-1, PATH_WIDTH)
        path[:] = 0.0
        path[:, 1] = 1.0  # s: t = 0 is inside [t_start, t_end), where u' and u'' count
        path[:, 2], path[:, 3] = state[k], state[n + k]
        path[:, 4] = 0.5 * np.asarray(accelerations, dtype=float)
