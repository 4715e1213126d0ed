"""The evaluations inverse dynamics makes, and which path makes them: the numpy `Mechanics`
(the reference) or the compiled engine (`inverse_engine`).

Both paths give, for `inverse_dynamics` and the coordinate partitioning of
`free_inverse_dynamics` (inverse_dynamics_partition.py), the same three things:

    solve(q, start)                 a configuration (q, x, e, DF) by Newton from start.x
    motion(config, qdot)            conv = (D2F qdot) qdot, M_bar = DF^T M DF and
                                    Q = DF^T (f - M conv - h - De^T sigma_c), inputs zero
    stress_resultants(config, qdot, qddot, input_force)
                                    sigma of the full dynamic balance with the input forces

so the algorithms above them (Newton on the outputs, the balance solved for the forces, the
Radau steps) are one code, and the two paths differ by the evaluations' round-off.

Which path (`compiled=None`): the engine where it takes the model (`inverse_engine.supports`)
and the work is large enough that it is the faster, its start-up in a process included:

    free coordinates x evaluations >= ENGINE_MIN_WORK

an integer rule (no timing is compared at run time, so the choice cannot flip with the CPU;
a tie, work equal to the threshold, takes the engine). The evaluations are counted as
`inverse_dynamics` makes them: one per time (with the Newton on the positions: about three
kinematics per time); `free_inverse_dynamics` makes about ten per step (three stages, two to
four Newton iterations), and counts them so. Measured (docs/benchmarks.md, 2026-11-30:
whole-process CPU, the engine's cache warm; one evaluation of the engine about 0.1 ms on a
small model, 2 ms on manipulator_control, against 2 ms and 70 ms of numpy): the engine's
start-up in a process (numba, llvmlite, the cached entries, the packing) is 0.2 to 0.3 s of
CPU, which the numpy path's saving pays for from about 1e5 free-coordinate evaluations.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from . import inverse_engine

if TYPE_CHECKING:  # names for the annotations only
    from ..mechanics.kinematics import Configuration
    from ..mechanics.mechanics import Mechanics
    from ..model import Model

ENGINE_MIN_WORK = 100_000  # free coordinates x evaluations from which the engine is preferred


def preferred(model: Model, evaluations: int) -> bool:
    """Whether the engine is the default path of an inverse dynamics of `model` that makes
    about `evaluations` evaluations (module docstring: the rule and its threshold)."""
    return (inverse_engine.supports(model)
            and int(model.free_coordinates.size) * int(evaluations) >= ENGINE_MIN_WORK)


def motion_evaluator(model: Model, mech: Mechanics, compiled: bool | None, evaluations: int):
    """The evaluator of the path `compiled` asks for (None: the preferred one for about
    `evaluations` evaluations): an `inverse_engine.EngineMotion` or a `NumpyMotion`.

    Raises
    ------
    SceneError
        compiled=True for a model the engine does not take.
    """
    if compiled is None:
        compiled = preferred(model, evaluations)
    if not compiled:
        return NumpyMotion(mech)
    if not inverse_engine.supports(model):
        from ..errors import SceneError

        raise SceneError(f"{model.source}: the compiled engine does not take the inverse "
                         f"dynamics of {model.name!r} (actuators, or a model not exactly "
                         "counted): compiled=False takes the numpy path")
    return inverse_engine.engine_motion(model)


class NumpyMotion:
    """The evaluations of inverse dynamics on the numpy `Mechanics` (module docstring): the
    reference the engine's (`inverse_engine.EngineMotion`) are compared with.

    Parameters
    ----------
    mech : Mechanics
        The model's mechanics.
    """

    def __init__(self, mech: Mechanics):
        self.mech = mech

    def start(self, config: Configuration) -> Configuration:
        """The configuration to start from: `config` itself."""
        return config

    def solve(self, q: np.ndarray, start) -> Configuration:
        """The configuration at DOFs q (NDOF,) m or rad, by Newton from start.x (NX,).

        Raises
        ------
        ConvergenceError
            The constraints cannot be solved at q.
        """
        return self.mech.kinematics.solve(q, start.x)

    def motion(self, config: Configuration, qdot: np.ndarray,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(conv (NX,) m/s^2, M_bar (NDOF, NDOF) kg, Q (NDOF,) N) at config and qdot m/s
        (rad/s on an angle): the module docstring's terms, the inputs zero."""
        mech = self.mech
        inertia = mech.inertia
        conv = mech.kinematics.convective_acceleration(config, qdot)
        xdot = config.DF @ qdot
        M_x = inertia.mass_matrix(config.x)
        sigma_c = mech.constitutive_stress(config, config.De @ xdot)
        r = (mech.external_force(config.x) - M_x @ conv
             - inertia.convective_force(config.x, xdot) - config.De.T @ sigma_c)
        return conv, config.DF.T @ (M_x @ config.DF), config.DF.T @ r

    def stress_resultants(self, config: Configuration, qdot: np.ndarray, qddot: np.ndarray,
                          input_force: np.ndarray) -> np.ndarray:
        """sigma (NE,) N of the full dynamic balance at config, qdot, qddot with the input
        forces `input_force` (NX,) N or N m (`stresses.dynamic_stress_resultants`)."""
        from .stresses import dynamic_stress_resultants

        return dynamic_stress_resultants(self.mech, config, qdot, qddot, input_force)


__all__ = ["ENGINE_MIN_WORK", "NumpyMotion", "motion_evaluator", "preferred"]
