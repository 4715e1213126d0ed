"""What an output on a node reads: the one table of its quantities (`QUANTITIES`).

An output on a coordinate c reads the coordinate's time derivative of some order,

    order 0: x_c (m, rad),  order 1: xdot_c (m/s, rad/s),  order 2: xddot_c (m/s2, rad/s2),

and an output about a global axis k of a 3-D rotational node (Euler parameters lambda) reads
the angle phi_k (order 0, the rotation-vector component) or the angular velocity and
acceleration in the global frame,

    omega_k = 2 E_k(lambda) lambda_dot,   alpha_k = d omega_k / dt = 2 E_k(lambda) lambda_ddot,

the last because E is linear in lambda and E(lambda_dot) lambda_dot = 0 (each row of E is
orthogonal to its argument), so the term 2 E_k(lambda_dot) lambda_dot of the product rule
vanishes. An order-r output is therefore linear in the r-th derivative of the coordinates,
with the same gradient for every r >= 1 (`flexure.core.mechanics.ports.output_gradient`).

Everything that interprets a node output's quantity reads this table: the scene reader (its
names and units), the port maths (`ports`: value, gradient, description), the simulation's
outputs (`flexure.core.simulation.simulator_outputs`: what of the state each order needs), the
state space (`flexure.core.analysis.statespace`, `motion_statespace`: the row of each order)
and the FMU (its unit definitions). docs/extending.md ("A port quantity") says what a new row
needs.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class OutputQuantity:
    """One quantity an output on a node may read.

    Attributes
    ----------
    name : str
        The scene's `quantity` ("position", "velocity", "acceleration").
    order : int
        The time derivative of the coordinate it reads: 0, 1 or 2.
    unit, rotation_unit : str
        Its unit on a translation and on a rotation (a planar angle or a rotation about a
        global axis), as FMI writes units ("m/s2").
    rotation_words : str
        What it is about a global axis, for the FMU's descriptions ("angular velocity").
    needs : str
        What of the state `ports.output_value` needs besides x ("" for none), named in the
        error when it is missing.
    """

    name: str
    order: int
    unit: str
    rotation_unit: str
    rotation_words: str
    needs: str


QUANTITIES = {quantity.name: quantity for quantity in (
    OutputQuantity("position", 0, "m", "rad", "rotation", ""),
    OutputQuantity("velocity", 1, "m/s", "rad/s", "angular velocity", "the velocities xdot"),
    OutputQuantity("acceleration", 2, "m/s2", "rad/s2", "angular acceleration",
                   "the velocities xdot and the accelerations xddot"),
)}


def output_order(port) -> int:
    """The time derivative (0, 1, 2) of the coordinates an output on a node reads; -1 for an
    output on an element (a deformation or a stress) or an input."""
    quantity = QUANTITIES.get(port.quantity)
    return -1 if quantity is None or port.deformation is not None else quantity.order


def quantity_unit(quantity: str, *, rotation: bool) -> str:
    """The unit of a node output's quantity: on a translation (m, m/s, m/s2) or on a rotation
    (rad, rad/s, rad/s2)."""
    entry = QUANTITIES[quantity]
    return entry.rotation_unit if rotation else entry.unit


__all__ = ["QUANTITIES", "OutputQuantity", "output_order", "quantity_unit"]
