"""A move of other coordinates (an end effector) turned into references for the loops.

A parallel compliant mechanism is driven at its actuators but asked to move something else:
the manipulator's end effector. `move_path` takes the desired displacements of as many target
coordinates as there are loops (e.g. the end effector's x and y, with its height and
rotations held) and gives, along the move's progress s in [0, 1] (the targets at s times
their displacement), the displacement of each loop's output and the static force of each
input that holds the targets there:

- "nonlinear": the inverse statics of the nonlinear model (flexure.core.inverse_statics) at
  `points` values of s, a cubic spline through them: the exact path of the mechanism;
- "linear": the linearised statics at the start, y(s) = s C_yu C_tu^-1 dt with the static
  compliances C_yu (loop outputs per input) and C_tu (targets per input): what a linear model
  predicts, exact only for small moves.

The loops then follow y(s(t)) with s(t) a third-order profile from 0 to 1
(`LoopController(path=...)`), and the feedforward is m y'' + c y' plus, for the nonlinear
path, the static forces along it (for the linear one, k y of the low-frequency model).
Units: m and rad (displacements), N and N m (forces).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .feedback import ControlDesignError, colocated_pairs

KINDS = ("nonlinear", "linear")


@dataclass(frozen=True)
class MovePath:
    """The loops' output displacements (m) and static forces (N) along a move, s in [0, 1]."""

    s: np.ndarray  # (K,) the progress of the points
    displacements: np.ndarray  # (K, n_loops) m, zero at s = 0
    forces: np.ndarray | None  # (K, n_loops) N: the static port forces; None (linear)
    kind: str
    targets: dict  # {coordinate: displacement at s = 1}

    def __post_init__(self):
        from scipy.interpolate import CubicSpline  # for a path only: the loop without one
        # imports neither scipy.interpolate nor scipy.optimize

        _check(self)
        object.__setattr__(self, "_spline", CubicSpline(self.s, self.displacements, axis=0))
        if self.forces is not None:
            object.__setattr__(self, "_force_spline", CubicSpline(self.s, self.forces, axis=0))

    def displacement(self, s, derivative: int = 0) -> np.ndarray:
        """y(s) (m), or its `derivative`-th derivative with respect to s; (len(s), n)."""
        return self._spline(np.clip(np.asarray(s, float), 0.0, 1.0), derivative)

    def static_force(self, s) -> np.ndarray:
        """The input forces (N) that hold the targets at s; (len(s), n). Nonlinear only."""
        return self._force_spline(np.clip(np.asarray(s, float), 0.0, 1.0))

    def to_dict(self) -> dict:
        """The path as JSON-able lists: its knots, not the splines' coefficients.

        Floats survive JSON exactly (Python writes the shortest repr that reads back to the
        same double), and `from_dict` fits the same splines through the same knots, so the
        path read back gives the same displacements and forces bit for bit: the controller
        FMU computes the references and feedforward of the in-process loop.
        """
        return {"s": self.s.tolist(), "displacements": self.displacements.tolist(),
                "forces": None if self.forces is None else self.forces.tolist(),
                "kind": self.kind, "targets": dict(self.targets)}

    @classmethod
    def from_dict(cls, data: dict) -> MovePath:
        """The path of `to_dict`; ControlDesignError names a missing key or a bad shape."""
        missing = [key for key in ("s", "displacements", "kind", "targets") if key not in data]
        if missing:
            raise ControlDesignError(f"move path: the dictionary lacks {missing[0]!r}; "
                                     "expected the keys of MovePath.to_dict()")
        forces = data.get("forces")
        return cls(np.asarray(data["s"], float), np.asarray(data["displacements"], float),
                   None if forces is None else np.asarray(forces, float), data["kind"],
                   dict(data["targets"]))


def _check(path: MovePath) -> None:
    """ControlDesignError unless the path's arrays fit together (expected against found)."""
    s, y = np.asarray(path.s), np.asarray(path.displacements)
    if path.kind not in KINDS:
        raise ControlDesignError(f"move path kind must be one of {', '.join(KINDS)}, got "
                                 f"{path.kind!r}")
    if s.ndim != 1 or s.size < 2 or not np.all(np.diff(s) > 0) or s[0] != 0.0 or s[-1] != 1.0:
        raise ControlDesignError(f"move path: s must rise strictly from 0 to 1, got {s.tolist()}")
    if y.ndim != 2 or y.shape[0] != s.size:
        raise ControlDesignError(f"move path: expected displacements of shape ({s.size}, "
                                 f"n_loops), got {y.shape}")
    if path.forces is not None and np.shape(path.forces) != y.shape:
        raise ControlDesignError(f"move path: expected forces of shape {y.shape}, got "
                                 f"{np.shape(path.forces)}")


def move_targets(model, targets: dict):
    """The loops of a move of `targets` {coordinate: displacement (m or rad)}, the targets'
    names and displacements: (pairs, names, delta (n_loops,)).

    Raises
    ------
    ControlDesignError
        Not one target per loop.
    """
    pairs = colocated_pairs(model)
    if len(targets) != len(pairs):
        raise ControlDesignError(f"{model.name}: {len(targets)} target(s) for {len(pairs)} "
                                 "loop(s); a move needs one target coordinate per loop")
    names = list(targets)
    return pairs, names, np.array([float(targets[name]) for name in names])


def target_port(model, name: str):
    """The position output of a move's target `name`: a coordinate, or an angle about a global
    axis of a 3-D rotational node ("Pr.rz").

    Raises
    ------
    ControlDesignError
        No such coordinate or axis (naming the scene and the target).
    """
    from flexure.core import position_port

    try:
        return position_port(model, name)
    except KeyError as error:
        raise ControlDesignError(f"{model.source}: move target: {error.args[0]}") from None


def move_path(model, targets: dict, *, kind: str = "nonlinear", points: int = 11,
              progress=None) -> MovePath:
    """The loops' path for moving `targets` {coordinate: displacement (m or rad)}.

    Parameters
    ----------
    model : Model
    targets : dict
        One displacement per loop (input), of the coordinates "NODE.AXIS" to move, or of
        angles about a global axis of 3-D rotational nodes ("Pr.rz"); a held one has
        displacement 0.
    kind : "nonlinear" or "linear"
    points : int
        The number of points of the nonlinear path (its spline's knots), s = 0 .. 1.
    progress : callable, optional
        Called with the fraction of the points done.
    """
    from flexure.core import (  # the models on first use
        input_columns,
        inverse_statics,
        linearize,
        output_rows,
        output_value,
        static_equilibrium,
        steady_port_values,
        steady_slopes,
    )

    if kind not in KINDS:
        raise ControlDesignError(f"move path kind must be one of {', '.join(KINDS)}, got "
                                 f"{kind!r}")
    pairs, names, delta = move_targets(model, targets)
    if kind == "nonlinear" and points < 4:
        raise ControlDesignError(f"a nonlinear move path needs at least 4 points, got {points}")
    inputs = [pair.input_name for pair in pairs]
    outputs = [model.outputs[pair.output_index] for pair in pairs]
    target_ports = [target_port(model, name) for name in names]
    # the move starts where the mechanism rests under its loads, the inputs at zero
    rest = static_equilibrium(model)
    if kind == "linear":
        lin = linearize(model, rest)
        columns = input_columns(model, rest.x, [model.inputs[p.input_index] for p in pairs])
        # per unit drive signal where an actuator drives the input
        columns = columns * steady_slopes(model, np.zeros(len(model.inputs)))[
            [p.input_index for p in pairs]]
        response = np.linalg.solve(lin.K, lin.DF.T @ columns)  # dq per unit input
        c_yu = output_rows(model, rest.x, lin.DF, outputs) @ response
        c_tu = output_rows(model, rest.x, lin.DF, target_ports) @ response
        end = c_yu @ np.linalg.solve(c_tu, delta)
        # a straight line: the spline through three collinear points is the line itself
        s_values = np.array([0.0, 0.5, 1.0])
        return MovePath(s_values, np.outer(s_values, end), None, kind, dict(targets))
    start_values = np.array([output_value(model, port, rest.x) for port in target_ports])
    s_values = np.linspace(0.0, 1.0, points)
    displacements, forces = [], []
    point, previous = None, None
    for j, s in enumerate(s_values):
        wanted = dict(zip(names, start_values + s * delta, strict=True))
        # Newton on the forces from the line through the last two points' forces (the
        # points are equally spaced in s): one equilibrium and linearisation fewer a point
        initial = None if previous is None else 2.0 * point.forces - previous.forces
        previous, point = point, inverse_statics(model, wanted, inputs=inputs, start=point,
                                                 initial=initial)
        displacements.append([output_value(model, port, point.solution.x)
                              - output_value(model, port, rest.x) for port in outputs])
        # the static forces (N, N m) on the ports, an actuator's drive signal turned into its
        # steady force
        held = np.zeros(len(model.inputs))
        held[[p.input_index for p in pairs]] = point.forces
        forces.append(steady_port_values(model, held)[[p.input_index for p in pairs]])
        if progress is not None:
            progress((j + 1) / len(s_values))
    return MovePath(s_values, np.array(displacements), np.array(forces), kind, dict(targets))
