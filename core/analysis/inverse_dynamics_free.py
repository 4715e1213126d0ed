"""Inverse dynamics with free DOFs: the input forces for a prescribed output path, the DOFs
the outputs leave free integrated under it.

Prescribed are as many position outputs y (node coordinates, or angles about global axes of
3-D rotational nodes) as force inputs w; the other NDOF - n_y DOFs move freely. The equations
of motion with the outputs as constraints form a DAE,

    M(q) qddot = Q(q, qdot) + B(q) w,     y(x(q)) = y*(t)

(M = DF^T M_x DF, Q = DF^T (f - M_x (D2F qdot) qdot - h - De^T sigma_c), B = DF^T b). It is
solved in minimal coordinates (coordinate partitioning, inverse_dynamics_partition.py): the
free DOFs q_i are integrated; at every evaluation the dependent q_d follow from the outputs,
and the free DOFs' accelerations a(t, q_i, qdot_i) and the forces w from one square system.

Integration: Radau IIA with three stages (order 5 at the steps, stage order 3; A- and
L-stable, stiffly accurate), one step from each given time to the next (any increasing
times: a step may end where the path has a kink, e.g. a third-order profile's knots, and the
order holds between them). On q' = v, v' = a the stage rates V_j are the unknowns,

    Q_j = q_n + h sum_k A_jk V_k,   V_j = v_n + h sum_k A_jk a(t_n + c_j h, Q_j, V_j),

solved by Newton with the matrix I - h A (x) A_v - h^2 A^2 (x) A_q of the linearisation at
the start (A_q, A_v the accelerations' derivatives by q_i and qdot_i), until every |h dV_j|
is within `tolerance` of its DOF's unit; a step still iterating after 8 iterations renews
A_q, A_v by forward differences where it is (the rest's go stale along a long stroke: the
manipulator's 6 mm). The last stage is the step's end (c_3 = 1). The outputs hold the path at
every time to that tolerance; the free DOFs and the forces at the steps carry the global
error O(h^5), the forces at the inner stages O(h^4) (measured in
tests/test_inverse_dynamics_free.py).

The evaluations (positions, the motion's terms, the stress resultants) come from the numpy
`Mechanics` or the compiled engine (`inverse_evaluation`: the engine where the work,
EVALUATIONS_PER_STEP per step, reaches its rule; compiled= forces a path; the linearisation
at rest and the statics take their own paths). The two paths' forces differ by round-off:
a leaf's axial stiffness (about 1e8 N/m) times the coordinates' round-off (an ulp of a
translation, 2e-17 m, is 2e-9 N), summed over the chain's leaves, is 1e-8 to 1e-7 N on
the manipulator (at the rest, where the forces are zero, numpy's are 2e-8 N and the
engine's differ from them by 2.7e-8 N); Newton carried past its tolerance does not move
it. That is the floor of the manipulator's forward check
(tests/test_manipulator_feedforward.py): numpy's forces at 1.25 ms with white noise of the
two paths' rms difference (3.5e-8 N) added leave E 6.6 to 15 pm and 0.12 to 0.22 nrad off
the path, where numpy's own leave 3.65 pm and 0.068 nrad and the engine's 4.7 pm and 0.11
nrad (docs/benchmarks.md, session 29).
So the check halves from 5 ms, where the discretisation's error (56 to 60 pm, 0.64 to 0.80
nrad) is at least four times that floor in position and three in rotation.

Forces between the steps. Each step has four nodes, its start, its two inner stages
t_n + c_j h (c = (4 -+ sqrt 6) / 10) and its end, and the forces at them; the cubic through
the four, step by step, is the force history w(t) that a forward simulation takes
(`FreeInverseDynamics.force_polynomial`: continuous, O(h^4)). A forward run driven by it
reproduces the path within its own tolerance where h is small enough for the forces'
O(h^4) to lie below that, and `tolerance` tight enough: what each step's Newton leaves adds
up over the steps (docs/manipulator.md, the forward check: 1e-10 was the largest error on
the manipulator at 1.25 ms, 1e-14 is not).

Zero dynamics. The free DOFs' motion with the outputs held is the system's zero dynamics,
the eigenvalues of [[0, I], [A_q, A_v]] (its transmission zeros). A zero in the right half
plane (non-minimum phase) makes the exact inverse non-causal. A flexure's consistent beam
masses couple its nodes, and so give real zeros at about sqrt(k / m_c), the inverse of a
travel time along the flexure (3.1e5 1/s on manipulator_control). The step's amplification
of such a mode is Radau IIA's stability function R(h lambda), |R(z)| -> 3 / |z| for large z
(L-stability): where |R(h lambda)| < 1 (h lambda > 11.84 on the real axis) the step damps
the mode and takes its bounded branch, the quasi-static one that the non-causal stable
inversion gives to O(1 / (lambda T)) for a path slower than it (T its time scale). An
unstable zero with |R(h lambda)| >= 1 at some step cannot be integrated this way:
ConstraintError names it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg

from ..errors import ConstraintError, ConvergenceError, SceneError
from ..mechanics.mechanics import Mechanics
from ..mechanics.ports import input_columns, output_value, position_port
from ..mechanics.scales import dof_tolerances, within
from ..numerics.blas import blas_threads
from .inverse_dynamics import InverseDynamics, Path, input_ports, sample_path, solved_ports
from .inverse_dynamics_partition import (
    Partitioned,
    linear_derivatives,
    numerical_derivatives,
    zero_dynamics,
)
from .inverse_evaluation import motion_evaluator

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike
    from scipy.interpolate import PPoly

    from ..model import Model

RENEW_AFTER = 8  # Newton iterations of a step before its matrix is renewed
# the evaluations a step makes, about (three stages, two to four Newton iterations, and the
# step's end): the work the evaluations' path is given (`inverse_evaluation`)
EVALUATIONS_PER_STEP = 10

_S6 = np.sqrt(6.0)
# Radau IIA, three stages (Hairer & Wanner, Solving ODEs II, Table IV.5.6)
RADAU_C = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
RADAU_A = np.array([
    [(88.0 - 7.0 * _S6) / 360.0, (296.0 - 169.0 * _S6) / 1800.0, (-2.0 + 3.0 * _S6) / 225.0],
    [(296.0 + 169.0 * _S6) / 1800.0, (88.0 + 7.0 * _S6) / 360.0, (-2.0 - 3.0 * _S6) / 225.0],
    [(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0]])
NODES = np.concatenate([[0.0], RADAU_C])  # a step's four nodes, in units of its length


def amplification(z: ArrayLike) -> np.ndarray:
    """|R(z)|: Radau IIA's amplification of a mode y' = lambda y over a step, z = h lambda.

    Parameters
    ----------
    z : array_like complex
        h lambda (dimensionless).

    Returns
    -------
    ndarray of float: |1 + z b^T (I - z A)^-1 1|, b the last row of A.
    """
    z = np.atleast_1d(np.asarray(z, dtype=complex))
    ones = np.ones(3)
    return np.array([abs(1.0 + value * RADAU_A[2] @ np.linalg.solve(
        np.eye(3) - value * RADAU_A, ones)) for value in z])


def _lagrange(tau: np.ndarray) -> np.ndarray:
    """(len(tau), 4): the cubic Lagrange basis on a step's nodes at tau (its fraction)."""
    basis = np.ones((tau.size, NODES.size))
    for j, node in enumerate(NODES):
        for k, other in enumerate(NODES):
            if k != j:
                basis[:, j] *= (tau - other) / (node - other)
    return basis


def node_polynomial(times: ArrayLike, values: ArrayLike) -> PPoly:
    """The cubic through each step's four nodes, step by step, as a piecewise polynomial.

    Parameters
    ----------
    times : array_like (n_t,)
        s, increasing: the steps' ends.
    values : array_like (3 n_t - 2, ...)
        The values at the nodes in time order: times[0], then per step its two inner stages
        and its end (`FreeInverseDynamics.node_times`), in any unit.

    Returns
    -------
    scipy.interpolate.PPoly
        Continuous at the steps' ends, exact at the nodes; its derivative, antiderivative and
        `integrate` are the polynomials'.
    """
    from scipy.interpolate import PPoly

    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    n = times.size - 1
    if values.shape[0] != 3 * n + 1:
        raise ValueError(f"expected {3 * n + 1} node values for {n} steps, got "
                         f"{values.shape[0]}")
    # power coefficients in tau of the Lagrange basis: rows tau^3, tau^2, tau, 1
    vandermonde = np.vander(NODES, 4)
    to_power = np.linalg.inv(vandermonde)  # (4 powers, 4 nodes)
    index = 3 * np.arange(n)[:, None] + np.arange(4)[None, :]  # (n, 4) nodes of each step
    local = values[index]  # (n, 4, ...)
    coefficients = np.einsum("pj,nj...->pn...", to_power, local)
    h = np.diff(times)
    scale = h[None, :] ** -np.arange(3, -1, -1)[:, None]  # tau = (t - t_n) / h
    coefficients = coefficients * scale.reshape(scale.shape + (1,) * (values.ndim - 1))
    return PPoly(coefficients, times)


@dataclass
class FreeInverseDynamics(InverseDynamics):
    """`InverseDynamics` at the given times, plus every step's inner stages (module
    docstring): node_times (3 n_t - 2,) s, the times and the stages in order; node_forces
    (3 n_t - 2, n_inputs) N or N m and node_x (3 n_t - 2, NX) the coordinates there."""

    node_times: np.ndarray | None = None
    node_forces: np.ndarray | None = None
    node_x: np.ndarray | None = None

    def force_polynomial(self) -> PPoly:
        """The forces between the steps: the cubic through each step's four nodes.

        Returns
        -------
        scipy.interpolate.PPoly
            t (s) -> forces (n_inputs,) in N or N m, in `input_names` order.
        """
        return node_polynomial(self.times, self.node_forces)


def start_at_rest(model, mech, evaluator, path, out_ports, times):
    """(rest, config): the static equilibrium where the path must start (SceneError if not),
    and its configuration from `evaluator`."""
    from .statics import static_equilibrium

    rest = static_equilibrium(model, mechanics=mech)
    config = evaluator.solve(rest.q, rest)
    values = sample_path(model, path, times[0], len(out_ports))[0]
    start = np.array([output_value(model, port, config.x) for port in out_ports])
    scale = dof_tolerances(model, 1.0).max()
    off = np.abs(values - start) > 1e-9 * scale
    if np.any(off):
        name = out_ports[int(np.argmax(off))].name
        raise SceneError(f"{model.source}: the path must start where {model.name!r} rests: "
                         f"output {name!r} is {start[np.argmax(off)]:.9g} there, the path "
                         f"gives {values[np.argmax(off)]:.9g} at t = {times[0]:g} s")
    return rest, config


def _check_zeros(model, zeros, spacing):
    """ConstraintError for an unstable zero that some step does not damp (|R(h lambda)| >=
    1)."""
    unstable = zeros[zeros.real > 0]
    for h in np.unique(np.round(spacing / spacing.max(), 9)) * spacing.max():
        grown = unstable[amplification(h * unstable) >= 1.0]
        if grown.size:
            raise ConstraintError(
                f"{model.source}: inverse dynamics of {model.name!r}: the zero dynamics (the "
                f"free DOFs with the outputs held) have an unstable mode at {grown[0]:.6g} "
                f"1/s that a step of {h:.6g} s does not damp (|R(h lambda)| >= 1; on the "
                f"real axis h lambda must exceed 11.84, h > {11.85 / abs(grown[0]):.3g} s): "
                "the outputs cannot be followed causally (non-minimum phase); larger steps "
                "take only such fast modes on their bounded branch")


class _Stepper:
    """Radau IIA steps of the free DOFs (module docstring), with the Newton matrices per h."""

    def __init__(self, part, A_q, A_v, max_iterations, model):
        self.part, self.model, self.max_iterations = part, model, max_iterations
        self.i = part.independent
        self.steps = np.tile(part.steps[self.i], 3)
        self.A_q, self.A_v = A_q, A_v
        self.factored = (None, None)  # (h, LU): the last step's Newton matrix

    def factor(self, h):
        """The LU of the Newton matrix at step h, kept while h stays within 1e-9 (the
        spacings of h * arange(n) differ in their last bits; the matrix sets only how fast
        Newton converges, not where)."""
        last, lu = self.factored
        if last is None or abs(h - last) > 1e-9 * h:
            n = self.i.size
            matrix = (np.eye(3 * n) - h * np.kron(RADAU_A, self.A_v)
                      - h * h * np.kron(RADAU_A @ RADAU_A, self.A_q))
            lu = scipy.linalg.lu_factor(matrix)
            self.factored = (h, lu)
        return lu

    def step(self, t, h, q, v, guess):
        """(stage rates (3, n_i), the last iteration's evaluations at the stages)."""
        n, i = self.i.size, self.i
        V = guess.copy()
        renewed = False
        for iteration in range(self.max_iterations):
            if iteration == RENEW_AFTER and not renewed:
                # the matrix of the rest has gone stale along a long stroke: renew it here
                end = q + h * RADAU_A[2] @ V
                self.A_q, self.A_v = numerical_derivatives(self.part, t + h, end, V[2],
                                                           self.part.steps[i], h)
                self.factored = (None, None)
                renewed = True
            Q = q + h * RADAU_A @ V
            evaluations = [self.part.evaluate(t + c * h, Q[j], V[j])
                           for j, c in enumerate(RADAU_C)]
            accelerations = np.array([found[2][i] for found in evaluations])
            residual = v + h * RADAU_A @ accelerations - V
            dV = scipy.linalg.lu_solve(self.factor(h), residual.reshape(-1)).reshape(3, n)
            V = V + dV
            if within(h * dV.reshape(-1), self.steps):
                return V, evaluations
        raise ConvergenceError(f"{self.model.source}: inverse dynamics of "
                               f"{self.model.name!r}: the step to t = {t + h:g} s did not "
                               f"converge in {self.max_iterations} Newton iterations")


def _predicted(v_start, V, h_before, h):
    """The stage rates of the next step extrapolated from the last step's cubic through
    (v at its start, its stage rates)."""
    tau = 1.0 + RADAU_C * h / h_before
    return _lagrange(tau) @ np.vstack([v_start, V])


@blas_threads()
def free_inverse_dynamics(model: Model, times: ArrayLike, path: Path, *,
                          outputs: Sequence[str] | None = None,
                          inputs: Sequence[str] | None = None, tolerance: float = 1e-12,
                          max_iterations: int = 30, mechanics: Mechanics | None = None,
                          compiled: bool | None = None) -> FreeInverseDynamics:
    """The input forces that make `model` follow `path`, the DOFs the outputs leave free
    integrated from rest (module docstring: the method, its order and tolerance).

    Parameters
    ----------
    model : Model
        Without kinematic inputs or actuators.
    times : array_like (n_t,)
        s, increasing, n_t >= 2: the steps' ends (Radau IIA from each to the next; a kink of
        the path should be one of them). The motion starts at rest at the static
        equilibrium under the scene's loads (the inputs zero) at times[0].
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
    compiled : bool, optional
        Evaluate the model through the compiled engine (True: 0.12 of the numpy path's CPU
        per step on manipulator_control) or the numpy `Mechanics` (False); None (the
        default) takes the engine where `inverse_evaluation.preferred` does for
        EVALUATIONS_PER_STEP evaluations a step.

    Returns
    -------
    FreeInverseDynamics
        The forces (N, N m) and the motion at `times`, the forces and coordinates at the
        steps' inner stages, the forces between (`force_polynomial`); no efforts.

    Raises
    ------
    SceneError
        An unknown or unsuitable output or input name, unequal counts, times not finite and
        increasing, a path of the wrong shape, not finite, or not starting at the rest; a
        model with kinematic inputs (`inverse_dynamics` takes them, nothing free).
    ConstraintError
        The outputs are not independent, the inputs do not reach their accelerations, or the
        zero dynamics have an unstable mode a step does not damp (|R(h lambda)| >= 1).
    ConvergenceError
        A position solve or a step's Newton does not converge.
    """
    if model.kinematic_inputs:
        raise SceneError(f"{model.source}: inverse dynamics with free DOFs takes force "
                         f"inputs only; {model.name!r} has kinematic inputs "
                         f"({', '.join(p.name for p in model.kinematic_inputs)}): "
                         "inverse_dynamics prescribes them where nothing is left free")
    mech = mechanics or Mechanics(model)
    out_ports, in_ports = resolved_ports(model, outputs, inputs)
    times = np.asarray(times, dtype=float).reshape(-1)
    spacing = np.diff(times)
    if times.size < 2 or not np.all(np.isfinite(times)) or np.any(spacing <= 0):
        raise SceneError(f"{model.source}: inverse dynamics with free DOFs needs at least two "
                         "finite, increasing times (the steps' ends), got "
                         f"{np.array2string(times, threshold=8)}")
    evaluator = motion_evaluator(model, mech, compiled,
                                 EVALUATIONS_PER_STEP * spacing.size)
    rest, config = start_at_rest(model, mech, evaluator, path, out_ports, times)
    part = Partitioned(model, evaluator, path, out_ports, in_ports, config, tolerance,
                       max_iterations)
    A_q, A_v = linear_derivatives(part, model, mech, rest, config, times[0])
    _check_zeros(model, zero_dynamics(A_q, A_v), spacing)
    stepper = _Stepper(part, A_q, A_v, max_iterations, model)
    i = part.independent
    q_now, v_now = config.q[i].copy(), np.zeros(i.size)
    rows = [_row(part, times[0], q_now, v_now)]
    node_times, node_forces, node_x = [times[0]], [rows[0][5]], [rows[0][3]]
    guess, before = np.tile(v_now, (3, 1)), None
    for t, h in zip(times[:-1], spacing, strict=True):
        if before is not None:
            guess = _predicted(*before, h)
        V, evaluations = stepper.step(t, h, q_now, v_now, guess)
        for c, (found_config, _, _, forces) in zip(RADAU_C[:2], evaluations[:2],
                                                    strict=True):
            node_times.append(t + c * h)
            node_forces.append(forces)
            node_x.append(found_config.x.copy())
        before = (v_now, V, h)
        q_now, v_now = q_now + h * RADAU_A[2] @ V, V[2].copy()  # stiffly accurate
        rows.append(_row(part, t + h, q_now, v_now))
        node_times.append(t + h)
        node_forces.append(rows[-1][5])
        node_x.append(rows[-1][3])
    q, qdot, qddot, x, e, forces, sigma = (np.array(column)
                                           for column in zip(*rows, strict=True))
    return FreeInverseDynamics(
        model, times, [p.name for p in in_ports], [p.name for p in out_ports],
        forces.reshape(times.size, -1), np.zeros((times.size, 0)), q, qdot, qddot, x, e,
        sigma, node_times=np.array(node_times),
        node_forces=np.array(node_forces).reshape(len(node_times), -1),
        node_x=np.array(node_x))


def resolved_ports(model, outputs, inputs):
    """(output ports, input ports): `inverse_dynamics`'s, where an output is also a name
    "NODE.AXIS" that no output of the model has: a coordinate ("E.x"), or an angle about a
    global axis of a 3-D rotational node ("Pr.rz")."""
    if outputs is None:
        return solved_ports(model, None, inputs)
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


def _row(part, t, q_i, qdot_i):
    """(q, qdot, qddot, x, e, forces, stress resultants) at t."""
    config, qdot, qddot, forces = part.evaluate(t, q_i, qdot_i)
    b = input_columns(part.model, config.x, part.in_ports)
    sigma = part.evaluator.stress_resultants(config, qdot, qddot, b @ forces)
    return config.q.copy(), qdot, qddot, config.x.copy(), config.e.copy(), forces, sigma


__all__ = ["FreeInverseDynamics", "amplification", "free_inverse_dynamics", "node_polynomial",
           "zero_dynamics"]
