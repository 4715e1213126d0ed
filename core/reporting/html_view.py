"""The page of `flexure view`: one self-contained HTML file that opens offline.

plotly draws the model (`view_page`): a 3-D scene for a spatial model, 2-D axes with equal
aspect for a planar one, both to rotate (3-D), zoom and pan with the mouse; the undeformed
model in grey, the shape shown in blue, the translational nodes (their names, coordinates,
DOFs and fixed coordinates on hover) and the nodes with a fixed coordinate as red diamonds.
plotly.js is inlined (include_plotlyjs=True, about 4.8 MB), so the page needs no server and
no network.

The shapes (`analysis.view_data`) travel as displacement fields, not as plotly frames: a
frame per phase and magnification would hold the whole picture again each time (the
manipulator's 5481 line points, 10 modes x 24 phases: 48 MB as JSON), whereas base + m a D
evaluated by the page's script needs one field per mode. The fields are float32 (7
significant digits, far below a pixel) in base64, and the script (`SCRIPT`) evaluates

    points = base + magnification * amplitude * D[frame]

(amplitude sin(2 pi k / PHASES) of a mode's phase k, 1 otherwise) and hands them to
Plotly.restyle, one restyle at a time (a heavy model drops frames rather than queueing them).
The controls: a menu of the shapes, a magnification slider (logarithmic, from a thousandth of
the default to ten times it, and 1), a frame slider (a mode's phase or a simulation's time)
and play / pause. `window.flexureView` gives a test (or a user's console) the same handles.
"""

from __future__ import annotations

import base64
import json
from importlib import resources
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # names for the annotations only
    from ..analysis.view_data import ViewData

SCRIPT = "view_page.js"  # the page's script (module docstring), a file beside this one
PHASES = 24  # frames per cycle of a mode's animation
FRAMES_PER_SECOND = 20  # the animation's pace: a mode's cycle takes 1.2 s on the page
DIV_ID = "flexure-view"
UNDEFORMED, DEFORMED, NODES, FIXED = range(4)  # the traces, in this order
GREY, BLUE, RED = "#b8b8b8", "#1f5fbf", "#d62728"


def float32_base64(values: np.ndarray) -> str:
    """The values as little-endian float32, base64 (what the script's `decode` reads)."""
    return base64.b64encode(np.ascontiguousarray(values, dtype="<f4").tobytes()).decode()


def payload(data: ViewData) -> dict:
    """What the script needs, JSON-ready: the configurations and shapes' fields as base64
    float32, the rest as numbers and strings."""
    return {
        "name": data.name, "dimension": data.dimension, "size": data.size,
        "phases": PHASES, "fps": FRAMES_PER_SECOND,
        "traces": {"deformed": DEFORMED, "nodes": NODES, "fixed": FIXED},
        "fixedNodes": [int(i) for i in data.fixed_nodes],
        "configurations": {key: {"lines": float32_base64(c.lines), "nodes": float32_base64(c.nodes),
                                 "lineCount": int(c.lines.shape[0]),
                                 "nodeCount": int(c.nodes.shape[0])}
                           for key, c in data.configurations.items()},
        "shapes": [{"kind": s.kind, "label": s.label, "title": s.title, "base": s.base,
                    "magnification": s.magnification, "largest": s.largest,
                    "frames": int(s.line_fields.shape[0]),
                    "times": None if s.times is None else [float(t) for t in s.times],
                    "frequency": s.frequency_hz,
                    "lines": float32_base64(s.line_fields), "nodes": float32_base64(s.node_fields)}
                   for s in data.shapes],
    }


def axis_ranges(data: ViewData) -> np.ndarray:
    """(dimension, 2) m: the range of each axis around every picture the page shows at its
    default magnification (each mode at both extremes), with a margin of 5 % of the largest
    span, so that the axes stand still while the model moves."""
    pictures = [c.lines for c in data.configurations.values()]
    for shape in data.shapes:
        base = data.configurations[shape.base].lines
        for sign in (1.0, -1.0) if shape.kind == "mode" else (1.0,):
            pictures.extend(base + sign * shape.magnification * shape.line_fields)
    points = np.vstack([p.reshape(-1, data.dimension) for p in pictures])
    low, high = np.nanmin(points, axis=0), np.nanmax(points, axis=0)
    margin = 0.05 * max(float(np.max(high - low)), 1e-12)
    return np.column_stack([low - margin, high + margin])


def figure(data: ViewData):
    """The plotly figure at the undeformed configuration: its four traces (UNDEFORMED ...
    FIXED) and a layout with fixed, equal axis ranges (m)."""
    import plotly.graph_objects as go

    base = data.configurations["initial"]
    spatial = data.dimension == 3
    scatter = go.Scatter3d if spatial else go.Scatter

    def trace(points, **style):
        columns = dict(zip("xyz", points.T, strict=False))
        return scatter(**columns, **style)

    fixed = base.nodes[data.fixed_nodes] if len(data.fixed_nodes) else base.nodes[:0]
    marker = 3 if spatial else 6
    traces = [
        trace(base.lines, mode="lines", name="undeformed", hoverinfo="skip",
              line={"color": GREY, "width": 2}),
        trace(base.lines, mode="lines", name="shape shown", text=data.point_elements,
              hovertemplate="element %{text}<extra></extra>", line={"color": BLUE, "width": 4}),
        trace(base.nodes, mode="markers", name="nodes", text=data.node_text,
              hovertemplate="%{text}<extra></extra>", marker={"color": BLUE, "size": marker}),
        trace(fixed, mode="markers", name="fixed coordinates", text=data.fixed_text,
              hovertemplate="%{text}<extra></extra>",
              marker={"color": RED, "size": marker + 3, "symbol": "diamond"}),
    ]
    ranges = axis_ranges(data)
    layout = {"title": {"text": f"{data.name}: the undeformed model", "font": {"size": 14}},
              "margin": {"l": 10, "r": 10, "t": 50, "b": 10}, "uirevision": "keep",
              "legend": {"orientation": "h", "y": 0}, "paper_bgcolor": "white"}
    if spatial:
        axes = {f"{axis}axis": {"range": list(r), "title": {"text": f"{axis} [m]"}}
                for axis, r in zip("xyz", ranges, strict=True)}
        spans = ranges[:, 1] - ranges[:, 0]  # drawn to scale: a flat model as a flat box
        ratio = dict(zip("xyz", (spans / spans.max()).tolist(), strict=True))
        layout["scene"] = {**axes, "aspectmode": "manual", "aspectratio": ratio,
                           "camera": {"eye": {"x": 1.0, "y": 1.0, "z": 0.8}}}  # plotly's: 1.25
    else:
        layout["xaxis"] = {"range": list(ranges[0]), "title": {"text": "x [m]"}}
        layout["yaxis"] = {"range": list(ranges[1]), "title": {"text": "y [m]"},
                           "scaleanchor": "x", "scaleratio": 1}
        layout["plot_bgcolor"] = "white"
        layout["dragmode"] = "pan"
    return go.Figure(data=traces, layout=layout)


def view_page(data: ViewData) -> str:
    """The whole page, one self-contained HTML document (module docstring)."""
    import plotly.io

    script = (resources.files(__package__) / SCRIPT).read_text()
    script = script.replace("__DATA__", json.dumps(payload(data)))
    return plotly.io.to_html(
        figure(data), include_plotlyjs=True, full_html=True, div_id=DIV_ID,
        default_width="100%", default_height="88vh", post_script=script,
        config={"scrollZoom": True, "displaylogo": False, "responsive": True})
