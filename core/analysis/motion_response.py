"""The nonlinear response to prescribed motion, in plain numpy and scipy: the reference for
a compiled one.

The kinematic inputs follow a path u(t) (values, rates and accelerations given); the DOFs
proper q_f move under it, the force inputs held and the loads on. With q = [q_f, u(t)] and
qdot = [qdot_f, u'(t)] the reduced equations of motion (formulation.md) split as

    M_ff qddot_f = Q_f - M_fk u''
    F            = M_kf qddot_f + M_kk u'' - Q_k            (the efforts, N or N m)

with M = DF^T M_x DF and Q = DF^T (f - M_x (D2F qdot) qdot - h(x, xdot) - De^T sigma_c), the
kinematics solved at every evaluation (`Kinematics.solve`, warm-started). The first-order
system in [q_f, qdot_f] is integrated by scipy's Radau (implicit, for the stiff modes of a
flexure), from rest at the static equilibrium with the inputs at u(t0). Every evaluation runs
the numpy kinematics: meant for small models and as the reference a compiled engine is held
against, not for speed (docs/analyses.md says what the engine needs).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError, SceneError
from ..mechanics.mechanics import Mechanics
from ..mechanics.ports import input_forces, input_values
from ..numerics.blas import blas_threads
from .statics import static_equilibrium

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..model import Model
    from .inverse_dynamics import Path


@dataclass
class MotionResponse:
    """The response along the times asked for: q, qdot (n_t, NDOF) on all of q (m, rad and
    their rates), x (n_t, NX), efforts (n_t, n_kinematic) N or N m, in the order of
    `Model.kinematic_inputs`; `evaluations` the right-hand sides the integrator took."""

    model: Model
    times: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    x: np.ndarray
    efforts: np.ndarray
    evaluations: int


class PrescribedBalance:
    """The equations of motion with the inputs prescribed, evaluated at (t, q_f, qdot_f)."""

    def __init__(self, model, mech, motion, forces):
        self.model, self.mech, self.motion, self.forces = model, mech, motion, forces
        self.free, self.prescribed = model.free_dofs, model.prescribed_dofs
        self.x = mech.initial_configuration().x
        self.evaluations = 0

    def evaluate(self, t, q_f, qdot_f):
        """(q, qdot, qddot, efforts, x) at time t."""
        model, mech = self.model, self.mech
        u, rate, acceleration = self.motion(t)
        q, qdot, qddot = (np.zeros(model.declared_dof_count) for _ in range(3))
        q[self.free], q[self.prescribed] = q_f, u
        qdot[self.free], qdot[self.prescribed] = qdot_f, rate
        config = mech.kinematics.solve(q, self.x)
        self.x = config.x
        xdot = config.DF @ qdot
        sigma_c = mech.constitutive_stress(config, config.De @ xdot)
        inertia = mech.inertia
        M_x = inertia.mass_matrix(config.x)
        force = mech.external_force(config.x) + input_forces(model, config.x, self.forces)
        r = (force - M_x @ mech.kinematics.convective_acceleration(config, qdot)
             - inertia.convective_force(config.x, xdot) - config.De.T @ sigma_c)
        Q, M = config.DF.T @ r, config.DF.T @ M_x @ config.DF
        free, prescribed = self.free, self.prescribed
        qddot[prescribed] = acceleration
        if free.size:
            qddot[free] = np.linalg.solve(M[np.ix_(free, free)],
                                          Q[free] - M[np.ix_(free, prescribed)] @ acceleration)
        efforts = M[prescribed] @ qddot - Q[prescribed]
        self.evaluations += 1
        return q, qdot, qddot, efforts, config.x

    def rhs(self, t, state):
        n = self.free.size
        _, _, qddot, _, _ = self.evaluate(t, state[:n], state[n:])
        return np.concatenate([state[n:], qddot[self.free]])


@blas_threads()
def motion_response(model: Model, times: ArrayLike, motion: Path, *,
                    inputs: dict | ArrayLike | None = None, rtol: float = 1e-8,
                    atol: float | None = None,
                    mechanics: Mechanics | None = None) -> MotionResponse:
    """Integrate the DOFs proper under prescribed motion (module docstring).

    Parameters
    ----------
    model : Model
        With at least one kinematic input.
    times : array_like (n_t,)
        s, increasing: the first is the start, the response is given at each.
    motion : callable
        motion(t) -> (values, rates, accelerations), each (n_kinematic,): m, m/s, m/s^2
        (rad, rad/s, rad/s^2 on an angle), in the order of `Model.kinematic_inputs`.
    inputs : dict of str to float or array_like (n_inputs,), optional
        Held force and moment inputs, N or N m (not actuators' drive signals).
    rtol : float
        Relative tolerance of the integrator.
    atol : float, optional
        Absolute tolerance on [q_f, qdot_f] (default rtol times the model's length scale).
    mechanics : Mechanics, optional
        The model's mechanics to reuse.

    Returns
    -------
    MotionResponse

    Raises
    ------
    SceneError
        No kinematic input, an actuator, times not increasing, or a motion of the wrong shape.
    ConvergenceError
        The integrator fails (it names the time).
    """
    from scipy.integrate import solve_ivp

    from ..mechanics.scales import length_scale
    from .inverse_dynamics import sample_path

    if not model.kinematic_inputs:
        raise SceneError(f"{model.source}: a response to prescribed motion needs a kinematic "
                         f"input ([inputs.NAME] kind = \"motion\"); {model.name!r} has none")
    if model.actuators:
        raise SceneError(f"{model.source}: {model.name!r} drives its inputs through actuators, "
                         "whose coils this reference does not integrate")
    times = np.asarray(times, dtype=float).reshape(-1)
    if times.size < 2 or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise SceneError(f"{model.source}: expected at least two finite, increasing times, got "
                         f"{np.array2string(times, threshold=8)}")
    mech = mechanics or Mechanics(model)
    n_kin = len(model.kinematic_inputs)

    def path(t):
        return sample_path(model, motion, t, n_kin)

    held = np.zeros(len(model.inputs)) if inputs is None else input_values(model, inputs)
    balance = PrescribedBalance(model, mech, path, held)
    start = static_equilibrium(model, inputs=held, motions=path(times[0])[0], mechanics=mech)
    balance.x = start.x
    n = model.free_dofs.size
    state = np.concatenate([start.q[model.free_dofs], np.zeros(n)])
    if n:
        scale = atol if atol is not None else rtol * length_scale(model)
        solved = solve_ivp(balance.rhs, (times[0], times[-1]), state, method="Radau",
                           t_eval=times, rtol=rtol, atol=scale)
        if not solved.success:
            raise ConvergenceError(f"{model.source}: response of {model.name!r} to its "
                                   f"prescribed motion: {solved.message} (t = "
                                   f"{solved.t[-1]:g} s)")
        states = solved.y.T
    else:  # nothing free: the motion is the path, and the efforts its inverse dynamics
        states = np.zeros((times.size, 0))
    rows = [balance.evaluate(t, s[:n], s[n:]) for t, s in zip(times, states, strict=True)]
    q, qdot, _, efforts, x = (np.array(column) for column in zip(*rows, strict=True))
    return MotionResponse(model, times, q, qdot, x, efforts.reshape(times.size, n_kin),
                          balance.evaluations)


__all__ = ["MotionResponse", "motion_response"]
