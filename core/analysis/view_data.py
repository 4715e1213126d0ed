"""The data of an interactive view of a model (`flexure view`): the picture of `pictures`
(every element's centre line, the translational nodes) as plain arrays, and each shape to
show on it as a displacement field of those points.

The points: every drawn element's centre line (`pictures.centre_lines`: a beam the Hermite
curve its mass interpolates, a truss straight) at `pictures.POINTS` points, all lines in one
array (P, dimension) m with a row of NaN after each line (a gap between lines, as plotly
draws one trace of many lines), and the translational nodes (n, dimension) m.

A shape is drawn about a base configuration (the scene's initial coordinates, or the static
equilibrium the modes are computed at) as

    points(m, a) = base + m a D,

m the magnification the page's slider sets, a the amplitude of the frame (sin(2 pi phase) of
a mode's animation, 1 otherwise), D (frames, P, dimension) the displacement of the points per
unit magnification. D is the picture's own: at the shape's default magnification m0
(`pictures.displacement_scale`, the largest displacement drawn as 10 % of the model's size),

    D = (centre_lines(scaled(x_base, u, m0)) - centre_lines(x_base)) / m0,

so at m = m0 the page draws exactly what `flexure analyze --plot-shape / --plot-modes` draw;
at any other m the points move linearly along it (as a mode shape is drawn by any finite
element program; a large rotation magnified further is drawn stretched, not turned).

This module lives in analysis/ beside `pictures`: it evaluates the elements' interpolation
and runs the analyses (statics, modes, the kinematics of a trajectory); `reporting.html_view`
turns its arrays into the page.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .pictures import (
    MAX_FRAMES,
    POINTS,
    STILL,
    centre_lines,
    coordinates_along,
    displacement_scale,
    drawn_elements,
    frame_indices,
    largest_displacement,
    model_size,
    node_positions,
    require_drawable,
    scaled,
)

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

INITIAL, EQUILIBRIUM = "initial", "equilibrium"  # the base configurations a shape is drawn about


@dataclass
class Configuration:
    """The picture at one set of coordinates: `lines` (P, dimension) m, the centre lines with
    a NaN row after each; `nodes` (n, dimension) m, the translational nodes."""

    lines: np.ndarray
    nodes: np.ndarray


@dataclass
class ViewShape:
    """One shape the page shows: a static deflection, a mode, or a simulated motion.

    kind : "static", "mode" or "simulation"
    label : the entry of the page's menu; title : the line above the plot
    base : the configuration it is drawn about (INITIAL or EQUILIBRIUM)
    magnification : the default magnification m0 (1 for a shape without motion)
    largest : the largest displacement (m) at unit magnification (`pictures.largest_displacement`)
    line_fields, node_fields : (frames, P, dimension), (frames, n, dimension) the displacement
        of the points per unit magnification (m); one frame but for a simulation
    times : (frames,) s, the simulated time of each frame (a simulation only)
    frequency_hz : the natural frequency (a mode only)
    """

    kind: str
    label: str
    title: str
    base: str
    magnification: float
    largest: float
    line_fields: np.ndarray
    node_fields: np.ndarray
    times: np.ndarray | None = None
    frequency_hz: float | None = None


@dataclass
class ViewData:
    """Everything the page draws, SI units (module docstring).

    name, dimension : the model's; size : its largest extent (m) at the initial coordinates
    configurations : {INITIAL or EQUILIBRIUM: Configuration}
    point_elements : (P,) the element each line point belongs to ("" on the gaps), for hover
    node_names, node_text : the translational nodes' names and hover texts
    fixed_nodes : indices into the nodes of those with a fixed coordinate (or whose rotational
        node has one); fixed_text : what is fixed there
    shapes : the shapes, in the page's menu order
    """

    name: str
    dimension: int
    size: float
    configurations: dict
    point_elements: list
    node_names: list
    node_text: list
    fixed_nodes: np.ndarray
    fixed_text: list
    shapes: list = field(default_factory=list)

    def points(self, shape: int, magnification: float, *, frame: int = 0,
               amplitude: float = 1.0) -> Configuration:
        """The points shape number `shape` draws at a magnification and a frame: base + m a D
        (module docstring), the formula the page's script evaluates."""
        found = self.shapes[shape]
        base = self.configurations[found.base]
        factor = float(magnification) * float(amplitude)
        return Configuration(base.lines + factor * found.line_fields[frame],
                             base.nodes + factor * found.node_fields[frame])


def configuration(model: Model, x: np.ndarray) -> Configuration:
    """The picture at coordinates x (NX,): the centre lines joined by NaN rows, the nodes."""
    gap = np.full((1, model.dimension), np.nan)
    lines = [part for line in centre_lines(model, x) for part in (line, gap)]
    joined = np.vstack(lines) if lines else np.empty((0, model.dimension))
    return Configuration(joined, node_positions(model, x))


def displacement_field(model: Model, base: np.ndarray, u: np.ndarray, magnification: float
                       ) -> tuple[np.ndarray, np.ndarray]:
    """D of the module docstring for one displacement u (NX,) about `base`: the lines' and
    the nodes' displacement per unit magnification (m), taken at `magnification`."""
    start = configuration(model, base)
    moved = configuration(model, scaled(model, base, u, magnification))
    lines = np.nan_to_num(moved.lines - start.lines)  # the gaps stay gaps in base + m D
    return lines / magnification, (moved.nodes - start.nodes) / magnification


# -- what the hover texts say ----------------------------------------------------------------

def _node_of_coordinate(model: Model) -> dict:
    return {index: node for node in model.nodes for index in node.coordinates}


def rotations_of(model: Model) -> dict:
    """{translational node name: [rotational nodes]}: a rotational node belongs to the
    translational node it follows in an element's node list (a beam's p, rotation p, q,
    rotation q), so its fixed coordinates are marked at that node."""
    owner = _node_of_coordinate(model)
    found: dict = {}
    for group in model.groups:
        for row in group.coordinate_index:
            previous = None
            for node in dict.fromkeys(owner[int(i)] for i in row):
                if node.kind == "translational":
                    previous = node
                elif previous is not None and node not in found.setdefault(previous.name, []):
                    found[previous.name].append(node)
    return found


def _status_words(model: Model, node) -> dict:
    """{"fixed": [axes], "DOF": [axes]} of a node's coordinates."""
    words: dict = {"fixed": [], "DOF": []}
    for index, axis in zip(node.coordinates, node.axes, strict=True):
        status = str(model.coordinate_status[index])
        if status == "fixed":
            words["fixed"].append(axis)
        elif status == "dof":
            words["DOF"].append(axis)
    return words


def describe_nodes(model: Model, x: np.ndarray) -> tuple[list, list, np.ndarray, list]:
    """(names, hover texts, indices of the fixed ones, their texts) of the translational
    nodes at coordinates x: each its position (m), its DOFs and fixed coordinates, with those
    of its rotational nodes (`rotations_of`)."""
    rotations = rotations_of(model)
    names, texts, fixed, fixed_texts = [], [], [], []
    for node in (n for n in model.nodes if n.kind == "translational"):
        position = ", ".join(f"{axis} {x[i]:.6g}" for axis, i in
                             zip(node.axes, node.coordinates, strict=True))
        lines = [f"node {node.name}: {position} m"]
        fixed_parts = []
        for part in [node, *rotations.get(node.name, [])]:
            words = _status_words(model, part)
            where = "" if part is node else f" (rotation {part.name})"
            for status in ("DOF", "fixed"):
                if words[status]:
                    lines.append(f"{status}: {', '.join(words[status])}{where}")
            if words["fixed"]:
                fixed_parts.append(f"{', '.join(words['fixed'])}{where}")
        if fixed_parts:
            fixed.append(len(names))
            fixed_texts.append(f"node {node.name} fixed: " + "; ".join(fixed_parts))
        names.append(node.name)
        texts.append("<br>".join(lines))
    return names, texts, np.array(fixed, dtype=int), fixed_texts


def point_elements(model: Model, *, points: int) -> list[str]:
    """The element of every line point (`configuration`'s rows), "" on the gaps."""
    lines = centre_lines(model, model.initial_coordinates, points=points)
    return [name if k < len(line) else "" for name, line in
            zip(drawn_elements(model), lines, strict=True) for k in range(len(line) + 1)]


# -- the shapes -------------------------------------------------------------------------------

def static_shape(model: Model, x_equilibrium: np.ndarray) -> ViewShape:
    """The static deflection under the scene's loads, drawn about the initial coordinates."""
    base = model.initial_coordinates
    u = np.asarray(x_equilibrium, float) - base
    m0 = displacement_scale(model, base, u)
    lines, nodes = displacement_field(model, base, u, m0)
    largest = largest_displacement(model, u)
    # round-off of an unloaded equilibrium is no displacement (as `pictures.plot_shape` says)
    words = (f"largest displacement {largest:.3g} m"
             if largest > STILL * model_size(model, base) else "no displacement")
    return ViewShape("static", "static deformed shape",
                     f"{model.name}: static deformed shape under the scene's loads ({words})",
                     INITIAL, m0, largest, lines[None], nodes[None])


def mode_shapes(model: Model, modes, x_equilibrium: np.ndarray) -> list[ViewShape]:
    """Each mode of `modes` (a `modal.Modes`), drawn about the equilibrium it is computed at
    and animated by the page as base + m sin(2 pi phase) D."""
    from .modal import describe_mode

    shapes = []
    for k, frequency in enumerate(modes.frequencies_hz):
        phi = modes.coordinate_shapes[:, k]
        m0 = displacement_scale(model, x_equilibrium, phi)
        lines, nodes = displacement_field(model, x_equilibrium, phi, m0)
        words = describe_mode(model, phi, x_equilibrium)
        shapes.append(ViewShape(
            "mode", f"mode {k + 1}: {frequency:.4g} Hz",
            f"{model.name}: mode {k + 1}, {frequency:.6g} Hz: {words}", EQUILIBRIUM, m0,
            largest_displacement(model, phi), lines[None], nodes[None],
            frequency_hz=float(frequency)))
    return shapes


def simulation_shape(model: Model, times: np.ndarray, q: np.ndarray, *,
                     frames: int = MAX_FRAMES, source: str = "") -> ViewShape:
    """A simulated motion (times (n,) s, DOFs q (n, NDOF)) about the initial coordinates: at
    most `frames` frames at recorded times (`pictures.frame_indices`), each configuration
    from the kinematics (`pictures.coordinates_along`)."""
    chosen = frame_indices(np.asarray(times, float), frames)
    xs = coordinates_along(model, np.asarray(q, float)[chosen])
    base = model.initial_coordinates
    u = xs - base
    m0 = displacement_scale(model, base, u)
    fields = [displacement_field(model, base, row, m0) for row in u]
    t = np.asarray(times, float)[chosen]
    what = f" from {source}" if source else ""
    return ViewShape("simulation", "simulation",
                     f"{model.name}: simulated motion{what}, {t[0]:g} to {t[-1]:g} s",
                     INITIAL, m0, largest_displacement(model, u),
                     np.array([f[0] for f in fields]), np.array([f[1] for f in fields]),
                     times=t)


def view_data(model: Model, *, modes: int | None = None, static: bool = False,
              times: np.ndarray | None = None, q: np.ndarray | None = None,
              source: str = "") -> ViewData:
    """The data of the view of `model`: its picture, and the shapes asked for.

    Parameters
    ----------
    model : Model
    modes : int, optional
        Show the lowest `modes` mode shapes (at the static equilibrium under the scene's
        loads, as `flexure analyze --modes` computes them).
    static : bool
        Show the static deformed shape under the scene's loads.
    times, q : ndarray (n,) s and (n, NDOF), optional
        A simulated motion to show (the DOFs at each time); `source` names where it is from.

    Returns
    -------
    ViewData
    """
    from .linearization import linearize
    from .modal import natural_frequencies
    from .statics import static_equilibrium

    require_drawable(model, "view")
    x0 = model.initial_coordinates
    names, texts, fixed, fixed_texts = describe_nodes(model, x0)
    data = ViewData(model.name, model.dimension, model_size(model, x0),
                    {INITIAL: configuration(model, x0)}, point_elements(model, points=POINTS),
                    names, texts, fixed, fixed_texts)
    if static or modes:
        solution = static_equilibrium(model)
        if static:
            data.shapes.append(static_shape(model, solution.x))
        if modes:
            found = natural_frequencies(model, modes, linear_model=linearize(model, solution))
            data.configurations[EQUILIBRIUM] = configuration(model, solution.x)
            data.shapes.extend(mode_shapes(model, found, solution.x))
    if q is not None:
        data.shapes.append(simulation_shape(model, times, q, source=source))
    return data
