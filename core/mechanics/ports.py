"""The maths of a model's inputs and outputs (`Port`), in plain numpy.

A port on one coordinate c (SPACAR's INPUTF / OUTX) is linear: an input u puts the force u on
x_c (N, or N m on a planar angle), an output reads x_c or a rate of it (m, rad; m/s, rad/s;
...: each quantity, its order and its units are `flexure.core.mechanics.output_quantities`).

A port about a global axis k of a 3-D rotational node (Euler parameters lambda, see
`flexure.core.numerics.rotations`) is not:

- a moment input u (N m) about axis k, fixed in space, has the generalised force on lambda

      f = 2 u E_k(lambda)^T,          omega = 2 E(lambda) lambda_dot  (global frame),

  from its virtual work u delta theta_k = u (2 E_k delta lambda): its power f . lambda_dot =
  u omega_k is that of a moment on the angular velocity. E is linear in lambda
  (E_k,a = P_kab lambda_b, `rotations.RATES_TENSOR`), so f has the constant derivative
  df / dlambda = 2 u P_k, the load stiffness of a moment whose axis does not turn with the
  node (not symmetric: such a moment is not conservative in 3-D);
- an angle output is phi_k(lambda), the rotation-vector component about axis k (rad), with the
  gradient d phi_k / d lambda (`rotations.rotation_vector_derivatives`); its velocity output is
  the angular velocity omega_k = 2 E_k lambda_dot (rad/s), the rate a gyroscope measures and
  the power conjugate of the moment input about the same axis. omega_k equals d phi_k / dt
  about the unrotated orientation (d phi / d lambda = 2 E there) and for any rotation about
  axis k alone; otherwise they differ by d phi / d theta = I + [phi x] / 2 + O(phi^2). A rate
  of higher order r is 2 E_k times the r-th rate of lambda (`output_quantities`).

Linearised at a configuration x the state space takes B = DF^T f / u and C = (d y / d x) DF
from `input_direction` and `output_gradient`. The compiled twins are in
`flexure.core.engine.ports`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SceneError
from ..numerics.rotations import RATES_TENSOR, global_rates_matrix, rotation_vector_derivatives
from .output_quantities import QUANTITIES, output_order

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..model import Model, Port

AXIS_INDEX = {"rx": 0, "ry": 1, "rz": 2}


def input_values(model: Model, inputs: Mapping[str, float] | ArrayLike) -> np.ndarray:
    """The model's inputs as an array, from a dict by name or a sequence.

    Parameters
    ----------
    model : Model
    inputs : dict of str to float or array_like (n_inputs,)
        {name: value} (the others zero) or the values in the model's order: N, N m for a
        force or moment, V for an actuator's drive signal.

    Returns
    -------
    ndarray (n_inputs,)
        The inputs in the model's order, in the same units.

    Raises
    ------
    SceneError
        An unknown input name, a wrong length, or a value that is not finite.
    """
    return named_values(model, inputs, [port.name for port in model.inputs], "input",
                        np.zeros(len(model.inputs)))


def named_values(model: Model, given, names: list[str], what: str,
                 defaults: np.ndarray) -> np.ndarray:
    """The values of the ports `names`, in their order, from `given`: a mapping {name: value}
    (the others at `defaults`) or every value in order (array_like); a SceneError naming the
    model's file for an unknown name (listing `names`), a wrong length or a value that is
    not finite. `what` names the ports in those messages ("input", "kinematic input")."""
    if isinstance(given, Mapping):
        values = np.array(defaults, dtype=float)
        for name, value in given.items():
            if name not in names:
                raise SceneError(f"{model.source}: unknown {what} {name!r}; the model "
                                 f"{model.name!r} has {what}s: {', '.join(names) or '(none)'}")
            values[names.index(name)] = value
    else:
        values = np.array(given, dtype=float).reshape(-1)
        if values.size != len(names):
            raise SceneError(f"{model.source}: expected {len(names)} {what}s "
                             f"({', '.join(names) or 'none'}), got {values.size}")
    if not np.all(np.isfinite(values)):
        raise SceneError(f"{model.source}: the {what}s must be finite, got {values.tolist()}")
    return values


def input_direction(model, port, x):
    """The generalised force (NX,) of a unit input `port` at coordinates x: a unit force on its
    coordinate, or 2 E_k(lambda)^T on the Euler parameters of a moment about axis k."""
    f = np.zeros(model.nx)
    if port.about_axis:
        f[list(port.euler)] = 2.0 * global_rates_matrix(x[list(port.euler)])[
            AXIS_INDEX[port.axis]]
    else:
        f[port.coordinate] = 1.0
    return f


def input_forces(model, x, u):
    """The generalised force (NX,) of the inputs u (n_inputs,) N, N m at coordinates x."""
    force = np.zeros(model.nx)
    for port, value in zip(model.inputs, np.atleast_1d(u), strict=True):
        if port.about_axis:
            force += value * input_direction(model, port, x)
        else:
            force[port.coordinate] += value
    return force


def input_stiffness(model, x, u):
    """d f / d x (NX, NX) of `input_forces`: 2 u P_k on the Euler parameters of each moment
    input (zero for the forces on coordinates, which do not depend on x)."""
    H = np.zeros((model.nx, model.nx))
    for port, value in zip(model.inputs, np.atleast_1d(u), strict=True):
        if port.about_axis and value != 0.0:
            H[np.ix_(port.euler, port.euler)] += 2.0 * value * RATES_TENSOR[
                AXIS_INDEX[port.axis]]
    return H


def position_port(model: Model, name: str) -> Port:
    """The position output that reads "NODE.AXIS": a coordinate ("3.x", "4.phi"), or the
    angle about a global axis of a 3-D rotational node ("Pr.rz", rad), whose coordinates are
    Euler parameters.

    Parameters
    ----------
    model : Model
    name : str
        "NODE.AXIS": a coordinate's name, or a 3-D rotational node's name with "rx", "ry" or
        "rz".

    Returns
    -------
    Port
        A position output (m or rad): its value is `output_value`, its row in dq
        `output_rows`.

    Raises
    ------
    KeyError
        The model has no such coordinate or rotational node (the message names it).
    """
    from ..model import GLOBAL_ROTATIONS, Port

    node, _, axis = name.rpartition(".")
    euler = [n for n in model.nodes if n.name == node and n.axes and
             n.axes[0] == "lambda0"] if axis in GLOBAL_ROTATIONS else []
    if euler:
        return Port(name, None, "position", "rad", euler=tuple(euler[0].coordinates), axis=axis)
    index = model.coordinate_index(name)  # KeyError naming it
    unit = "m" if model.coordinate_axis[index] in ("x", "y", "z") else "rad"
    return Port(name, index, "position", unit)


def output_value(model: Model, port: Port, x: np.ndarray, *rates: np.ndarray) -> float:
    """The value of an output on a node: x_c or its r-th rate; phi_k, or 2 E_k times the r-th
    rate of lambda about a global axis k (omega_k for r = 1), r the order of the output's
    quantity (`output_quantities`).

    Parameters
    ----------
    model : Model
    port : Port
        One of the model's outputs on nodes.
    x : ndarray (NX,)
        The coordinates, m and rad (Euler parameters unitless).
    *rates : ndarray (NX,)
        Their rates, first xdot (m/s, rad/s, 1/s), then the higher ones, up to the order
        the output's quantity reads (a velocity needs xdot).

    Returns
    -------
    float
        In the port's unit (m or rad, m/s or rad/s, ...).

    Raises
    ------
    ValueError
        An output without the rate its quantity reads.
    """
    quantity = QUANTITIES[port.quantity]
    if quantity.order and (len(rates) < quantity.order or rates[quantity.order - 1] is None):
        raise ValueError(f"output {port.name!r} is a {port.quantity}: it needs "
                         f"{quantity.needs}")
    rates = (x, *rates)[quantity.order]
    if not port.about_axis:
        return float(rates[port.coordinate])
    lam = x[list(port.euler)]
    k = AXIS_INDEX[port.axis]
    if quantity.order:  # omega_k, alpha_k: 2 E_k times the rate of lambda (module docstring)
        return float(2.0 * global_rates_matrix(lam)[k] @ rates[list(port.euler)])
    return float(rotation_vector_derivatives(lam, order=0)[0][0, k])


def output_gradient(model, port, x):
    """d y / d x (NX,) of a position output at x, or of a rate output d y / d (its rate of x)
    (a rate output is linear in it: `output_quantities`): a unit row on the coordinate;
    d phi_k / d lambda or 2 E_k on the Euler parameters of a rotation about axis k."""
    row = np.zeros(model.nx)
    if not port.about_axis:
        row[port.coordinate] = 1.0
        return row
    lam = x[list(port.euler)]
    k = AXIS_INDEX[port.axis]
    if output_order(port):
        row[list(port.euler)] = 2.0 * global_rates_matrix(lam)[k]
    else:
        row[list(port.euler)] = rotation_vector_derivatives(lam, order=1)[1][0, k]
    return row


def output_rows(model: Model, x: np.ndarray, DF: np.ndarray,
                ports: Sequence[Port] | None = None) -> np.ndarray:
    """C = d y / d q of the outputs at a configuration; position and rate outputs alike (a
    velocity output's row multiplies qdot, a higher rate's that rate of q: the state space
    maps it, `flexure.core.analysis.statespace`).

    Parameters
    ----------
    model : Model
    x : ndarray (NX,)
        The coordinates, m and rad (Euler parameters unitless).
    DF : ndarray (NX, NDOF)
        The first-order transfer function dx/dq at x.
    ports : sequence of Port, optional
        The outputs (default: the model's).

    Returns
    -------
    ndarray (n_ports, NDOF)
        The output per unit DOF: m/m, m/rad, rad/m or rad/rad (the same for their rates).
    """
    ports = model.outputs if ports is None else ports
    C = np.zeros((len(ports), DF.shape[1]))
    for row, port in enumerate(ports):
        if port.about_axis:
            euler = list(port.euler)
            C[row] = output_gradient(model, port, x)[euler] @ DF[euler]
        else:
            C[row] = DF[port.coordinate]
    return C


def output_dofs(model, ports=None):
    """int64 (n_ports,): the DOF index of each position output that is itself a DOF (a
    coordinate DOF: the output is then q_j exactly, with no kinematics to solve), else -1."""
    ports = model.outputs if ports is None else ports
    where = {int(c): j for j, c in enumerate(model.dof_coordinates)}
    return np.array([where.get(port.coordinate, -1) if not port.about_axis
                     and output_order(port) == 0 else -1 for port in ports],
                    dtype=np.int64)


def input_columns(model: Model, x: np.ndarray,
                  ports: Sequence[Port] | None = None) -> np.ndarray:
    """b: the generalised force of a unit value of each input at coordinates x
    (`input_direction`).

    Parameters
    ----------
    model : Model
    x : ndarray (NX,)
        The coordinates, m and rad (Euler parameters unitless); a moment's column depends on
        its node's orientation.
    ports : sequence of Port, optional
        The inputs (default: the model's).

    Returns
    -------
    ndarray (NX, n_ports)
        Unitless: a unit force (per N) on a coordinate, or 2 E_k(lambda)^T (per N m) on the
        Euler parameters of a moment about axis k.
    """
    ports = model.inputs if ports is None else ports
    b = np.zeros((model.nx, len(ports)))
    for column, port in enumerate(ports):
        b[:, column] = input_direction(model, port, x)
    return b


def port_description(model: Model, port: Port, *, is_input: bool) -> str:
    """What a port is, in words (the FMU's variable descriptions).

    Parameters
    ----------
    model : Model
    port : Port
        One of the model's inputs or outputs (its outputs on elements too).
    is_input : bool
        Whether `port` is an input (a force or moment) or an output (a quantity of
        `output_quantities`).

    Returns
    -------
    str
        E.g. "force on coordinate 3.x", "moment about the global z axis on node 4",
        "stress resultant of leaf_left.e2".
    """
    if port.deformation is not None:  # an output on an element (SPACAR's OUTE, OUTF)
        what = "deformation" if port.quantity == "deformation" else "stress resultant"
        return f"{what} of {model.deformation_names[port.deformation]}"
    if port.about_axis:
        node = model.coordinate_node[port.euler[0]]
        axis = port.axis[1]
        if is_input:
            return f"moment about the global {axis} axis on node {node}"
        words = QUANTITIES[port.quantity].rotation_words
        if output_order(port):
            return f"{words} about the global {axis} axis of node {node}"
        return f"{words} about the global {axis} axis of node {node} (rotation vector component)"
    preposition = "on" if is_input else "of"
    return f"{port.quantity} {preposition} coordinate {model.coordinate_names[port.coordinate]}"


__all__ = ["AXIS_INDEX", "input_columns", "input_direction", "input_forces",
           "input_stiffness", "input_values", "output_gradient", "output_rows", "output_value",
           "port_description"]
