"""Inverse dynamics with free DOFs: the input forces for a prescribed output path, the DOFs
the outputs leave free integrated under it.

Prescribed are as many position outputs y (node coordinates, or angles about global axes of
3-D rotational nodes) as force inputs w; the other NDOF - n_y DOFs move freely. The equations
of motion with the outputs as constraints form a DAE,

    M(q) qddot = Q(q, qdot) + B(q) w,     y(x(q)) = y*(t)

(M = DF^T M_x DF, Q = DF^T (f - M_x (D2F qdot) qdot - h - De^T sigma_c), B = DF^T b). It is
solved in minimal coordinates (coordinate partitioning): at the start, QR with column
pivoting on C = (dy/dx) DF picks n_y dependent DOFs q_d whose block C_d is best conditioned;
the others, q_i, are the coordinates integrated. At every evaluation, given (t, q_i, qdot_i):

1. positions: Newton on q_d for y(q) = y*(t) (C_d dq_d = y* - y), warm-started;
2. velocities: C_d qdot_d = y*' - C_i qdot_i;
3. accelerations and forces together: with qddot_d = C_d^-1 (y*'' - c_y - C_i qddot_i)
   (c_y the outputs' acceleration at qddot = 0, as in `inverse_dynamics`), the balance
   becomes one square system of NDOF rows

       [M_i - M_d C_d^-1 C_i,  -B] [qddot_i; w] = Q - M_d C_d^-1 (y*'' - c_y)

   (M_i, M_d the columns of M). It is singular where the forces do not reach the outputs'
   accelerations (relative degree above two: a force on one mass, the output on another
   joined by a massless spring): refused.

The ODE in z = [q_i, qdot_i] is integrated by BDF2 (backward differentiation, order 2, L- and
A-stable) with a fixed step, the given times' spacing h, its first step backward Euler;
each step's implicit equation is solved by Newton on qdot_i with the matrix I - b (A_v + b A_q)
(b = 2h/3, h on the first step) of the linearisation at the start (A_q, A_v the
accelerations' derivatives by q_i and qdot_i), until every |b dqdot_i| is within `tolerance`
of its DOF's unit; a step still iterating after 8 iterations renews A_q, A_v by forward
differences where it is (the rest's go stale along a long stroke: the manipulator's 6 mm).
The outputs hold the path at every time to that tolerance; the free DOFs and the forces
carry the global error O(h^2) (the order is measured in tests/test_inverse_dynamics_free.py).

Zero dynamics. The free DOFs' motion with the outputs held is the system's zero dynamics,
the eigenvalues of [[0, I], [A_q, A_v]] (its transmission zeros). A zero in the right half
plane (non-minimum phase) makes the exact inverse non-causal. A flexure's consistent beam
masses couple its nodes, and so give real zeros at about sqrt(k / m_c), the inverse of a
travel time along the flexure (3.1e5 1/s on manipulator_control). BDF2 with h lambda > 4
takes such a fast unstable mode on its bounded branch, the quasi-static one that the
non-causal stable inversion gives to O(1 / (lambda T)) for a path slower than it (T its time
scale). An unstable zero with 0 < h Re(lambda) <= 4 cannot be integrated this way:
ConstraintError names it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg

from ..errors import ConstraintError, ConvergenceError, SceneError
from ..mechanics.mechanics import Mechanics
from ..mechanics.ports import input_columns, output_rows, output_value, position_port
from ..mechanics.scales import dof_tolerances, within
from ..numerics.blas import blas_threads
from .inverse_dynamics import (
    InverseDynamics,
    Path,
    _output_convective,
    _ports,
    input_ports,
    sample_path,
)
from .stresses import dynamic_stress_resultants

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..model import Model

CONDITION = 1e12  # the largest condition number of C_d and of the balance's matrix
RENEW_AFTER = 8  # Newton iterations of a step before its matrix is renewed


class _Partitioned:
    """The equations of motion in the minimal coordinates q_i (module docstring)."""

    def __init__(self, model, mech, path, out_ports, in_ports, config, tolerance,
                 max_iterations):
        self.model, self.mech, self.path = model, mech, path
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
        model, kin, d = self.model, self.mech.kinematics, self.dependent
        q = self.config.q.copy()
        q[self.independent] = q_i
        config = kin.solve(q, self.config.x)
        for _ in range(self.max_iterations):
            C = output_rows(model, config.x, config.DF, self.out_ports)
            current = np.array([output_value(model, port, config.x) for port in self.out_ports])
            dq = np.linalg.solve(C[:, d], values - current)
            q = config.q.copy()
            q[d] += dq
            config = kin.solve(q, config.x)
            if within(dq, self.steps[d], magnitudes=config.q[d]):
                self.config = config
                return config
        raise ConvergenceError(f"{model.source}: inverse dynamics of {model.name!r} at t = "
                               f"{t:g} s: the positions of the prescribed outputs did not "
                               f"converge in {self.max_iterations} iterations")

    def evaluate(self, t, q_i, qdot_i):
        """(config, qdot, qddot, w) at time t: the motion and the forces (module docstring)."""
        model, mech, d, i = self.model, self.mech, self.dependent, self.independent
        values, rates, accelerations = sample_path(model, self.path, t, len(self.out_ports))
        config = self.solve_positions(t, q_i, values)
        C = output_rows(model, config.x, config.DF, self.out_ports)
        C_d = scipy.linalg.lu_factor(C[:, d])
        qdot = np.zeros(model.declared_dof_count)
        qdot[i] = qdot_i
        qdot[d] = scipy.linalg.lu_solve(C_d, rates - C[:, i] @ qdot_i)
        convective = mech.kinematics.convective_acceleration(config, qdot)
        wanted = accelerations - _output_convective(model, self.out_ports, config, qdot,
                                                    convective)
        inertia = mech.inertia
        xdot = config.DF @ qdot
        M_x = inertia.mass_matrix(config.x)
        sigma_c = mech.constitutive_stress(config, config.De @ xdot)
        r = (mech.external_force(config.x) - M_x @ convective
             - inertia.convective_force(config.x, xdot) - config.De.T @ sigma_c)
        M = config.DF.T @ (M_x @ config.DF)
        B = config.DF.T @ input_columns(model, config.x, self.in_ports)
        system = np.hstack([M[:, i] - M[:, d] @ scipy.linalg.lu_solve(C_d, C[:, i]), -B])
        right = config.DF.T @ r - M[:, d] @ scipy.linalg.lu_solve(C_d, wanted)
        _check_reach(model, system, self.in_ports, t)
        unknowns = np.linalg.solve(system, right)
        qddot = np.zeros_like(qdot)
        qddot[i] = unknowns[:i.size]
        qddot[d] = scipy.linalg.lu_solve(C_d, wanted - C[:, i] @ qddot[i])
        return config, qdot, qddot, unknowns[i.size:]


def _check_reach(model, system, in_ports, t):
    """ConstraintError where the balance's matrix [M_i - M_d C_d^-1 C_i, -B] is singular."""
    if np.linalg.cond(system) > CONDITION:
        raise ConstraintError(
            f"{model.source}: inverse dynamics of {model.name!r} at t = {t:g} s: the force "
            f"inputs {', '.join(p.name for p in in_ports)} do not reach the accelerations of "
            "the prescribed outputs (their balance is singular: the outputs' relative degree "
            "is above two, e.g. a massless spring between an input and an output)")


def _linear_derivatives(part, model, mech, rest, config, t0):
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
    _check_reach(model, system, part.in_ports, t0)
    A_q = np.linalg.solve(system, -lin.K @ S_i)[:i.size]
    A_v = np.linalg.solve(system, -lin.C0 @ S_i)[:i.size]
    return A_q, A_v


def _numerical_derivatives(part, t, q_i, qdot_i, steps, h):
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


@blas_threads()
def free_inverse_dynamics(model: Model, times: ArrayLike, path: Path, *,
                          outputs: Sequence[str] | None = None,
                          inputs: Sequence[str] | None = None, tolerance: float = 1e-12,
                          max_iterations: int = 30,
                          mechanics: Mechanics | None = None) -> InverseDynamics:
    """The input forces that make `model` follow `path`, the DOFs the outputs leave free
    integrated from rest (module docstring: the method, its order and tolerance).

    Parameters
    ----------
    model : Model
        Without kinematic inputs or actuators.
    times : array_like (n_t,)
        s, equally spaced (the BDF2 step h is their spacing), n_t >= 2: the motion starts at
        rest at the static equilibrium under the scene's loads (the inputs zero) at times[0].
    path : callable
        path(t) -> (values, rates, accelerations), each (n_outputs,): the prescribed outputs
        in `outputs` order, m, m/s, m/s^2 (rad, rad/s, rad/s^2 on an angle); its values at
        times[0] those of the rest.
    outputs : sequence of str, optional
        The position outputs to prescribe (default: every position output of the model).
    inputs : sequence of str, optional
        The force inputs to solve for (default: all of the model's), as many as `outputs`.
    tolerance : float
        Newton's tolerance on the positions and on each step's implicit equation, relative to
        each DOF's unit (m through the model's length scale, rad through 1).
    max_iterations : int
        Newton iterations per position solve and per step before ConvergenceError.
    mechanics : Mechanics, optional
        The model's mechanics to reuse.

    Returns
    -------
    InverseDynamics
        The forces (N, N m) and the motion at `times`; no efforts (no kinematic inputs).

    Raises
    ------
    SceneError
        An unknown or unsuitable output or input name, unequal counts, times not equally
        spaced and increasing, a path of the wrong shape, not finite, or not starting at the
        rest; a model with kinematic inputs (`inverse_dynamics` takes them, nothing free).
    ConstraintError
        The outputs are not independent, the inputs do not reach their accelerations, or the
        zero dynamics have an unstable mode the step cannot damp (0 < h Re(lambda) <= 4).
    ConvergenceError
        A position solve or a step's Newton does not converge.
    """
    if model.kinematic_inputs:
        raise SceneError(f"{model.source}: inverse dynamics with free DOFs takes force "
                         f"inputs only; {model.name!r} has kinematic inputs "
                         f"({', '.join(p.name for p in model.kinematic_inputs)}): "
                         "inverse_dynamics prescribes them where nothing is left free")
    mech = mechanics or Mechanics(model)
    out_ports, in_ports = _resolved_ports(model, outputs, inputs)
    times = np.asarray(times, dtype=float).reshape(-1)
    spacing = np.diff(times)
    if (times.size < 2 or not np.all(np.isfinite(times)) or np.any(spacing <= 0)
            or np.ptp(spacing) > 1e-9 * spacing[0]):
        raise SceneError(f"{model.source}: inverse dynamics with free DOFs needs at least two "
                         "finite, increasing, equally spaced times (the step), got "
                         f"{np.array2string(times, threshold=8)}")
    h = float(spacing[0])
    from .statics import static_equilibrium

    rest = static_equilibrium(model, mechanics=mech)
    config = mech.kinematics.solve(rest.q, rest.x)
    values = sample_path(model, path, times[0], len(out_ports))[0]
    start = np.array([output_value(model, port, config.x) for port in out_ports])
    scale = dof_tolerances(model, 1.0).max()
    off = np.abs(values - start) > 1e-9 * scale
    if np.any(off):
        name = out_ports[int(np.argmax(off))].name
        raise SceneError(f"{model.source}: the path must start where {model.name!r} rests: "
                         f"output {name!r} is {start[np.argmax(off)]:.9g} there, the path "
                         f"gives {values[np.argmax(off)]:.9g} at t = {times[0]:g} s")
    part = _Partitioned(model, mech, path, out_ports, in_ports, config, tolerance,
                        max_iterations)
    A_q, A_v = _linear_derivatives(part, model, mech, rest, config, times[0])
    zeros = zero_dynamics(A_q, A_v)
    slow = zeros[(zeros.real > 0) & (h * zeros.real <= 4.0)]
    if slow.size:
        raise ConstraintError(
            f"{model.source}: inverse dynamics of {model.name!r}: the zero dynamics (the free "
            f"DOFs with the outputs held) have an unstable mode at {slow[0]:.6g} 1/s, within "
            f"4 / h = {4.0 / h:.6g} 1/s: the outputs cannot be followed causally (non-minimum "
            "phase); a larger step takes only modes faster than 4 / h on their bounded branch")
    i = part.independent
    steps = part.steps[i]
    q_now, v_now = config.q[i].copy(), np.zeros(i.size)
    q_before = v_before = None
    rows = [_row(part, mech, times[0], q_now, v_now)]
    eye = np.eye(i.size)
    factors, renewed = {}, False
    for t in times[1:]:
        if q_before is None:  # backward Euler
            b, q_base, v_base = h, q_now, v_now
        else:  # BDF2
            b = 2.0 * h / 3.0
            q_base = (4.0 * q_now - q_before) / 3.0
            v_base = (4.0 * v_now - v_before) / 3.0
        if b not in factors:
            factors[b] = scipy.linalg.lu_factor(eye - b * (A_v + b * A_q))
        # predicted: the rates extrapolated from the last two steps
        v = v_now.copy() if v_before is None else 2.0 * v_now - v_before
        for iteration in range(max_iterations):
            if iteration == RENEW_AFTER and not renewed:
                # the matrix of the rest has gone stale along a long stroke: renew it here
                A_q, A_v = _numerical_derivatives(part, t, q_base + b * v, v, steps, h)
                factors = {b: scipy.linalg.lu_factor(eye - b * (A_v + b * A_q))}
                renewed = True
            _, _, qddot, _ = part.evaluate(t, q_base + b * v, v)
            dv = scipy.linalg.lu_solve(factors[b], v_base + b * qddot[i] - v)
            v = v + dv
            if within(b * dv, steps):
                renewed = False  # converged: a later stall may renew it again
                break
        else:
            raise ConvergenceError(f"{model.source}: inverse dynamics of {model.name!r}: the "
                                   f"step to t = {t:g} s did not converge in {max_iterations} "
                                   "Newton iterations")
        q_before, v_before = q_now, v_now
        q_now, v_now = q_base + b * v, v
        rows.append(_row(part, mech, t, q_now, v_now))
    q, qdot, qddot, x, e, forces, sigma = (np.array(column)
                                           for column in zip(*rows, strict=True))
    return InverseDynamics(model, times, [p.name for p in in_ports],
                           [p.name for p in out_ports], forces.reshape(times.size, -1),
                           np.zeros((times.size, 0)), q, qdot, qddot, x, e, sigma)


def _resolved_ports(model, outputs, inputs):
    """(output ports, input ports): `inverse_dynamics`'s, where an output is also a name
    "NODE.AXIS" that no output of the model has: a coordinate ("E.x"), or an angle about a
    global axis of a 3-D rotational node ("Pr.rz")."""
    if outputs is None:
        return _ports(model, None, inputs)
    own = {port.name: port for port in model.outputs if port.quantity == "position"}
    ports = []
    for name in outputs:
        if name in own:
            ports.append(own[name])
            continue
        try:
            ports.append(position_port(model, name))
        except KeyError:
            raise SceneError(f"{model.source}: {name!r} is neither a position output of "
                             f"{model.name!r} ({', '.join(own) or 'none'}) nor one of its "
                             "coordinates (NODE.AXIS) or a rotational node's angle "
                             "(NODE.rx, .ry, .rz)") from None
    return ports, input_ports(model, inputs, ports)


def _row(part, mech, t, q_i, qdot_i):
    """(q, qdot, qddot, x, e, forces, stress resultants) at t."""
    config, qdot, qddot, forces = part.evaluate(t, q_i, qdot_i)
    b = input_columns(part.model, config.x, part.in_ports)
    sigma = dynamic_stress_resultants(mech, config, qdot, qddot, b @ forces)
    return config.q.copy(), qdot, qddot, config.x.copy(), config.e.copy(), forces, sigma


__all__ = ["free_inverse_dynamics", "zero_dynamics"]
