"""Inverse dynamics: the input forces that make the model follow a prescribed path.

Prescribed are as many position outputs as force inputs (`outputs`, `inputs`: the model's,
by default) and every kinematic input; together they must fix all NX - NXO - NEO entries of
q, so that the path determines the motion (a flexible mode left free needs the time
integration of its own dynamics: refused here, naming the count; `free_inverse_dynamics`,
inverse_dynamics_free.py, integrates it). At each time t:

1. Positions: Newton's method on q for the prescribed values, the outputs as kinematic
   constraints,

       y(x(q)) = y(t),  q_k = u_k(t)          Jacobian [C; E_k^T],  C = (dy/dx) DF

   (E_k the unit columns of the kinematic inputs in q), warm-started from the previous time.
2. Velocities and accelerations: the same Jacobian, differentiated once and twice,

       [C; E_k^T] qdot = [ydot; u_k'],   [C; E_k^T] qddot = [yddot - c_y; u_k'']

   xdot = DF qdot, xddot = DF qddot + (D2F qdot) qdot (`Kinematics.convective_acceleration`),
   and c_y the outputs' acceleration at qddot = 0: (D2F qdot) qdot on a coordinate; for an
   angle about a global axis k of a 3-D rotational node, phi_k(lambda),
   (d phi_k / d lambda) ((D2F qdot) qdot)_lambda + lambda'^T (d2 phi_k / d lambda2) lambda'
   (`rotations.rotation_vector_derivatives`).
3. The dynamic balance on q, with the inertia and damping of the motion,

       R = DF^T (f - M xddot - h(x, xdot) - De^T sigma_c(e, edot))
       DF^T b w + E_k F + R = 0

   solved for the force inputs w (N, N m; b their unit generalised forces,
   `ports.input_columns`) and the efforts F of the kinematic inputs (N, N m). The stress
   resultants of every deformation then follow from the multipliers of the full balance
   (`stresses.dynamic_stress_resultants`): SPACAR's OUTF along the path.

In step 3, DF^T r = Q - M_bar qddot with M_bar = DF^T M DF and Q the generalised force at
qddot = 0. The evaluations (the configurations of step 1, (D2F qdot) qdot, M_bar and Q, the
stress resultants) come from the numpy `Mechanics` or from the compiled engine, by a measured
rule (`inverse_evaluation`, `compiled`): the steps above are the same code on both.

The path's derivatives are the caller's (a profile's own), or a cubic spline's through
samples (`sampled_path`): stated, not guessed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg

from ..errors import ConstraintError, ConvergenceError, SceneError
from ..mechanics.element_outputs import element_output_values
from ..mechanics.mechanics import Mechanics
from ..mechanics.ports import AXIS_INDEX, input_columns, output_rows, output_value
from ..mechanics.scales import dof_tolerances, within
from ..numerics.blas import blas_threads
from ..numerics.rotations import rotation_vector_derivatives
from .inverse_evaluation import motion_evaluator

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..model import Model

Path = Callable[[float], tuple["ArrayLike", "ArrayLike", "ArrayLike"]]


@dataclass
class InverseDynamics:
    """The forces along a prescribed path, one row per time.

    times (n_t,) s; forces (n_t, n_inputs) the force inputs' values, N or N m, in the order
    of `input_names`; efforts (n_t, n_kinematic) the force that realises each kinematic input
    (N, N m); q, qdot, qddot (n_t, NDOF) the motion on q (m, rad and their rates); x (n_t, NX)
    the coordinates; e (n_t, NE) the deformations, m; stress_resultants (n_t, NE) every
    deformation's, N.
    """

    model: Model
    times: np.ndarray
    input_names: list[str]
    output_names: list[str]
    forces: np.ndarray
    efforts: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    x: np.ndarray
    e: np.ndarray
    stress_resultants: np.ndarray

    def element_output(self, name: str) -> np.ndarray:
        """An output on an element over time, by name ([outputs.NAME] element, deformation,
        quantity).

        Parameters
        ----------
        name : str
            The output's name.

        Returns
        -------
        ndarray (n_t,)
            m for a deformation, N for a stress resultant.

        Raises
        ------
        KeyError
            No such output on an element (the message lists them).
        """
        names = [port.name for port in self.model.element_outputs]
        if name not in names:
            raise KeyError(f"no output {name!r} on an element; the model has "
                           f"{', '.join(names) or 'none'}")
        return element_output_values(self.model, self.e, self.stress_resultants)[
            :, names.index(name)]

    def force(self, name: str) -> np.ndarray:
        """The force over time of a force input or a kinematic input, by name.

        Parameters
        ----------
        name : str
            A force input's or a kinematic input's name.

        Returns
        -------
        ndarray (n_t,)
            N, or N m on an angle or a moment.

        Raises
        ------
        KeyError
            No such input (the message lists them).
        """
        kinematic = [port.name for port in self.model.kinematic_inputs]
        if name in self.input_names:
            return self.forces[:, self.input_names.index(name)]
        if name in kinematic:
            return self.efforts[:, kinematic.index(name)]
        raise KeyError(f"no input {name!r}; the inverse dynamics computed "
                       f"{', '.join(self.input_names + kinematic) or 'none'}")


@blas_threads()
def inverse_dynamics(model: Model, times: ArrayLike, path: Path, *,
                     outputs: Sequence[str] | None = None, inputs: Sequence[str] | None = None,
                     tolerance: float = 1e-12, max_iterations: int = 30,
                     mechanics: Mechanics | None = None,
                     compiled: bool | None = None) -> InverseDynamics:
    """The input forces that make `model` follow `path` (module docstring).

    Parameters
    ----------
    model : Model
    times : array_like (n_t,)
        s, increasing.
    path : callable
        path(t) -> (values, rates, accelerations), each (n_outputs + n_kinematic,): the
        prescribed outputs in `outputs` order, then the kinematic inputs in the model's order;
        m, m/s, m/s^2 (rad, rad/s, rad/s^2 on an angle).
    outputs : sequence of str, optional
        The position outputs to prescribe (default: every position output of the model).
    inputs : sequence of str, optional
        The force inputs to solve for (default: all of the model's), as many as `outputs`.
    tolerance : float
        Newton on q stops when every |dq_j| is within `tolerance` of its unit (m through the
        model's length scale, rad through 1).
    max_iterations : int
        Newton iterations per time before ConvergenceError.
    mechanics : Mechanics, optional
        The model's mechanics to reuse.
    compiled : bool, optional
        Evaluate the model through the compiled engine (True) or the numpy `Mechanics`
        (False); default: the engine where it takes the model and the work is large enough
        (`inverse_evaluation.preferred`).

    Returns
    -------
    InverseDynamics

    Raises
    ------
    SceneError
        An unknown or unsuitable output or input name, unequal counts, a path of the wrong
        shape or with non-finite values, times not increasing.
    ConstraintError
        The prescribed outputs and kinematic inputs do not fix every entry of q, or fix it
        singularly (the outputs do not determine the DOFs, or the inputs cannot act on them).
    ConvergenceError
        The positions of a time cannot be solved (beyond the mechanism's reach).
    """
    mech = mechanics or Mechanics(model)
    out_ports, in_ports = solved_ports(model, outputs, inputs)
    times = np.asarray(times, dtype=float).reshape(-1)
    if times.size == 0 or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise SceneError(f"{model.source}: inverse dynamics needs finite, increasing times, "
                         f"got {np.array2string(times, threshold=8)}")
    ndof, n_out, n_kin = model.declared_dof_count, len(out_ports), len(model.kinematic_inputs)
    if n_out + n_kin != ndof:
        raise ConstraintError(
            f"{model.source}: inverse dynamics of {model.name!r}: {n_out} prescribed output(s) "
            f"and {n_kin} kinematic input(s) fix {n_out + n_kin} of the NDOF + NKI = {ndof} "
            "entries of q; the path must determine the motion (DOFs left free: "
            "free_inverse_dynamics integrates their dynamics)")
    prescribed = model.prescribed_dofs
    steps = dof_tolerances(model, tolerance)
    evaluator = motion_evaluator(model, mech, compiled, times.size)
    config = evaluator.start(mech.initial_configuration())
    rows = []
    for t in times:
        values, rates, accelerations = sample_path(model, path, t, n_out + n_kin)
        config, jacobian = _positions(model, evaluator, config, out_ports, values, steps,
                                      max_iterations, t)
        lu = _factor(model, jacobian, t)
        qdot = scipy.linalg.lu_solve(lu, rates) if ndof else np.zeros(0)
        conv, M_bar, Q = evaluator.motion(config, qdot)
        right = accelerations.copy()
        right[:n_out] -= output_convective(model, out_ports, config, qdot, conv)
        qddot = scipy.linalg.lu_solve(lu, right) if ndof else np.zeros(0)
        forces, efforts, sigma = _balance(model, evaluator, config, qdot, qddot, M_bar, Q,
                                          in_ports, prescribed, t)
        rows.append((config.q.copy(), qdot, qddot, config.x.copy(), config.e.copy(), forces,
                     efforts, sigma))
    q, qdot, qddot, x, e, forces, efforts, sigma = (np.array(column)
                                                    for column in zip(*rows, strict=True))
    return InverseDynamics(model, times, [p.name for p in in_ports], [p.name for p in out_ports],
                           forces.reshape(times.size, -1), efforts.reshape(times.size, -1),
                           q, qdot, qddot, x, e, sigma)


def sampled_path(times: ArrayLike, values: ArrayLike) -> Path:
    """A path through samples: a cubic spline per column (not-a-knot ends), with its first and
    second derivatives as the rates and accelerations.

    Parameters
    ----------
    times : array_like (n,)
        s, increasing, n >= 4.
    values : array_like (n, n_prescribed)
        The prescribed values at `times` (m, rad).

    Returns
    -------
    callable
        path(t) -> (values, rates, accelerations) for `inverse_dynamics`.
    """
    from scipy.interpolate import CubicSpline

    spline = CubicSpline(np.asarray(times, float), np.asarray(values, float), axis=0)
    first, second = spline.derivative(1), spline.derivative(2)
    return lambda t: (spline(t), first(t), second(t))


def solved_ports(model, outputs, inputs):
    """The prescribed position outputs and the force inputs solved for, by name, checked."""
    positions = {port.name: port for port in model.outputs if port.quantity == "position"}
    names = list(positions) if outputs is None else list(outputs)
    out_ports = []
    for name in names:
        port = positions.get(name)
        if port is None:
            raise SceneError(f"{model.source}: {name!r} is not a position output of "
                             f"{model.name!r}; its position outputs: "
                             f"{', '.join(positions) or 'none'}")
        out_ports.append(port)
    return out_ports, input_ports(model, inputs, out_ports)


def input_ports(model, inputs, out_ports):
    """The force inputs solved for, by name (default all), as many as `out_ports`; checked."""
    by_name = {port.name: port for port in model.inputs}
    names = list(by_name) if inputs is None else list(inputs)
    unknown = [name for name in names if name not in by_name]
    if unknown:
        raise SceneError(f"{model.source}: unknown force input(s) {', '.join(unknown)}; "
                         f"{model.name!r} has {', '.join(by_name) or 'none'}")
    if model.actuators:
        raise SceneError(f"{model.source}: inverse dynamics solves for forces and moments; "
                         f"{model.name!r} drives its inputs through actuators")
    if len(names) != len(out_ports):
        raise SceneError(f"{model.source}: inverse dynamics needs as many force inputs as "
                         f"prescribed outputs, got {len(names)} input(s) "
                         f"({', '.join(names) or 'none'}) and {len(out_ports)} output(s) "
                         f"({', '.join(p.name for p in out_ports) or 'none'})")
    return [by_name[name] for name in names]


def sample_path(model, path, t, size):
    """(values, rates, accelerations) of the path at t, each (size,), checked."""
    try:
        parts = [np.asarray(part, dtype=float).reshape(-1) for part in path(t)]
    except (TypeError, ValueError) as error:
        raise SceneError(f"{model.source}: the path at t = {t:g} s must give (values, rates, "
                         f"accelerations): {error}") from None
    if len(parts) != 3 or any(part.size != size for part in parts):
        raise SceneError(f"{model.source}: the path at t = {t:g} s must give three arrays of "
                         f"{size} (the prescribed outputs, then the kinematic inputs), got "
                         f"sizes {[part.size for part in parts]}")
    if not all(np.all(np.isfinite(part)) for part in parts):
        raise SceneError(f"{model.source}: the path at t = {t:g} s is not finite")
    return parts


def output_convective(model, out_ports, config, qdot, convective):
    """c_y (n_outputs,): each prescribed output's acceleration at qddot = 0 (module docstring),
    m/s^2 or rad/s^2."""
    xdot = config.DF @ qdot
    result = np.zeros(len(out_ports))
    for row, port in enumerate(out_ports):
        if not port.about_axis:
            result[row] = convective[port.coordinate]
            continue
        euler = list(port.euler)
        _, first, second = rotation_vector_derivatives(config.x[euler], order=2)
        k, rate = AXIS_INDEX[port.axis], xdot[euler]
        result[row] = first[0, k] @ convective[euler] + rate @ second[0, k] @ rate
    return result


def _jacobian(model, config, out_ports):
    """[C; E_k^T] (NDOF, NDOF): the prescribed outputs' rows, then the kinematic inputs'."""
    jacobian = np.zeros((model.declared_dof_count, model.declared_dof_count))
    jacobian[:len(out_ports)] = output_rows(model, config.x, config.DF, out_ports)
    jacobian[len(out_ports) + np.arange(len(model.kinematic_inputs)), model.prescribed_dofs] = 1
    return jacobian


def _positions(model, evaluator, config, out_ports, values, steps, max_iterations, t):
    """The configuration whose outputs and kinematic inputs take `values` (Newton on q)."""
    n_out = len(out_ports)
    for _ in range(max_iterations):
        jacobian = _jacobian(model, config, out_ports)
        current = np.concatenate([[output_value(model, port, config.x) for port in out_ports],
                                  config.q[model.prescribed_dofs]])
        dq = scipy.linalg.lu_solve(_factor(model, jacobian, t), values - current) \
            if current.size else np.zeros(0)
        config = evaluator.solve(config.q + dq, config)
        if within(dq, steps, magnitudes=config.q):
            return config, _jacobian(model, config, out_ports)
    raise ConvergenceError(f"{model.source}: inverse dynamics of {model.name!r} at t = {t:g} s: "
                           f"the positions of the {n_out} prescribed output(s) did not converge "
                           f"in {max_iterations} iterations (beyond the mechanism's reach?)")


def _factor(model, jacobian, t):
    """The LU factors of [C; E_k^T]; ConstraintError where it is singular."""
    if jacobian.size and np.linalg.cond(jacobian) > 1e12:
        raise ConstraintError(f"{model.source}: inverse dynamics of {model.name!r} at "
                              f"t = {t:g} s: the prescribed outputs and kinematic inputs do not "
                              "determine the DOFs (their Jacobian [C; E_k^T] is singular)")
    return scipy.linalg.lu_factor(jacobian)


def _balance(model, evaluator, config, qdot, qddot, M_bar, Q, in_ports, prescribed, t):
    """(forces, efforts, sigma): the force inputs, the kinematic inputs' efforts and every
    stress resultant that balance the motion (module docstring, step 3), from M_bar and Q
    at (config, qdot) (`inverse_evaluation`): DF^T r = Q - M_bar qddot."""
    b = input_columns(model, config.x, in_ports)
    ndof = model.declared_dof_count
    system = np.zeros((ndof, ndof))
    system[:, :b.shape[1]] = config.DF.T @ b
    system[prescribed, b.shape[1] + np.arange(prescribed.size)] = 1.0
    if ndof and np.linalg.cond(system) > 1e12:
        raise ConstraintError(f"{model.source}: inverse dynamics of {model.name!r} at "
                              f"t = {t:g} s: the force inputs cannot balance the motion "
                              "(DF^T b is singular: an input does not act on the DOFs)")
    unknowns = np.linalg.solve(system, M_bar @ qddot - Q) if ndof else np.zeros(0)
    forces, efforts = unknowns[:b.shape[1]], unknowns[b.shape[1]:]
    # the efforts act on DOF rows only, whose multipliers take them: the rigid deformations'
    # resultants need the force inputs alone
    sigma = evaluator.stress_resultants(config, qdot, qddot, b @ forces)
    return forces, efforts, sigma


__all__ = ["InverseDynamics", "inverse_dynamics", "sampled_path"]
