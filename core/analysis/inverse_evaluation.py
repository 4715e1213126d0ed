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
and the work is large enough that it is the faster in a process, its start-up included:

    evaluations x (free coordinates + OVERHEAD_COORDINATES) >= ENGINE_MIN_WORK

an integer rule (no timing is compared at run time, so the choice cannot flip with the CPU;
a tie, work equal to the threshold, takes the engine). The evaluations are counted as the
caller makes them: `inverse_dynamics` one per time (with about three kinematics for the
positions), `free_inverse_dynamics` EVALUATIONS_PER_STEP per step. Measured
(docs/benchmarks.md, 2026-11-30; 2-core VM under a load of 5 to 7): once started, the engine
is the faster on every model, per time 0.47 against 0.99 ms on truss_1dof_x (1 free
coordinate), 0.51 against 1.6 ms on stage_planar_3dof (6), 1.5 against 6.9 ms on wire_tripod
(28), per step of the free variant 4.8 against 32 ms on stage_spatial_19dof (35) and 62
against 511 ms on manipulator_control (784; about eight evaluations a step): the numpy
path's saving is about 0.1 ms per free coordinate and evaluation plus 0.4 ms
(OVERHEAD_COORDINATES = 4 free coordinates' worth) of its own Python per evaluation.
Starting the engine in a process (numba, llvmlite, the cached entries, the packing) costs
about 0.12 s of CPU. Whole-process CPU, engine over numpy, alternating, medians:
truss_1dof_x 1.10 at 101 times and 0.95 at 301, stage_planar_3dof 1.22 at 11, 0.98 at 101,
0.78 at 301, wire_tripod 1.10 at 11 and 0.85 at 41: the break-even lies at a work of 1060,
1100 and 640, and ENGINE_MIN_WORK = 1000 takes the engine where it is the faster or within a
few per cent of it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from . import inverse_engine

if TYPE_CHECKING:  # names for the annotations only
    from ..mechanics.kinematics import Configuration
    from ..mechanics.mechanics import Mechanics
    from ..model import Model

# the work (module docstring) from which the engine is the default, and the numpy path's own
# overhead per evaluation in free coordinates' worth
ENGINE_MIN_WORK = 1000
OVERHEAD_COORDINATES = 4


def preferred(model: Model, evaluations: int) -> bool:
    """Whether the engine is the default path of an inverse dynamics of `model` that makes
    about `evaluations` evaluations (module docstring: the rule and its threshold)."""
    work = int(evaluations) * (int(model.free_coordinates.size) + OVERHEAD_COORDINATES)
    return inverse_engine.supports(model) and work >= ENGINE_MIN_WORK


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
        M_x = mech.coordinate_mass(config.x)  # formed once, for M conv and M_bar
        sigma_c = mech.constitutive_stress(config, config.De @ xdot)
        r = (mech.external_force(config.x) - M_x @ conv
             - inertia.convective_force(config.x, xdot) - config.De.T @ sigma_c)
        return conv, mech.mass_matrix(config, M_x), config.DF.T @ r

    def stress_resultants(self, config: Configuration, qdot: np.ndarray, qddot: np.ndarray,
                          input_force: np.ndarray) -> np.ndarray:
        """sigma (NE,) N of the full dynamic balance at config, qdot, qddot with the input
        forces `input_force` (NX,) N or N m (`stresses.dynamic_stress_resultants`)."""
        from .stresses import dynamic_stress_resultants

        return dynamic_stress_resultants(self.mech, config, qdot, qddot, input_force)


__all__ = ["ENGINE_MIN_WORK", "OVERHEAD_COORDINATES", "NumpyMotion", "motion_evaluator",
           "preferred"]
