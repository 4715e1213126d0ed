"""Pictures of a model: the deformed shape of a static solution, mode shapes, and an animation
of a simulation, planar in 2-D axes and spatial in 3-D axes, both with equal aspect.

What is drawn (`centre_lines`): every element's centre line, in m, from the coordinates x.
A beam (PLBEAM, BEAM) is drawn as the curve its distributed mass uses: the cubic Hermite
interpolation between its end positions r^p, r^q and end tangents l0 t^p, l0 t^q (t the
element axis rotated with each end node; the element's `inertia_points`),

    r(s) = (1 - 3 s^2 + 2 s^3) r^p + (s - 2 s^2 + s^3) l0 t^p
           + (3 s^2 - 2 s^3) r^q + (s^3 - s^2) l0 t^q,          s in [0, 1],

so a bent leaf spring is drawn curved as its own end rotations say; a truss (PLTRUSS, TRUSS)
is drawn straight, as its mass interpolates it. The centre line passes through the nodes
(r(0) = r^p, r(1) = r^q), and a straight unloaded beam is drawn straight.

How much the motion is magnified (`displacement_scale`): the largest displacement of a
translational node is drawn as FRACTION (10 %) of the model's size, the largest extent of its
undeformed picture; the factor is rounded to two significant digits and stated in the title.
A displacement field u (a static deflection, a mode shape, a simulated motion) is drawn at
x_ref + scale u, with the Euler parameters of spatial nodes normalised again (a magnified
rotation is still a rotation). Where no translational node moves (a pure twist) the rotations
times the model's length scale (its longest element) stand in for the displacement.

This module lives in analysis/ rather than reporting/ because it evaluates the elements'
interpolation and solves the kinematics of a trajectory (q to x), which reporting/ (plain
tables and progress lines, importing nothing of the model) does not.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SceneError

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

FRACTION = 0.1  # the largest displacement drawn as this fraction of the model's size
POINTS = 21  # points along each beam's centre line
STILL = 1e-9  # a largest displacement below this fraction of the size is no motion
MAX_FRAMES = 100  # the most frames an animation gets
FRAMES_PER_SECOND = 20
REFERENCE_COLOUR = "0.72"  # the undeformed model: grey
HERMITE = ("position", "tangent", "position", "tangent")


def drawable(model: Model) -> bool:
    """Whether `model` has an element with a centre line to draw (a truss or a beam)."""
    return any(_interpolation(group) is not None for group in model.groups)


def require_drawable(model: Model, option: str = "picture") -> None:
    """SceneError (one line) unless `model` has a truss or beam to draw."""
    if not drawable(model):
        raise SceneError(f"{model.source}: {option}: {model.name!r} has no truss or beam "
                         "element, so no picture to draw")


def _interpolation(group):
    """"hermite", "linear" or None (nothing to draw: the Euler-parameter constraint)."""
    kinds = tuple(getattr(group.kind, "inertia_point_kinds", ()))
    if not hasattr(group.kind, "inertia_points"):
        return None
    if kinds[:4] == HERMITE:
        return "hermite"
    if kinds[:2] == ("position", "position"):
        return "linear"
    return None


def drawn_elements(model: Model) -> list[str]:
    """The names of the elements `centre_lines` draws, in the order of its polylines."""
    return [name for group in model.groups if _interpolation(group) is not None
            for name in group.names]


def hermite_weights(s: np.ndarray) -> np.ndarray:
    """The cubic Hermite weights (len(s), 4) of [r^p, l0 t^p, r^q, l0 t^q] at s in [0, 1]."""
    s = np.asarray(s, dtype=float)[:, None]
    return np.hstack([1 - 3 * s**2 + 2 * s**3, s - 2 * s**2 + s**3, 3 * s**2 - 2 * s**3,
                      s**3 - s**2])


def normalised(model: Model, x: np.ndarray) -> np.ndarray:
    """x (NX,) with the Euler parameters of every spatial rotational node scaled to unit
    length (a magnified rotation drawn as a rotation)."""
    x = np.array(x, dtype=float)
    for node in model.nodes:
        if node.kind == "rotational" and len(node.axes) == 4:
            index = list(node.coordinates)
            norm = np.linalg.norm(x[index])
            if norm > 0:
                x[index] /= norm
    return x


def centre_lines(model: Model, x: np.ndarray, *, points: int = POINTS) -> list[np.ndarray]:
    """The centre line of every truss and beam at coordinates x (NX,): a list of polylines,
    each (k, dimension) in m, a beam's the Hermite curve at `points` points from p to q, a
    truss's its two end positions."""
    x = normalised(model, x)
    d = model.dimension
    lines = []
    weights = hermite_weights(np.linspace(0.0, 1.0, points))
    for group in model.groups:
        how = _interpolation(group)
        if how is None:
            continue
        (p,) = group.kind.inertia_points(group.local(x), group.reference, order=0)
        if how == "hermite":
            ends = p[:, : 4 * d].reshape(-1, 4, d)  # [r^p, l0 t^p, r^q, l0 t^q] per element
            lines.extend(np.einsum("sk,nkd->nsd", weights, ends))
        else:
            lines.extend(p[:, : 2 * d].reshape(-1, 2, d))
    return lines


def node_positions(model: Model, x: np.ndarray) -> np.ndarray:
    """The positions (n, dimension) m of the translational nodes at coordinates x."""
    rows = [x[list(node.coordinates)] for node in model.nodes if node.kind == "translational"]
    return np.array(rows, dtype=float).reshape(-1, model.dimension)


def model_size(model: Model, x: np.ndarray) -> float:
    """The largest extent (m) of the picture of `model` at x: of its centre lines and nodes
    (the model's length scale if that is zero, a lone point)."""
    from ..mechanics.kinematics import length_scale

    pts = np.vstack([*centre_lines(model, x), node_positions(model, x)])
    extent = float(np.max(np.ptp(pts, axis=0))) if pts.size else 0.0
    return extent if extent > 0 else length_scale(model)


def largest_displacement(model: Model, displacement: np.ndarray) -> float:
    """The largest displacement (m) in a field u (NX,) or fields (n, NX): the largest norm of
    a translational node's displacement; without any, the largest rotation (rad; Euler
    parameters: twice their change) times the model's length scale."""
    from ..mechanics.kinematics import length_scale

    u = np.atleast_2d(np.asarray(displacement, dtype=float))
    moves, turns = [0.0], [0.0]
    for node in model.nodes:
        part = u[:, list(node.coordinates)]
        if node.kind == "translational":
            moves.append(float(np.max(np.linalg.norm(part, axis=1))))
        else:
            factor = 1.0 if len(node.axes) == 1 else 2.0
            turns.append(factor * float(np.max(np.linalg.norm(part, axis=1))))
    return max(moves) if max(moves) > 0 else max(turns) * length_scale(model)


def displacement_scale(model: Model, reference: np.ndarray, displacement: np.ndarray, *,
                       fraction: float = FRACTION) -> float:
    """The factor that draws the largest displacement of u (NX,) or (n, NX) as `fraction` of
    the model's size at `reference`, rounded to two significant digits (1 if nothing moves more
    than STILL times the size)."""
    largest, size = largest_displacement(model, displacement), model_size(model, reference)
    if not largest > STILL * size:  # round-off of an unloaded equilibrium is no motion
        return 1.0
    return float(f"{fraction * size / largest:.2g}")


def scaled(model: Model, reference: np.ndarray, displacement: np.ndarray,
           scale: float) -> np.ndarray:
    """The coordinates x_ref + scale u that draw a displacement field magnified."""
    return normalised(model, np.asarray(reference, float) + scale * np.asarray(displacement))


# -- drawing --------------------------------------------------------------------------------

def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _axes(fig, model, *position):
    if model.dimension == 3:
        return fig.add_subplot(*position, projection="3d")
    return fig.add_subplot(*position)


def _draw(ax, model, x, **style):
    """Draw the centre lines and nodes at x; returns the line artists (centre lines, nodes)."""
    lines = [ax.plot(*line.T, **style)[0] for line in centre_lines(model, x)]
    nodes = node_positions(model, x)
    dots = ax.plot(*nodes.T, "o", ms=3, color=style.get("color"))[0]
    return lines, dots


def _update(model, artists, x):
    """Move the artists of `_draw` to the picture at x."""
    lines, dots = artists
    for artist, line in zip(lines, centre_lines(model, x), strict=True):
        if model.dimension == 3:
            artist.set_data_3d(*line.T)
        else:
            artist.set_data(*line.T)
    nodes = node_positions(model, x)
    if model.dimension == 3:
        dots.set_data_3d(*nodes.T)
    else:
        dots.set_data(*nodes.T)


def _frame(ax, model, pictures):
    """Equal aspect around every picture x in `pictures`, with a margin; axes in m."""
    pts = np.vstack([np.vstack([*centre_lines(model, x), node_positions(model, x)])
                     for x in pictures])
    low, high = pts.min(axis=0), pts.max(axis=0)
    half = 0.55 * max(float(np.max(high - low)), 1e-12)
    centre = 0.5 * (low + high)
    if model.dimension == 3:
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(centre[2] - half, centre[2] + half)
        ax.set_box_aspect((1, 1, 1))
        ax.set_zlabel("z [m]")
    else:
        ax.set_aspect("equal")
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.grid(True, alpha=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def _pair(ax, model, reference, x):
    """The undeformed model in grey and the deformed one over it."""
    _draw(ax, model, reference, color=REFERENCE_COLOUR, lw=1.0)
    artists = _draw(ax, model, x, color="C0", lw=1.8)
    _frame(ax, model, [reference, x])
    return artists


def plot_shape(model: Model, x: np.ndarray, path, *, reference: np.ndarray | None = None,
               scale: float | None = None, title: str | None = None) -> float:
    """Draw the deformed shape at coordinates x (NX,) over the undeformed model (`reference`,
    default the scene's initial coordinates) to an image file (PNG, PDF or SVG by suffix).
    The displacement x - reference is magnified by `scale` (default `displacement_scale`'s:
    the largest displacement 10 % of the model's size); returns the factor used."""
    require_drawable(model, "--plot-shape")
    reference = model.initial_coordinates if reference is None else np.asarray(reference)
    u = np.asarray(x, float) - reference
    scale = displacement_scale(model, reference, u) if scale is None else float(scale)
    plt = _pyplot()
    fig = plt.figure(figsize=(6, 5.5))
    ax = _axes(fig, model, 1, 1, 1)
    _pair(ax, model, reference, scaled(model, reference, u, scale))
    largest = largest_displacement(model, u)
    if largest > STILL * model_size(model, reference):
        words = f"displacements x {scale:g}\n(largest {largest:.3g} m; undeformed in grey)"
    else:
        words = "no displacement\n(the equilibrium is the undeformed model)"
    ax.set_title(title or f"{model.name}: deformed shape, {words}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return scale


def plot_modes(model: Model, modes, path, count: int = 6, *,
               reference: np.ndarray | None = None) -> list[float]:
    """Draw the lowest `count` mode shapes of `modes` (a `Modes`), one panel each, to an image
    file: each over the configuration it was computed in (`reference`, default the static
    equilibrium of its linear model), magnified so that its largest displacement is 10 % of
    the model's size, titled with its frequency (Hz) and `describe_mode`'s words. Returns
    the scale factor of each panel."""
    from .modal import describe_mode

    require_drawable(model, "--plot-modes")
    if reference is None:
        solution = getattr(modes.linear_model, "solution", None)
        reference = model.initial_coordinates if solution is None else solution.x
    n = min(int(count), modes.frequencies_hz.size)
    columns = min(n, 3)
    rows = -(-n // columns)
    plt = _pyplot()
    fig = plt.figure(figsize=(4.2 * columns, 4.0 * rows))
    scales = []
    for k in range(n):
        shape = modes.coordinate_shapes[:, k]
        scale = displacement_scale(model, reference, shape)
        scales.append(scale)
        ax = _axes(fig, model, rows, columns, k + 1)
        _pair(ax, model, reference, scaled(model, reference, shape, scale))
        words = describe_mode(model, shape, reference)
        ax.set_title(f"mode {k + 1}: {modes.frequencies_hz[k]:.4g} Hz (x {scale:g})\n{words}",
                     fontsize=9)
    fig.suptitle(f"{model.name}: mode shapes (undeformed in grey)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return scales


# -- animation ------------------------------------------------------------------------------

def frame_indices(times: np.ndarray, frames: int = MAX_FRAMES) -> np.ndarray:
    """Indices of at most `frames` recorded times, the ones nearest to equally spaced times
    from the first to the last (every one when there are no more than `frames`)."""
    times = np.asarray(times, dtype=float)
    if times.size <= frames:
        return np.arange(times.size)
    wanted = np.linspace(times[0], times[-1], frames)
    right = np.clip(np.searchsorted(times, wanted), 1, times.size - 1)
    nearer_left = (wanted - times[right - 1]) <= (times[right] - wanted)
    return np.unique(np.where(nearer_left, right - 1, right))


def coordinates_along(model: Model, q: np.ndarray) -> np.ndarray:
    """The coordinates x (n, NX) of DOF values q (n, NDOF), by the kinematics, each Newton
    solve started from the previous configuration."""
    from ..mechanics.kinematics import Kinematics

    kinematics = Kinematics(model)
    x = model.initial_coordinates.copy()
    result = []
    for row in np.atleast_2d(np.asarray(q, dtype=float)):
        x = kinematics.solve(row, x).x
        result.append(x)
    return np.array(result).reshape(-1, model.nx)


def animate(model: Model, result, path, *, frames: int = MAX_FRAMES,
            scale: float | None = None, fps: int = FRAMES_PER_SECOND) -> float:
    """Write an animated GIF of a simulation (a `SimulationResult`: times, q) over the
    undeformed model: at most `frames` frames at recorded times (`frame_indices`), each with
    its time stamp (s), the motion from the scene's initial coordinates magnified by `scale`
    (default: the largest displacement of the run drawn as 10 % of the model's size).
    Returns the factor used."""
    from matplotlib.animation import PillowWriter

    require_drawable(model, "--animate")
    chosen = frame_indices(result.times, frames)
    times = np.asarray(result.times)[chosen]
    xs = coordinates_along(model, np.asarray(result.q)[chosen])
    reference = model.initial_coordinates
    u = xs - reference
    scale = displacement_scale(model, reference, u) if scale is None else float(scale)
    pictures = [scaled(model, reference, row, scale) for row in u]
    plt = _pyplot()
    fig = plt.figure(figsize=(5.5, 5.0))
    ax = _axes(fig, model, 1, 1, 1)
    _draw(ax, model, reference, color=REFERENCE_COLOUR, lw=1.0)
    artists = _draw(ax, model, pictures[0], color="C0", lw=1.8)
    _frame(ax, model, [reference, *pictures])
    ax.set_title(f"{model.name}: motion x {scale:g} (undeformed in grey)", fontsize=10)
    stamp = fig.text(0.02, 0.02, "", fontsize=10, family="monospace")
    writer = PillowWriter(fps=fps)
    with writer.saving(fig, str(path), dpi=80):
        for t, x in zip(times, pictures, strict=True):
            _update(model, artists, x)
            stamp.set_text(f"t = {t:.4f} s")
            writer.grab_frame()
    plt.close(fig)
    return scale
