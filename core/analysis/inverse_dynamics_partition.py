"""Coordinate partitioning for inverse dynamics with free DOFs: the equations of motion in
the free DOFs q_i, with the prescribed outputs solved for the dependent ones q_d at every
evaluation, and the linearisation of the free DOFs' accelerations (their zero dynamics).

At the start, QR with column pivoting on C = (dy/dx) DF picks n_y dependent DOFs q_d whose
block C_d is best conditioned; the others, q_i, are the coordinates integrated
(inverse_dynamics_free.py). At every evaluation, given (t, q_i, qdot_i):

1. positions: Newton on q_d for y(q) = y*(t) (C_d dq_d = y* - y), warm-started;
2. velocities: C_d qdot_d = y*' - C_i qdot_i;
3. accelerations and forces together: with qddot_d = C_d^-1 (y*'' - c_y - C_i qddot_i)
   (c_y the outputs' acceleration at qddot = 0, as in `inverse_dynamics`), the balance
   becomes one square system of NDOF rows

       [M_i - M_d C_d^-1 C_i,  -B] [qddot_i; w] = Q - M_d C_d^-1 (y*'' - c_y)

   (M_i, M_d the columns of M). It is singular where the forces do not reach the outputs'
   accelerations (relative degree above two: a force on one mass, the output on another
   joined by a massless spring): refused.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..errors import ConstraintError, ConvergenceError
from ..mechanics.ports import input_columns, output_rows, output_value
from ..mechanics.scales import dof_tolerances, within
from .inverse_dynamics import output_convective, sample_path

CONDITION = 1e12  # the largest condition number of C_d and of the balance's matrix


class Partitioned:
    """The equations of motion in the minimal coordinates q_i (module docstring)."""

    def __init__(self, model, evaluator, path, out_ports, in_ports, config, tolerance,
                 max_iterations):
        self.model, self.evaluator, self.path = model, evaluator, path
        self.out_ports, self.in_ports = out_ports, in_ports
        self.max_iterations = max_iterations
        ndof = model.declared_dof_count
        C = output_rows(model, config.x, config.DF, out_ports)
        _, _, pivots = scipy.linalg.qr(C, pivoting=True, mode="economic")
        n_y = len(out_ports)
        self.dependent = np.sort(pivots[:n_y])
        self.independent = np.setdiff1d(np.arange(ndof), self.dependent)
        if np.linalg.cond(C[:, self.dependent]) > CONDITION:
            raise ConstraintError(
                f"{model.source}: inverse dynamics of {model.name!r}: the prescribed outputs "
                f"{', '.join(p.name for p in out_ports)} do not move independently (their "
                "Jacobian C = (dy/dx) DF has rank below their count)")
        self.steps = dof_tolerances(model, tolerance)
        self.config = config

    def solve_positions(self, t, q_i, values):
        """The configuration with q_i and the outputs at `values` (Newton on q_d)."""
        model, evaluator, d = self.model, self.evaluator, self.dependent
        q = self.config.q.copy()
        q[self.independent] = q_i
        config = evaluator.solve(q, self.config)
        for _ in range(self.max_iterations):
            C = output_rows(model, config.x, config.DF, self.out_ports)
            current = np.array([output_value(model, port, config.x) for port in self.out_ports])
            dq = np.linalg.solve(C[:, d], values - current)
            q = config.q.copy()
            q[d] += dq
            config = evaluator.solve(q, config)
            if within(dq, self.steps[d], magnitudes=config.q[d]):
                self.config = config
                return config
        raise ConvergenceError(f"{model.source}: inverse dynamics of {model.name!r} at t = "
                               f"{t:g} s: the positions of the prescribed outputs did not "
                               f"converge in {self.max_iterations} iterations")

    def evaluate(self, t, q_i, qdot_i):
        """(config, qdot, qddot, w) at time t: the motion and the forces (module docstring)."""
        model, d, i = self.model, self.dependent, self.independent
        values, rates, accelerations = sample_path(model, self.path, t, len(self.out_ports))
        config = self.solve_positions(t, q_i, values)
        C = output_rows(model, config.x, config.DF, self.out_ports)
        C_d = scipy.linalg.lu_factor(C[:, d])
        qdot = np.zeros(model.declared_dof_count)
        qdot[i] = qdot_i
        qdot[d] = scipy.linalg.lu_solve(C_d, rates - C[:, i] @ qdot_i)
        convective, M, Q = self.evaluator.motion(config, qdot)
        wanted = accelerations - output_convective(model, self.out_ports, config, qdot,
                                                    convective)
        B = config.DF.T @ input_columns(model, config.x, self.in_ports)
        system = np.hstack([M[:, i] - M[:, d] @ scipy.linalg.lu_solve(C_d, C[:, i]), -B])
        right = Q - M[:, d] @ scipy.linalg.lu_solve(C_d, wanted)
        check_reach(model, system, self.in_ports, t)
        unknowns = np.linalg.solve(system, right)
        qddot = np.zeros_like(qdot)
        qddot[i] = unknowns[:i.size]
        qddot[d] = scipy.linalg.lu_solve(C_d, wanted - C[:, i] @ qddot[i])
        return config, qdot, qddot, unknowns[i.size:]


def check_reach(model, system, in_ports, t):
    """ConstraintError where the balance's matrix [M_i - M_d C_d^-1 C_i, -B] is singular."""
    if np.linalg.cond(system) > CONDITION:
        raise ConstraintError(
            f"{model.source}: inverse dynamics of {model.name!r} at t = {t:g} s: the force "
            f"inputs {', '.join(p.name for p in in_ports)} do not reach the accelerations of "
            "the prescribed outputs (their balance is singular: the outputs' relative degree "
            "is above two, e.g. a massless spring between an input and an output)")


def linear_derivatives(part, model, mech, rest, config, t0):
    """(A_q, A_v): the free DOFs' accelerations' derivatives by q_i and qdot_i at the rest
    `config`, from the linearisation M0, C0, K of the model there (s^-2, s^-1)."""
    from .linearization import linearize

    lin = linearize(model, rest, mechanics=mech)
    d, i = part.dependent, part.independent
    C = output_rows(model, config.x, config.DF, part.out_ports)
    S_i = np.zeros((model.declared_dof_count, i.size))
    S_i[i] = np.eye(i.size)
    S_i[d] = -np.linalg.solve(C[:, d], C[:, i])
    B = lin.DF.T @ input_columns(model, config.x, part.in_ports)
    system = np.hstack([lin.M0 @ S_i, -B])
    check_reach(model, system, part.in_ports, t0)
    A_q = np.linalg.solve(system, -lin.K @ S_i)[:i.size]
    A_v = np.linalg.solve(system, -lin.C0 @ S_i)[:i.size]
    return A_q, A_v


def numerical_derivatives(part, t, q_i, qdot_i, steps, h):
    """(A_q, A_v) at (t, q_i, qdot_i) by forward differences of the accelerations, each DOF
    moved by 1e3 times its Newton tolerance (and its rate by that over h): the Newton matrix
    renewed where the linearisation at rest no longer converges (2 n_i + 1 evaluations)."""
    i = part.independent
    base = part.evaluate(t, q_i, qdot_i)[2][i]
    A_q, A_v = np.empty((i.size, i.size)), np.empty((i.size, i.size))
    for j in range(i.size):
        delta = 1e3 * steps[j]
        moved = q_i.copy()
        moved[j] += delta
        A_q[:, j] = (part.evaluate(t, moved, qdot_i)[2][i] - base) / delta
        moved = qdot_i.copy()
        moved[j] += delta / h
        A_v[:, j] = (part.evaluate(t, q_i, moved)[2][i] - base) / (delta / h)
    return A_q, A_v


def zero_dynamics(A_q: np.ndarray, A_v: np.ndarray) -> np.ndarray:
    """The eigenvalues (1/s) of the free DOFs' motion with the outputs held, linearised:
    of [[0, I], [A_q, A_v]] (the transmission zeros from the inputs to the outputs).

    Parameters
    ----------
    A_q, A_v : ndarray (n_i, n_i)
        s^-2 and s^-1: the accelerations' derivatives by the free DOFs and their rates.

    Returns
    -------
    ndarray (2 n_i,) complex, in decreasing real part.
    """
    n = A_q.shape[0]
    values = np.linalg.eigvals(np.block([[np.zeros((n, n)), np.eye(n)], [A_q, A_v]]))
    return values[np.argsort(-values.real)]


__all__ = ["Partitioned", "check_reach", "linear_derivatives", "numerical_derivatives",
           "zero_dynamics"]
