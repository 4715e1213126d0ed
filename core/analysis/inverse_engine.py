"""The evaluations of inverse dynamics through the compiled engine.

Inverse dynamics (`inverse_dynamics`, `free_inverse_dynamics`) asks of a model, at DOFs q
(m, rad) and their rates qdot (m/s, rad/s), for

- the configuration: coordinates x (NX,), deformations e (NE,) and DF = dx/dq (NX, NDOF),
  by Newton on the constraints from the last solution (OP_KINEMATICS);
- the motion's terms: the convective acceleration conv = (D2F qdot) qdot (NX,), the reduced
  mass M_bar = DF^T M DF (NDOF, NDOF; kg, kg m, kg m^2 in the DOF units) and the generalised
  force at qddot = 0 with the inputs zero,

      Q = DF^T (f - M conv - h(x, xdot) - De^T sigma_c(e, edot))          (NDOF,) N, N m

  (f the loads and gravity, h the convective inertia force), all from one evaluation in the
  reduced form (OP_ACCELERATIONS: slots conv, mass, reduced_force);
- the stress resultants of the full dynamic balance at accelerations qddot with the input
  forces b w (N, N m) added to r (OP_STRESS_RESULTANTS at that same evaluation).

These are `inverse_evaluation.NumpyMotion`'s (the numpy `Mechanics`, the reference) to
round-off (tests/test_inverse_engine.py). The model is packed once per live model in the
reduced form (the evaluation leaves M_bar and DF^T r in its slots, where the augmented form
forms neither) and without rigid clusters (a cluster's rigid beams' reactions are nowhere in
the clustered packing: `engine.reactions`), its inputs zero: the unknown forces enter r only
for the stress resultants, linearly, as b w. A configuration is singular only at a zero
pivot of J (`singular_ratio=0`), as in the numpy kinematics, and the kinematics are solved
to the engine's tolerance (1e-15 of each row's unit).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError
from ..live_models import PerLiveModel

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

_PACKED = PerLiveModel()  # model -> EngineMotion


@dataclass
class EngineConfiguration:
    """A configuration solved by the engine: DOFs q (NDOF,) m or rad, coordinates x (NX,),
    deformations e (NE,) m (rad on an angle), and DF (NX, NDOF), copies of its slots."""

    q: np.ndarray
    x: np.ndarray
    e: np.ndarray
    DF: np.ndarray


def supports(model: Model) -> bool:
    """Whether the engine evaluates the inverse dynamics of `model`: not with actuators
    (inverse dynamics solves for forces, and refuses them), and the model exactly counted
    (free coordinates as many as its constraints and DOFs, which the engine's packing
    needs)."""
    constraints = model.rigid_deformations.size + model.dof_deformations.size
    return (not model.actuators
            and model.free_coordinates.size == constraints + model.dof_coordinates.size)


def engine_motion(model: Model) -> EngineMotion:
    """The `EngineMotion` of `model`, packed once per live model and reused (packing takes
    0.3 s on manipulator_control)."""
    return _PACKED.get(model) or _PACKED.put(model, EngineMotion(model))


class EngineMotion:
    """The configurations, motion terms and stress resultants of one model through the
    engine (module docstring).

    Parameters
    ----------
    model : Model
        A model the engine takes (`supports`).
    """

    def __init__(self, model: Model):
        # the engine (and numba) imported on first use: a process that takes the numpy path
        # does not pay for that import
        from ..engine import data as ed
        from ..engine import engine
        from ..engine.data import EngineData

        self.model, self._ed, self._engine = model, ed, engine
        self.data = EngineData(model, augmented=False, singular_ratio=0.0, rigid=False)
        self.data.float_array("inputs")[:] = 0.0
        # `motion` returns slot conv, which the reduced form (augmented=False) forms in every
        # evaluation, as its own r reads it (`convective.keep_convective`)
        self.ndof = int(self.data.int_array("dims")[ed.NDOF])
        self._sigma = np.empty(int(self.data.int_array("dims")[ed.NE]))
        self._current: EngineConfiguration | None = None  # whose kinematics the engine holds
        self._evaluated = None  # (config, qdot) of the engine's last evaluation

    def start(self, config) -> EngineConfiguration:
        """The engine's configuration at config.q, from config.x (a configuration of the
        numpy kinematics, a static solution): where the inverse dynamics starts.

        Raises
        ------
        ConvergenceError
            As `solve`.
        """
        return self.solve(config.q, config)

    def solve(self, q: np.ndarray, start) -> EngineConfiguration:
        """The configuration at DOFs q, by Newton from `start`'s coordinates (a configuration
        with an x (NX,); the engine's last solution when it is that one).

        Raises
        ------
        ConvergenceError
            The constraints cannot be solved at q (beyond the mechanism's reach, or a
            singular configuration).
        """
        q = np.ascontiguousarray(q, dtype=float)
        self._restart(start)
        self._check(self._engine.call(self.data, self._engine.OP_KINEMATICS, q), q)
        data, n = self.data, self.ndof
        config = EngineConfiguration(q.copy(), data.float_array("x").copy(),
                                     data.float_array("e").copy(),
                                     data.float_array("DF").reshape(-1, n).copy())
        self._current, self._evaluated = config, None
        return config

    def motion(self, config: EngineConfiguration, qdot: np.ndarray,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(conv (NX,), M_bar (NDOF, NDOF), Q (NDOF,)) at `config` and the rates qdot (module
        docstring): m/s^2 (rad/s^2), kg (kg m, kg m^2), N (N m).

        Raises
        ------
        ConvergenceError
            As `solve` (the engine solves the kinematics at config.q again, from config.x
            unless it holds that configuration: one Newton step).
        """
        ed, data, n = self._ed, self.data, self.ndof
        qdot = np.ascontiguousarray(qdot, dtype=float)
        self._restart(config)
        status = self._engine.call(data, self._engine.OP_ACCELERATIONS, config.q, qdot)
        if status not in (ed.OK, ed.SINGULAR_MASS):  # M_bar and DF^T r are formed before
            self._check(status, config.q)  # its LU: a massless model's balance is still Q
        self._current, self._evaluated = config, (config, qdot)
        return (data.float_array("conv").copy(), data.float_array("mass").reshape(n, n).copy(),
                data.float_array("reduced_force").copy())

    def stress_resultants(self, config: EngineConfiguration, qdot: np.ndarray,
                          qddot: np.ndarray, input_force: np.ndarray) -> np.ndarray:
        """sigma (NE,) of every deformation, N (a bending or torsion resultant its moment over
        l0), in the balance at `config`, qdot and qddot with the input forces `input_force`
        (NX,) N or N m on the coordinates: the constitutive ones plus the multipliers of
        r - M xddot, r with `input_force` added.

        Raises
        ------
        ConvergenceError
            As `motion`, or a multiplier is not finite (J singular).
        """
        if self._evaluated is None or self._evaluated[0] is not config or not np.array_equal(
                self._evaluated[1], qdot):
            self.motion(config, qdot)
        # the inputs enter r linearly: adding b w to the evaluation's r (slot force) is the
        # evaluation with the inputs at w, without solving its kinematics again
        self.data.float_array("force")[:] += input_force
        self._evaluated = None  # slot force no longer the evaluation's with the inputs zero
        status = self._engine.call(self.data, self._engine.OP_STRESS_RESULTANTS,
                                   np.ascontiguousarray(qddot, dtype=float), self._sigma)
        self._check(status, config.q)
        return self._sigma.copy()

    def _restart(self, start):
        """Start the next kinematics from `start`'s x, unless the engine holds it."""
        if start is None or start is self._current:
            return
        self.data.restart_kinematics(start.x)

    def _check(self, status, q):
        """ConvergenceError unless `status` is OK."""
        if status == self._ed.OK:
            return
        from ..engine.status import status_message

        self._current = self._evaluated = None
        reason = status_message(status)
        raise ConvergenceError(f"kinematics of {self.model.name!r} at q = "
                               f"{np.array2string(q, precision=6)}: {reason}")


__all__ = ["EngineConfiguration", "EngineMotion", "engine_motion", "supports"]
