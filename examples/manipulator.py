"""The six-DOF flexure manipulator of the chapter, reconstructed: one parameter table, six scenes.

    python examples/manipulator.py            # writes the scenes into examples/scenes/
    python examples/manipulator.py --table    # prints the parameter table (docs/manipulator.md)
    python examples/manipulator.py --coils    # prints the voice coils' table

The chapter (Jonker, Aarts and van Dijk, "Flexible multibody modelling for exact constraint
design of compliant mechanisms", section 3) gives the architecture, not the dimensions; the
numbers below are ours, chosen so that the six suspension modes lie below 30 Hz and the first
parasitic mode far above the 300 rad/s (48 Hz) cross-over. Coordinates in m, z up; the
manipulator's plane is z = 0, its centre the origin.

- **Six straight guidances** (chapter Fig. 3.3), one per voice-coil actuator. Each guides its
  carriage H along one axis u (x or y): two parallel leaf springs from the base to an
  intermediate body L, two more from L down to H (a folded guidance: L moves half of H, the
  parasitic shortening cancels), and a lever U on a cross-pivot of two leaves (S, T) that holds
  L at half of H's stroke through two wire flexures (X to L, Z to H). Each parallel pair of
  leaves holds its body's rotation about u twice, and the cross-pivot holds its lever's z
  twice: over-constrained by design, as the chapter says, for out-of-plane stiffness.
- **Three intermediate bodies** C at 90, 210 and 330 degrees on radius `body_radius`. Each is
  pushed by two carriages, along x and along y, through an in-plane leaf spring each (A along
  x, D along y: thin in-plane, so each lets C move along the other's axis; tall, so C stays
  in the plane). The actuators push along the model's axes so that every force is an input on
  one coordinate and every encoder an output of one, as SPACAR's INPUTF and OUTX.
- **Three slanted leaf springs** M, from each C up and inward to the end effector E, at 45
  degrees, wide in the tangential direction. Moving all C alike moves E sideways; moving them
  radially inward lifts it; other combinations tilt and turn it.

The scenes written (all `flexure` built-ins once written into examples/scenes/):

- `manipulator_guidance`: one guidance alone, kinematic (one beam per flexure, a leaf's
  elongation and wide-plane bending prescribed, a wire's elongation): refused as
  over-constrained, with the redundant constraints named and releases proposed.
- `manipulator_stage`: the end-effector stage, kinematic: the three C translate in the plane
  (their x and y are the six DOFs), each slanted spring holds E along its length (e1) and
  sideways (e3, its wide-plane bending at C; its other wide-plane bending e4 released, as a
  notch where it meets E). Exactly constrained with 6 DOFs.
- `manipulator`: the whole manipulator, dynamic: every flexure in `segments` beams with all six
  deformations released, the bodies rigid with their masses and inertias (the chapter's
  870-DOF model's analogue).
- `manipulator_e1`: the same with every elongation prescribed zero (its 315-DOF analogue).
- `manipulator_control`: one beam per flexure, every elongation prescribed zero (75 DOFs): the
  plant of the closed loop, its ten lowest frequencies within 0.5 % of the full model's.
- `manipulator_control_vcm`: the control model with its six actuators voltage-driven voice
  coils (the table `COILS`): the inputs are the amplifiers' drive signals (V), the coil
  currents states, the back-EMF damps the suspension modes.
- `manipulator_reduced`: written by `flexure reduce manipulator_e1 --keep 7 --tol 1`
  (its 237-DOF analogue), not by this script: the six suspension modes and the first
  parasitic one within 1 % (keeping six only, the reduction freezes what the parasitic mode
  bends and doubles its frequency; a controller's robustness depends on that mode).

Inputs F1 ... F6 are the actuator forces (N) on the carriages, outputs x1 ... x6 the
carriages' positions (m) along their axes: the colocated encoders. With `--angle-outputs`
the dynamic scenes also get E_rx, E_ry, E_rz, the end effector's rotations about the global
axes (rad, rotation-vector components): its parasitic rotations.
"""

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from flexure.core.scene.scene_writer import scene_toml

SCENES = Path(__file__).resolve().parent / "scenes"

# The parameter table: (value, unit, what it is). Every dimension of the scenes comes from here.
PARAMETERS = {
    "E": (2.1e11, "Pa", "Young's modulus of the spring steel flexures"),
    "nu": (0.3, "-", "Poisson's ratio of the spring steel"),
    "rho_steel": (7850.0, "kg/m^3", "density of the spring steel"),
    "beta": (5e-5, "s", "stiffness-proportional damping of the flexures"),
    "body_radius": (0.12, "m", "radius of the intermediate bodies' centres"),
    "effector_radius": (0.03, "m", "radius of the slanted springs' attachments on the effector"),
    "leaf_length": (0.06, "m", "guidance leaf springs, length (vertical)"),
    "leaf_width": (0.02, "m", "guidance leaf springs, width"),
    "leaf_thickness": (0.3e-3, "m", "guidance leaf springs, thickness"),
    "leaf_spacing": (0.05, "m", "distance between the two leaves of a parallel pair"),
    "pair_distance": (0.05, "m", "distance between a guidance's two pairs of leaves"),
    "pivot_length": (0.02, "m", "cross-pivot leaves, length"),
    "pivot_width": (0.01, "m", "cross-pivot leaves, width (vertical)"),
    "pivot_thickness": (0.3e-3, "m", "cross-pivot leaves, thickness"),
    "lever_arm": (0.025, "m", "lever, pivot to the wire of L (the wire of H at twice this)"),
    "wire_length": (0.015, "m", "wire flexures X and Z, length"),
    "wire_diameter": (0.8e-3, "m", "wire flexures X and Z, diameter"),
    "push_length": (0.05, "m", "in-plane leaf springs A and D, length"),
    "push_height": (0.02, "m", "in-plane leaf springs A and D, height (along z)"),
    "push_thickness": (0.3e-3, "m", "in-plane leaf springs A and D, thickness"),
    "slant_length": (0.08, "m", "slanted leaf springs M, length (at 45 degrees)"),
    "slant_width": (0.03, "m", "slanted leaf springs M, width (tangential)"),
    "slant_thickness": (0.4e-3, "m", "slanted leaf springs M, thickness"),
    "carriage_mass": (0.20, "kg", "carriage H with its coil and encoder scale"),
    "guidance_body_mass": (0.06, "kg", "intermediate body L of a guidance"),
    "lever_mass": (0.02, "kg", "lever U"),
    "body_mass": (0.10, "kg", "intermediate body C"),
    "effector_mass": (0.25, "kg", "end effector E"),
    "body_size": (0.04, "m", "edge of the cube whose inertia each rigid body is given"),
    "segments": (3, "-", "beams per flexure in the dynamic models"),
}

# The voice coils of `manipulator_control_vcm`, one per carriage, voltage-driven. The chapter
# names VCMs and their back-EMF's damping, not their data; these are a small moving-coil
# actuator's (docs/manipulator.md, "Through its voice coils", gives the reasoning).
COILS = {
    "force_constant": (6.0, "N/A", "Km, force per current (= back-EMF constant, V s/m)"),
    "resistance": (3.0, "ohm", "R, the coil's resistance"),
    "inductance": (3e-4, "H", "L, the coil's inductance"),
    "amplifier_gain": (1.0, "V/V", "G, the voltage amplifier's gain from the drive signal"),
    "saturation": (24.0, "V", "the amplifier's output limit"),
}

BODY_ANGLES = (90.0, 210.0, 330.0)  # degrees, the intermediate bodies C1, C2, C3


def value(name, parameters=None):
    """A parameter's value (SI units) from `parameters` (default PARAMETERS)."""
    return (parameters or PARAMETERS)[name][0]


def layout(length, parameters):
    """A length of the layout that is not in the table (an offset between a body's centre and
    its attachments, the base's height; m at the table's size) at the table's `scale` (1 when
    the table has none: the macro design): examples/manipulator_mems.py scales the design
    down as a whole, so the layout keeps its proportions."""
    return length * (value("scale", parameters) if "scale" in parameters else 1.0)


class SceneParts:
    """The nodes, sections and elements of one scene as it is being assembled."""

    def __init__(self, parameters, *, dynamic, frozen=()):
        self.p = parameters
        self.dynamic = dynamic
        self.frozen = tuple(frozen)  # deformations a dynamic scene prescribes zero
        self.nodes = {}
        self.elements = {}
        self.inputs = {}
        self.outputs = {}

    def point(self, name, position, *, fixed=False, dof=()):
        """A translational node and its rotational node `name_r` at `position` (m)."""
        node = {"position": design(position)}
        if fixed:
            node["fixed"] = ["x", "y", "z"]
        if dof:
            node["dof"] = list(dof)
            if fixed:
                node["fixed"] = [a for a in "xyz" if a not in dof]
        self.nodes[name] = node
        self.nodes[f"{name}_r"] = {"rotation": [0.0, 0.0, 0.0]} | ({"fixed": True} if fixed
                                                                 else {})
        return name

    def body(self, name, centre, attachments, *, mass, dof=(), fixed_axes=(), fixed_rotation=False):
        """A rigid body: its centre node (carrying `mass` kg and the inertia of a cube of
        `body_size`) joined by rigid beams to the attachment points {label: position}; returns
        {label: attachment node name}."""
        self.point(name, centre)
        node = self.nodes[name]
        if dof:
            node["dof"] = list(dof)
        if fixed_axes:
            node["fixed"] = list(fixed_axes)
        if fixed_rotation:
            self.nodes[f"{name}_r"]["fixed"] = True
        if self.dynamic:
            node["mass"] = mass
            inertia = mass * value("body_size", self.p) ** 2 / 6.0  # a cube: m a^2 / 6
            self.nodes[f"{name}_r"]["inertia"] = [inertia] * 3
        names = {}
        for label, position in attachments.items():
            at = self.point(f"{name}_{label}", position)
            self.rigid(f"{name}_to_{label}", name, at)
            names[label] = at
        return names

    def rigid(self, name, p, q):
        """A rigid beam from node p to node q (all six deformations prescribed zero)."""
        axis = np.subtract(self.nodes[q]["position"], self.nodes[p]["position"])
        self.elements[name] = {"type": "BEAM", "nodes": [p, f"{p}_r", q, f"{q}_r"],
                               "section": "rigid", "y_axis": _normal_to(axis)}

    def flexure(self, name, p, q, section, thin, *, prescribed):
        """A flexure from node p to node q: the principal y' axis `thin` (its thickness
        direction); in a kinematic scene the deformations `prescribed` stay zero and the rest
        are released, in a dynamic scene everything is released and it has `segments` beams."""
        element = {"type": "BEAM", "nodes": [p, f"{p}_r", q, f"{q}_r"], "section": section,
                   "y_axis": design(thin)}
        if self.dynamic:
            element["released"] = [e for e in DEFORMATIONS if e not in self.frozen]
            segments = int(value("segments", self.p))
            if segments > 1:
                element["segments"] = segments
        else:
            element["released"] = [e for e in DEFORMATIONS if e not in prescribed]
        self.elements[name] = element


DEFORMATIONS = ("e1", "e2", "e3", "e4", "e5", "e6")
LEAF = ("e1", "e3", "e4")  # a leaf spring: stiff in elongation and in its wide plane
WIRE = ("e1",)  # a wire flexure: stiff in elongation only


def _normal_to(axis):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    trial = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    return design(np.cross(axis, trial) / np.linalg.norm(np.cross(axis, trial)))


def design(values):
    """Computed geometry (positions in m, the components of a unit vector) as the scene
    states it: rounded to 1e-12, as a drawing would be. The trigonometry behind it differs
    from one CPU to the next in its last bits (0.7071067811865476 or ...475); rounded, the
    scenes written are the same on every machine, and a round-off zero (4e-17) is 0.0."""
    return [round(float(c), 12) + 0.0 for c in values]  # + 0.0: no -0.0 from a -4e-17


def sections(parameters, *, dynamic):
    """The scene's [sections]: the flexures' rectangles and circles, and the rigid links.

    The flexures' material is the table's `E`, `nu` and `rho_steel` (or `rho`, a table of
    another material); a table with `wire_side` makes the wire flexures square (m), as an
    etched one is, instead of round."""
    p = parameters
    steel = {"E": value("E", p), "nu": value("nu", p)}
    if dynamic:
        rho = value("rho", p) if "rho" in p else value("rho_steel", p)
        steel |= {"rho": rho, "beta": value("beta", p)}

    def leaf(width, thickness):
        return steel | {"width": value(width, p), "height": value(thickness, p)}

    return {
        "leaf": leaf("leaf_width", "leaf_thickness"),
        "pivot": leaf("pivot_width", "pivot_thickness"),
        "push": leaf("push_height", "push_thickness"),
        "slant": leaf("slant_width", "slant_thickness"),
        "wire": steel | ({"width": value("wire_side", p), "height": value("wire_side", p)}
                         if "wire_side" in p else {"diameter": value("wire_diameter", p)}),
        # no stiffness: nothing of a rigid link can be released, so the exact-constraint check
        # never proposes it, and names it as the link a redundancy runs through
        "rigid": {},
    }


def guidance(parts, k, anchor, u, *, prescribed_leaf=LEAF, prescribed_wire=WIRE):
    """Straight guidance k: its carriage H moves along the horizontal unit vector u; `anchor`
    is H's attachment for the in-plane spring (m). Returns that attachment's node name."""
    p = parts.p
    u = np.asarray(u, float)
    v = np.cross([0.0, 0.0, 1.0], u)
    w = np.array([0.0, 0.0, 1.0])
    h = value("leaf_length", p)
    a = value("leaf_spacing", p) / 2.0
    c = value("pair_distance", p) / 2.0
    r = value("lever_arm", p)
    lw = value("wire_length", p)
    ls = value("pivot_length", p) / 2.0
    g = layout(0.04, p)  # m, from H's in-plane attachment to the guidance's centre along u
    base = layout(-0.10, p)  # m, the height of the base and of the carriage
    above = layout(0.01, p)  # m, a body's centre from its flexures' attachments

    def at(du, dv, dw):
        return np.asarray(anchor, float) + (g + du) * u + dv * v + dw * w

    top, middle = base + h, base + h / 2.0
    pivot = -c - layout(0.02, p)  # the lever's pivot, behind the first pair along v
    G = f"g{k}"
    carriage = parts.body(f"{G}_H", at(0.0, c, base - above), {
        "leaf3": at(-a, c, base), "leaf4": at(a, c, base),
        "wireZ": at(lw, pivot + 2 * r, middle),
        "push": np.asarray(anchor, float)}, mass=value("carriage_mass", p))
    body = parts.body(f"{G}_L", at(0.0, 0.0, top + above), {
        "leaf1": at(-a, -c, top), "leaf2": at(a, -c, top),
        "leaf3": at(-a, c, top), "leaf4": at(a, c, top),
        "wireX": at(lw, pivot + r, middle)}, mass=value("guidance_body_mass", p))
    d1, d2 = (u + v) / math.sqrt(2.0), (u - v) / math.sqrt(2.0)
    centre = at(0.0, pivot, middle)
    lever = parts.body(f"{G}_U", at(0.0, pivot + r, middle + above), {
        "S": centre + ls * d1, "T": centre + ls * d2,
        "wireX": at(0.0, pivot + r, middle), "wireZ": at(0.0, pivot + 2 * r, middle)},
        mass=value("lever_mass", p))
    for j, (du, dv) in enumerate(((-a, -c), (a, -c)), start=1):
        ground = parts.point(f"{G}_base{j}", at(du, dv, base), fixed=True)
        parts.flexure(f"{G}_leaf{j}", ground, body[f"leaf{j}"], "leaf", u,
                      prescribed=prescribed_leaf)
    for j in (3, 4):
        parts.flexure(f"{G}_leaf{j}", body[f"leaf{j}"], carriage[f"leaf{j}"], "leaf", u,
                      prescribed=prescribed_leaf)
    for label, d in (("S", d1), ("T", d2)):
        ground = parts.point(f"{G}_base{label}", centre - ls * d, fixed=True)
        parts.flexure(f"{G}_pivot{label}", ground, lever[label], "pivot",
                      np.cross(w, d), prescribed=prescribed_leaf)
    parts.flexure(f"{G}_wireX", lever["wireX"], body["wireX"], "wire", v,
                  prescribed=prescribed_wire)
    parts.flexure(f"{G}_wireZ", lever["wireZ"], carriage["wireZ"], "wire", v,
                  prescribed=prescribed_wire)
    return carriage["push"], f"{G}_H"


def actuator_axes(angle):
    """The two push directions of the body at `angle` (degrees): outward along x, along y."""
    x, y = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    return np.array([1.0 if x >= -1e-9 else -1.0, 0.0, 0.0]), np.array(
        [0.0, 1.0 if y > 0 else -1.0, 0.0])


def effector(parts):
    """The end effector: its centre above the origin and its three attachments (node names)."""
    p = parts.p
    height = _effector_height(p)
    points = {f"M{i}": [value("effector_radius", p) * math.cos(math.radians(angle)),
                        value("effector_radius", p) * math.sin(math.radians(angle)), height]
              for i, angle in enumerate(BODY_ANGLES, start=1)}
    return parts.body("E", [0.0, 0.0, height + layout(0.01, p)], points,
                      mass=value("effector_mass", p))


def _effector_height(p):
    # the slanted springs at 45 degrees from the attachment on C, layout(0.01) inside its centre
    return value("slant_length", p) / math.sqrt(2.0)


def _slant_start_radius(p):
    return value("effector_radius", p) + value("slant_length", p) / math.sqrt(2.0)


def slanted_springs(parts, body_points, effector_points, *, prescribed):
    """The three slanted leaf springs M1 ... M3 from the bodies to the end effector."""
    for i, angle in enumerate(BODY_ANGLES, start=1):
        start = np.array(parts.nodes[body_points[i - 1]]["position"])
        end = np.array(parts.nodes[effector_points[f"M{i}"]]["position"])
        s = (end - start) / np.linalg.norm(end - start)
        tangential = np.array([-math.sin(math.radians(angle)), math.cos(math.radians(angle)),
                               0.0])
        parts.flexure(f"M{i}", body_points[i - 1], effector_points[f"M{i}"], "slant",
                      np.cross(tangential, s), prescribed=prescribed)


def scene_guidance(parameters=PARAMETERS):
    """One straight guidance alone, kinematic: over-constrained by design."""
    parts = SceneParts(parameters, dynamic=False)
    guidance(parts, 1, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    return _scene(parts, "manipulator_guidance",
                  "one straight guidance of the six-DOF manipulator, kinematic (over-constrained "
                  "by design)", dynamic=False)


def scene_stage(parameters=PARAMETERS):
    """The end-effector stage, kinematic: three translating bodies, 6 DOFs."""
    parts = SceneParts(parameters, dynamic=False)
    starts = []
    for i, angle in enumerate(BODY_ANGLES, start=1):
        radial = np.array([math.cos(math.radians(angle)), math.sin(math.radians(angle)), 0.0])
        start = parts.point(f"C{i}", _slant_start_radius(parameters) * radial, dof=("x", "y"),
                            fixed=True)
        parts.nodes[f"{start}_r"]["fixed"] = True
        starts.append(start)
    ends = effector(parts)
    slanted_springs(parts, starts, ends, prescribed=("e1", "e3"))
    return _scene(parts, "manipulator_stage",
                  "the end-effector stage of the six-DOF manipulator, kinematic: three bodies "
                  "translating in the plane, 6 DOFs", dynamic=False)


def scene_manipulator(parameters=PARAMETERS, *, frozen=(), angle_outputs=False, name=None,
                      description=None):
    """The whole manipulator, dynamic: every flexure meshed, `frozen` deformations prescribed;
    with `angle_outputs` also the end effector's rotations about x, y and z (rad) as the
    outputs E_rx, E_ry, E_rz after the encoders (its parasitic rotations)."""
    parts = SceneParts(parameters, dynamic=True, frozen=frozen)
    starts = []
    for i, angle in enumerate(BODY_ANGLES, start=1):
        radial = np.array([math.cos(math.radians(angle)), math.sin(math.radians(angle)), 0.0])
        tangential = np.array([-radial[1], radial[0], 0.0])
        inside = layout(0.01, parameters)  # m, the slanted spring's attachment inside C
        centre = (_slant_start_radius(parameters) + inside) * radial
        ux, uy = actuator_axes(angle)
        offset = layout(0.02, parameters)
        points = parts.body(f"C{i}", centre, {
            "A": centre + offset * ux, "D": centre + offset * uy,
            "M": centre - inside * radial + 0.0 * tangential}, mass=value("body_mass", parameters))
        for j, (label, axis) in enumerate((("A", ux), ("D", uy))):
            k = 2 * i - 1 + j
            anchor = centre + offset * axis + value("push_length", parameters) * axis
            push, carriage = guidance(parts, k, anchor, axis)
            thin = np.cross([0.0, 0.0, 1.0], axis)
            parts.flexure(f"{label}{i}", points[label], push, "push", thin, prescribed=LEAF)
            coordinate = "x" if abs(axis[0]) > 0.5 else "y"
            parts.inputs[f"F{k}"] = {"node": carriage, "coordinate": coordinate}
            parts.outputs[f"x{k}"] = {"node": carriage, "coordinate": coordinate,
                                      "quantity": "position"}
        starts.append(points["M"])
    ends = effector(parts)
    if angle_outputs:
        for axis in ("rx", "ry", "rz"):
            parts.outputs[f"E_{axis}"] = {"node": "E_r", "coordinate": axis,
                                          "quantity": "position"}
    slanted_springs(parts, starts, ends, prescribed=LEAF)
    name = name or ("manipulator_e1" if "e1" in frozen else "manipulator")
    what = ("every elongation prescribed zero" if "e1" in frozen
            else "every deformation released")
    segments = int(value("segments", parameters))
    description = description or (f"the six-DOF flexure manipulator, dynamic, {segments} "
                                  f"beam{'s' if segments > 1 else ''} per flexure, {what}")
    return _scene(parts, name, description, dynamic=True)


def scene_control(parameters=PARAMETERS, *, name="manipulator_control",
                  description="the six-DOF flexure manipulator's control model: dynamic, 1 "
                              "beam per flexure, every elongation prescribed zero"):
    """The control model: one beam per flexure, every elongation prescribed zero.

    75 DOFs; its ten lowest natural frequencies lie within 0.5 % of the 816-DOF model's (the
    six suspension modes and the parasitic cluster at 166 Hz), so it is the plant of the
    closed-loop studies, where every sample costs an evaluation of the nonlinear model. It
    has the end effector's angles as outputs, for its parasitic rotations. `name` and
    `description` are the scene's (examples/manipulator_mems.py writes another table's)."""
    coarse = dict(parameters)
    coarse["segments"] = (1, "-", PARAMETERS["segments"][2])
    return scene_manipulator(coarse, frozen=("e1",), angle_outputs=True, name=name,
                             description=description)


def scene_control_vcm(parameters=PARAMETERS, coils=COILS):
    """The control model with its six forces driven by voltage-driven voice coils (`coils`):
    each input F1 ... F6 becomes the drive signal (V) of the amplifier of coil VCM1 ... VCM6,
    and each coil's current (A) a state; its back-EMF damps the suspension modes."""
    scene = scene_control(parameters)
    scene["scene"] |= {"name": "manipulator_control_vcm",
                       "description": scene["scene"]["description"] + "; its six actuators "
                       "voltage-driven voice coils"}
    keys = {name: coils[name][0] for name in coils}
    scene["actuators"] = {f"VCM{name[1:]}": {"input": name, "drive": "voltage", **keys}
                          for name in scene["inputs"]}
    return scene


def _scene(parts, name, description, *, dynamic):
    scene = {"scene": {"name": name, "description": description, "dimension": 3},
             "sections": sections(parts.p, dynamic=dynamic),
             "nodes": parts.nodes, "elements": parts.elements}
    if parts.inputs:
        scene["inputs"] = parts.inputs
        scene["outputs"] = parts.outputs
    return scene


def all_scenes(parameters=PARAMETERS, *, angle_outputs=False):
    """{file name: scene dictionary} of the scenes this table writes; `angle_outputs` adds the
    end effector's angles to the dynamic ones (`scene_manipulator`; not in the committed
    scenes)."""
    scenes = [scene_guidance(parameters), scene_stage(parameters),
              scene_manipulator(parameters, angle_outputs=angle_outputs),
              scene_manipulator(parameters, frozen=("e1",), angle_outputs=angle_outputs),
              scene_control(parameters), scene_control_vcm(parameters)]
    return {f"{s['scene']['name']}.toml": s for s in scenes}


HEADER = ("Written by examples/manipulator.py from its parameter table; edit the table there and\n"
          "run `python examples/manipulator.py` rather than this file.\n{description}")


def parameter_table(parameters=PARAMETERS):
    """The parameter table as Markdown (docs/manipulator.md); also the coil table's form."""
    rows = ["| parameter | value | unit | what |", "| --- | --- | --- | --- |"]
    rows += [f"| `{name}` | {val:g} | {unit} | {what} |"
             for name, (val, unit, what) in parameters.items()]
    return "\n".join(rows) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", action="store_true", help="print the parameter table")
    parser.add_argument("--coils", action="store_true",
                        help="print the voice coils' table (manipulator_control_vcm)")
    parser.add_argument("--out", type=Path, default=SCENES, help="folder for the scenes")
    parser.add_argument("--angle-outputs", action="store_true",
                        help="add the end effector's angles about x, y, z (E_rx, E_ry, E_rz, "
                             "rad) to the dynamic scenes' outputs (the committed scenes have "
                             "none: write these with --out elsewhere)")
    args = parser.parse_args(argv)
    if args.table:
        sys.stdout.write(parameter_table())
        return 0
    if args.coils:
        sys.stdout.write(parameter_table(COILS))
        return 0
    for file_name, scene in all_scenes(angle_outputs=args.angle_outputs).items():
        text = scene_toml(scene, HEADER.format(description=scene["scene"]["description"]))
        (args.out / file_name).write_text(text)
        print(f"wrote {args.out / file_name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
