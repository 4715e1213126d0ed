"""The stroke as a sweep axis: range-of-motion studies over the workspace.

    flexure sweep stage_planar_1dof --param stroke.3.x=-5e-3:5e-3:11 --analyses static,modes,stress

A parameter `stroke.NODE.AXIS` (a coordinate, "3.x", or the angle about a global axis of a
3-D rotational node, "Pr.rz") is a displacement from the scene's configuration, m or rad. At
each point the inputs' forces that put every stroke target there are found by inverse statics
(`analysis.inverse_statics`: Newton on the forces, each iterate a static equilibrium under the
scene's loads plus the forces), and the point's analyses run at that equilibrium: the static
displacements, the natural frequencies of the linearisation there (its geometric stiffness
included), the largest von Mises stress. The point gains, per stroke target and the input
that drives it (in order: the first stroke with the first input, ...):

- `force.INPUT [N]` (N m for a moment, V for an actuator's drive signal): the force held;
- `stiffness.TARGET [N/m]` (N m/rad, ...): the tangent stiffness the stroke meets there, the
  diagonal of (d x_t / d u)^-1, the inverse of the compliance between inputs and targets
  with the other targets held.

The inputs: the scene's, or `--stroke-inputs NAME,...`; as many as stroke targets (a target
swept over one value is held there). The base scene's value of every other key applies.
"""

from __future__ import annotations

import numpy as np

from ..errors import UsageError

__all__ = ["PREFIX", "check_strokes", "split_strokes", "stroke_columns", "stroke_point"]

PREFIX = "stroke."


def split_strokes(overrides: dict) -> tuple[dict, dict]:
    """(scene overrides, {target "NODE.AXIS": stroke}) of a point's {key: value}."""
    strokes = {k.removeprefix(PREFIX): v for k, v in overrides.items() if k.startswith(PREFIX)}
    return {k: v for k, v in overrides.items() if not k.startswith(PREFIX)}, strokes


def stroke_inputs(model, targets, inputs=None) -> list[str]:
    """The names of the inputs that drive the `targets`; UsageError where they do not fit."""
    names = [port.name for port in model.inputs] if inputs is None else list(inputs)
    unknown = [name for name in names if name not in [p.name for p in model.inputs]]
    if unknown:
        raise UsageError(f"--stroke-inputs: no input named {', '.join(unknown)}; the scene's "
                         f"inputs are {', '.join(p.name for p in model.inputs) or 'none'}")
    if len(names) != len(targets):
        what = ("hold another coordinate where it is (--param stroke.NODE.AXIS=0) or choose "
                "fewer inputs with --stroke-inputs NAME,..." if len(targets) < len(names) else
                "sweep fewer targets, or drive them with more inputs")
        raise UsageError(
            f"--param {', '.join(PREFIX + t for t in targets)}: {len(targets)} stroke "
            f"target(s) for {len(names)} input(s) ({', '.join(names) or 'none'}): inverse "
            f"statics needs as many; {what}")
    return names


def check_strokes(model, targets, inputs=None) -> list[str]:
    """Check the stroke targets and their inputs on the base model before a sweep: every
    target a coordinate or a global angle, the inputs as many; the inputs' names. UsageError
    naming the --param otherwise."""
    from ..mechanics.ports import position_port

    for target in targets:
        try:
            position_port(model, target)
        except KeyError as error:
            raise UsageError(f"--param {PREFIX}{target}: {error.args[0]}; a stroke target is "
                             "NODE.AXIS, a coordinate (3.x) or a global angle (Pr.rz)") from None
    return stroke_inputs(model, targets, inputs)


def stroke_columns(model, targets, inputs=None) -> list[str]:
    """The columns a stroke adds: force.INPUT and stiffness.TARGET with their units."""
    from ..mechanics.ports import position_port

    names = stroke_inputs(model, targets, inputs)
    units = {port.name: port.unit for port in model.inputs}
    forces = [f"force.{name} [{units[name]}]" for name in names]
    stiffness = []
    for target, name in zip(targets, names, strict=True):
        length = position_port(model, target).unit
        stiffness.append(f"stiffness.{target} [{units[name]}/{length}]")
    return forces + stiffness


def stroke_point(model, strokes: dict, inputs=None, mechanics=None):
    """(the equilibrium, {column: value}, the inputs' forces {name: value}) at the strokes
    {target: displacement} (module docstring); ConvergenceError where inverse statics fails
    (a stroke beyond what the inputs reach)."""
    from ..analysis.inverse_statics import inverse_statics, target_compliance
    from ..mechanics.ports import output_value, position_port

    targets = list(strokes)
    names = stroke_inputs(model, targets, inputs)
    ports = [position_port(model, target) for target in targets]
    at_rest = [output_value(model, port, model.initial_coordinates) for port in ports]
    wanted = {t: base + float(strokes[t]) for t, base in zip(targets, at_rest, strict=True)}
    found = inverse_statics(model, wanted, inputs=names)
    held = dict.fromkeys((p.name for p in model.inputs), 0.0)
    held |= dict(zip(names, found.forces.tolist(), strict=True))
    compliance, _ = target_compliance(model, found.solution, ports, names, held,
                                      mechanics=mechanics)
    stiffness = np.diag(np.linalg.inv(compliance))
    columns = stroke_columns(model, targets, inputs)
    values = [*found.forces.tolist(), *stiffness.tolist()]
    return found.solution, dict(zip(columns, map(float, values), strict=True)), held
