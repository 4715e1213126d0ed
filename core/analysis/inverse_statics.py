"""Inverse statics: the input forces that hold chosen coordinates at chosen values.

A compliant mechanism has no separate kinematics: where its actuators must be to put the end
effector somewhere follows from its static equilibrium. For n inputs (forces u, N or N m, on
their coordinates) and n target coordinates x_t with desired values x_t*, find u with

    x_t(u) = x_t*,   x(u) the static equilibrium under the scene's loads plus the inputs u

by Newton's method on u. Its Jacobian is the static compliance between the inputs and the
targets at the current equilibrium,

    d x_t / d u = DF_t K^-1 DF_u^T          (K = K0 + G0, the tangent stiffness on the DOFs)

(DF_t the rows of DF = dx/dq of the targets, DF_u^T the generalised forces of unit inputs: a
force on its coordinate, a moment about a global axis on its node's Euler parameters), so the
iteration
converges quadratically; it stops when every target is within `tolerance` of its own unit
(a position of the model's length scale L, an angle of 1 rad; `mechanics.scales`). The
solution also gives every other coordinate there, e.g. the actuator positions that put the
end effector at a pose: the nonlinear inverse kinematics of the mechanism, with its
nonlinear statics (the forces) for free.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConvergenceError, FlexureError
from ..mechanics.actuators import steady_slopes
from ..mechanics.mechanics import Mechanics
from ..mechanics.ports import input_columns, output_rows, output_value, position_port
from ..mechanics.scales import ROUND_OFF, coordinate_units
from ..model import Model
from ..numerics.blas import blas_threads
from .linearization import linearize
from .statics import StaticSolution, static_equilibrium

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike


class InverseStaticsError(FlexureError, ValueError):
    """Inverse statics was asked for with targets or inputs that do not fit the model."""


@dataclass(frozen=True)
class InverseStatics:
    """The forces that hold the targets, and the equilibrium they give."""

    forces: np.ndarray  # (n,) N or N m (V for an actuator's drive signal), one per input
    solution: StaticSolution
    iterations: int
    residual: float  # the largest |x_t - x_t*| at the solution, m or rad

    def coordinate(self, name: str) -> float:
        """The value of one coordinate at the solution.

        Parameters
        ----------
        name : str
            The coordinate, "NODE.AXIS" ("3.x", "4.phi"), or an angle about a global axis
            of a 3-D rotational node ("Pr.rz").

        Returns
        -------
        float
            Its value, m or rad (an Euler parameter: unitless).

        Raises
        ------
        KeyError
            The model has no such coordinate.
        """
        model = self.solution.model
        return output_value(model, position_port(model, name), self.solution.x)


def _ports(model, names, what):
    """The position outputs (`position_port`) that read the coordinates or angles `names`."""
    try:
        return [position_port(model, name) for name in names]
    except KeyError as error:
        raise InverseStaticsError(f"{model.source}: {what}: {error.args[0]}") from None


def target_compliance(model: Model, solution: StaticSolution, target_ports: list,
                      names: Sequence[str], held: dict[str, float], *,
                      mechanics: Mechanics | None = None) -> tuple[np.ndarray, float]:
    """The static compliance between inputs and targets at an equilibrium (module docstring).

    Parameters
    ----------
    model : Model
    solution : StaticSolution
        The equilibrium (under the inputs `held`).
    target_ports : list of Port
        The targets' position outputs (`position_port`).
    names : sequence of str
        The inputs whose forces move them.
    held : dict of str to float
        Every input's force at the equilibrium (N, N m, or V for a drive signal).
    mechanics : Mechanics, optional
        The model's Mechanics (made when not given).

    Returns
    -------
    (ndarray, float)
        d x_t / d u (n_targets, n_inputs), m/N or rad/(N m); and the 2-norm of the inputs'
        own compliance, the scale against which the targets' one is singular.
    """
    lin = linearize(model, solution, mechanics=mechanics or Mechanics(model))
    DF = lin.DF
    ports = [port.name for port in model.inputs]
    order = [ports.index(name) for name in names]  # the inputs' places in the model
    # the generalised forces of unit inputs (a moment's depends on the orientation)
    b = input_columns(model, solution.x, [model.inputs[i] for i in order])
    # an actuated input is its drive signal: its steady force per unit of it (Km/R ...)
    b = b * steady_slopes(model, np.array([held.get(p, 0.0) for p in ports]))[order]
    response = np.linalg.solve(lin.K, DF.T @ b)  # dq per unit input
    compliance = output_rows(model, solution.x, DF, target_ports) @ response
    # the inputs' own compliance (work-conjugate: m/N, rad/(N m)) sets the scale of
    # "cannot move": the targets' must not be smaller by the round-off of the solve
    own = float(np.linalg.norm((DF.T @ b).T @ response, 2))
    return compliance, own


@blas_threads()
def inverse_statics(model: Model, targets: dict[str, float], *,
                    inputs: Sequence[str] | None = None,
                    initial: ArrayLike | None = None, start: InverseStatics | None = None,
                    tolerance: float = 1e-10, max_iterations: int = 20) -> InverseStatics:
    """The input forces that put the `targets` coordinates at their values at equilibrium
    (for an input an actuator drives: its drive signal, at the actuator's steady state).

    Parameters
    ----------
    model : Model
    targets : dict of str to float
        {"NODE.AXIS": value (m or rad)}, as many as there are inputs used: a coordinate
        ("3.x"), or the angle about a global axis of a 3-D rotational node ("Pr.rz",
        `position_port`).
    inputs : sequence of str, optional
        The names of the inputs to use (default: all of the model's inputs).
    initial : array_like, optional
        The forces (n,) to start Newton from: N, N m, or V for an actuator's drive signal
        (default: zero, or those of `start`).
    start : InverseStatics, optional
        The solution for neighbouring targets (a previous point along a path): Newton starts
        from its forces and each equilibrium from its configuration.
    tolerance : float
        The largest allowed |x_t - x_t*| relative to the target's unit: tolerance L (m) for
        a position, tolerance (rad) for an angle (`mechanics.scales.coordinate_units`).
    max_iterations : int
        Newton iterations on the forces before ConvergenceError.

    Returns
    -------
    InverseStatics
        The forces (N, N m or V, in the order of `inputs`), the equilibrium they give, the
        iterations taken and the largest target error (m or rad).

    Raises
    ------
    InverseStaticsError
        An unknown input or target name, a count of targets or initial forces that does not
        match the inputs, or a target that is not finite.
    ConvergenceError
        Newton does not converge, or the compliance between inputs and targets is singular
        (the inputs cannot move the targets independently).
    """
    ports = {port.name: port for port in model.inputs}
    names = list(ports) if inputs is None else list(inputs)
    unknown = [name for name in names if name not in ports]
    if unknown:
        raise InverseStaticsError(f"{model.source}: no input named {', '.join(unknown)}; the "
                                  f"model's inputs are {', '.join(ports) or 'none'}")
    if len(targets) != len(names):
        raise InverseStaticsError(f"{model.source}: {len(targets)} target(s) for {len(names)} "
                                  "input(s): inverse statics needs as many targets as inputs")
    target_ports = _ports(model, targets, "target")
    wanted = np.array([float(v) for v in targets.values()])
    if not np.all(np.isfinite(wanted)):
        raise InverseStaticsError(f"{model.source}: every target value must be finite")
    if initial is None:
        initial = start.forces if start is not None else np.zeros(len(names))
    u = np.array(initial, float).reshape(-1)
    if u.size != len(names):
        raise InverseStaticsError(f"initial: expected {len(names)} forces, got {u.size}")
    mech = Mechanics(model)
    units, magnitudes = coordinate_units(model)
    # an angle about a global axis (no coordinate of its own) is in rad, of order 1
    unit = np.array([1.0 if p.coordinate is None else units[p.coordinate] for p in target_ports])
    size = np.array([1.0 if p.coordinate is None else magnitudes[p.coordinate]
                     for p in target_ports])
    allowed = np.maximum(tolerance * unit, ROUND_OFF * size)
    residual = np.inf
    solution = None if start is None else start.solution
    for iteration in range(1, max_iterations + 1):
        held = dict.fromkeys(ports, 0.0) | dict(zip(names, u.tolist(), strict=True))
        solution = static_equilibrium(model, inputs=held, mechanics=mech, start=solution)
        error = np.array([output_value(model, port, solution.x)
                          for port in target_ports]) - wanted
        residual = float(np.max(np.abs(error)))
        if np.all(np.abs(error) <= allowed):
            return InverseStatics(u, solution, iteration, residual)
        compliance, own = target_compliance(model, solution, target_ports, names, held,
                                            mechanics=mech)
        smallest = np.linalg.svd(compliance, compute_uv=False)[-1]
        if not smallest > 1e-9 * own:
            raise ConvergenceError(
                f"{model.source}: the inputs {', '.join(names)} cannot move the targets "
                f"{', '.join(targets)} independently (their compliance is singular)")
        du = np.linalg.solve(compliance, error)
        u = u - du
    raise ConvergenceError(f"{model.source}: inverse statics did not converge in "
                           f"{max_iterations} iterations (largest target error "
                           f"{residual:.3e}, allowed {np.min(allowed):.1e})")
