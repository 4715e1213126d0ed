"""Scenes: TOML files (or dicts) that declare a model, validated on load.

A scene has the tables [scene], [sections.NAME], [nodes.NAME], [elements.NAME] and the
optional [inputs.NAME], [actuators.NAME], [outputs.NAME] and [buckling];
docs/scene-format.md documents every key. Every problem is reported as a SceneError that names
the file, the key and what is wrong; the exact-constraint check then refuses an over- or
under-constrained model (ConstraintError).

Spatial scenes (dimension = 3): translational nodes have position = [x, y, z]; a rotational
node has rotation = [rx, ry, rz] (its initial orientation as a rotation vector, rad), is
either fixed as a whole (fixed = true) or free, and may carry a rigid-body inertia
(inertia = [Jx, Jy, Jz] or a 3 x 3 list, kg m^2, in its body frame). Its coordinates are the
four Euler parameters "NODE.lambda0" ... "NODE.lambda3" (see flexure.core.numerics.rotations); the
builder adds the normalisation constraint "NODE.norm" of every free rotational node. A BEAM
needs y_axis = [.., .., ..], its principal y' axis. A section takes the keys of the elements
that use it (their section schemas) and the shape and material keys that derive them
(`scene_sections`).
"""

from __future__ import annotations

import copy
import importlib.resources
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..elements.protocol import SchemaKey
from ..errors import SceneError
from ..mechanics.constraints import check_exact_constraint, choose_dofs
from ..model import DEPENDENT, DOF, FIXED, Model, Node
from .overrides import apply_overrides
from .rotational_nodes import RotationalNodeBuilding
from .scene_actuators import ACTUATOR_KEYS, ActuatorBuilding, actuator_key
from .scene_elements import ElementBuilding
from .scene_ports import PortBuilding
from .scene_reader import MAX_ANGLE, SceneReader, show
from .scene_sections import SectionBuilding, section_key
from .spacar_input import read_spacar

TRANSLATION_AXES = {2: ("x", "y"), 3: ("x", "y", "z")}
ROTATION_AXES = {2: ("phi",), 3: ("lambda0", "lambda1", "lambda2", "lambda3")}
# The numbers a node takes, with their units (a tunable FMU parameter's unit: `scene_key`);
# the section keys are the elements' (`scene_sections`).
NODE_KEYS = {key.name: key for key in (
    SchemaKey("mass", "kg", "lumped mass of a translational node, on each of its coordinates"),
    SchemaKey("inertia", "kg.m2", "lumped rotational inertia of a rotational node"),
    SchemaKey("angle", "rad", "initial angle of a planar rotational node"),
    SchemaKey("moment", "N.m", "constant moment on a planar rotational node"),
)}
SEGMENTS_KEY = SchemaKey("segments", "1", "the number of elements a meshed element is split into")


def builtin_scenes() -> list[str]:
    """Names of the scenes that ship with flexure (usable without a checkout).

    Returns
    -------
    list of str
        The scene names, sorted, for `load_scene`.
    """
    folder = importlib.resources.files("flexure.scenes")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def scene_path(name_or_path: str | Path) -> Path:
    """The path of a scene file: an existing path, or the name of a built-in scene.

    Parameters
    ----------
    name_or_path : str or Path
        A scene file, or a built-in scene's name (with or without ".toml").

    Returns
    -------
    Path

    Raises
    ------
    SceneError
        Neither a file nor a built-in scene (the message lists the built-in ones).
    """
    path = Path(name_or_path)
    if path.is_file():
        return path
    stem = path.name[:-5] if path.name.endswith(".toml") else path.name
    builtin = importlib.resources.files("flexure.scenes") / f"{stem}.toml"
    if builtin.is_file():
        return Path(str(builtin))
    raise SceneError(
        f"{name_or_path}: no such scene file, and no built-in scene of that name "
        f"(built in: {', '.join(builtin_scenes())})"
    )


def load_scene(name_or_path: str | Path, *, overrides: dict | None = None,
               check: bool = True) -> Model:
    """Load and validate a scene file or built-in scene name into a `Model`: `build_model`
    of the file's dictionary, its messages naming the file.

    Parameters
    ----------
    name_or_path : str or Path
        A TOML scene file, a SPACAR input file (.dat), or a built-in scene's name.
    overrides : dict of str to value, optional
        {dotted scene key: value}, set on the scene before it is built and checked as the
        file's own keys are (`flexure.core.scene.overrides`), e.g.
        {"sections.leaf.height": 0.3e-3, "nodes.3.mass": 0.2} (SI units: m, kg).
    check : bool
        As in `build_model`.

    Returns
    -------
    Model
        Named by [scene] name, or else by the file's stem.

    Raises
    ------
    SceneError
        No such scene, or a file that is not UTF-8 or not valid TOML; and what `build_model`
        raises (SceneError, ConstraintError).
    """
    path = scene_path(name_or_path)
    data = parse_toml(path)
    return build_model(data, overrides=overrides, source=str(path), default_name=path.stem,
                       check=check)


def read_scene_text(path):
    """The text of a scene file (UTF-8); SceneError on an unreadable file or invalid bytes."""
    try:
        raw = Path(path).read_bytes()
    except OSError as error:
        raise SceneError(f"{path}: cannot read the scene file: {error.strerror}") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as error:
        line = raw.count(b"\n", 0, error.start) + 1
        raise SceneError(f"{path}: line {line}: not UTF-8 text: byte "
                         f"0x{raw[error.start]:02x} at offset {error.start} ({error.reason}); "
                         "TOML files must be UTF-8") from None


def parse_toml(path):
    """The dictionary of a scene file; SceneError on invalid bytes or invalid TOML.

    A SPACAR input file (suffix .dat) is read by `spacar_input.read_spacar` instead, so every
    command that takes a scene takes one."""
    if Path(path).suffix.lower() == ".dat":
        return read_spacar(path)
    text = read_scene_text(path)
    try:
        return tomllib.loads(text)
    except (tomllib.TOMLDecodeError, ValueError) as error:  # ValueError: an int too long
        raise SceneError(f"{path}: not valid TOML: {error}") from None
    except RecursionError:  # tomllib recurses once per level of nested arrays or tables
        raise SceneError(f"{path}: not a scene: its arrays or inline tables are nested "
                         "deeper than Python's recursion limit") from None


def scene_key(key: str, model: Model | None = None) -> SchemaKey | None:
    """The SchemaKey (unit, meaning, ...) of a dotted scene key that holds a number:
    "sections.NAME.KEY" (an element property, or a section's shape or material),
    "nodes.NAME.KEY" ("mass", "inertia", ...), "elements.NAME.segments" or
    "actuators.NAME.KEY" (force_constant, resistance, inductance; with the `model`, also the
    units that depend on the actuator: `scene_actuators.actuator_key`); None for any other
    key."""
    table, _, rest = key.partition(".")
    name = rest.rpartition(".")[2] if "." in rest else None
    if table == "sections" and name:
        return section_key(name)
    if table == "nodes" and name:
        return NODE_KEYS.get(name)
    if table == "elements" and name == "segments":
        return SEGMENTS_KEY
    if table == "actuators" and name:
        return ACTUATOR_KEYS.get(name) if model is None else actuator_key(model, key)
    return None


def build_model(data: dict, *, overrides: dict | None = None, source: str = "<dict>",
                default_name: str = "scene", check: bool = True) -> Model:
    """Build a `Model` from a scene dictionary, validating every key.

    Parameters
    ----------
    data : dict
        The scene dictionary, as `tomllib` reads a scene file (docs/scene-format.md).
    overrides : dict of str to value, optional
        {dotted scene key: value}, set on a copy of `data` first (`data` is not changed); an
        error in one names it as `--set KEY` (`flexure.core.scene.overrides`).
    source : str
        How messages name the scene (a file path).
    default_name : str
        The model's name when [scene] gives none.
    check : bool
        Whether to check that the model is exactly constrained.

    Returns
    -------
    Model

    Raises
    ------
    SceneError
        Every key that is missing, unknown or has a bad value, collected into one message.
    ConstraintError
        With `check`, the model is not exactly constrained.
    """
    builder = _SceneBuilder(data, source, default_name)
    if overrides:
        builder.data = apply_overrides(data, overrides, source=source)
        builder.overridden = frozenset(overrides)
    return builder.build(check=check)


class _SceneBuilder(SceneReader, SectionBuilding, ElementBuilding, RotationalNodeBuilding,
                    PortBuilding, ActuatorBuilding):
    """Builds a Model from a scene dictionary: the checked reading of values
    (`SceneReader`), the [sections] (`SectionBuilding`), the [elements] (`ElementBuilding`),
    the 3-D rotational nodes (`RotationalNodeBuilding`), the [inputs] and [outputs]
    (`PortBuilding`), the [actuators] (`ActuatorBuilding`) and the rest here."""

    def __init__(self, data, source, default_name):
        self.data = data
        self.source = source
        self.default_name = default_name
        self.problems = []  # the mistakes of the table being read (`entry`)

    # -- the scene --------------------------------------------------------------------------

    def build(self, *, check):
        data = self.table("scene file", self.data)
        self.check_keys("scene file", data, {
            "scene", "sections", "nodes", "elements", "inputs", "actuators", "outputs",
            "buckling"})
        header = self.table("scene", data.get("scene", {}))
        self.check_keys("scene", header,
                        {"name", "description", "dimension", "gravity", "tunable"})
        name = header.get("name", self.default_name)
        if not isinstance(name, str) or not name.isidentifier():
            self.fail("scene.name", f"expected an identifier (letters, digits, _), got {name!r}")
        # text only: a scene is written back (scene_toml: reduce, an FMU of overrides), and a
        # TOML date or a table has no place there
        self.string("scene.description", header.get("description", ""))
        dimension = header.get("dimension", 2)
        if isinstance(dimension, bool) or dimension not in (2, 3):
            self.fail("scene.dimension",
                      f"expected 2 (planar) or 3 (spatial), got {show(dimension)}")
        dimension = int(dimension)
        gravity = np.array(self.vector("scene.gravity", header.get("gravity", [0.0] * dimension),
                                       dimension))
        self.dimension = dimension
        # whether the scene lists any DOF (a node's or element's non-empty "dof"): meshing
        # makes DOFs of its segments only then, and flexure chooses them all otherwise
        # (`build`, `constraints.choose_dofs`)
        self.lists_dofs = any(isinstance(table, dict) and table.get("dof")
                              for part in ("nodes", "elements")
                              if isinstance(data.get(part), dict)
                              for table in data[part].values())
        self.sections = self.build_sections(self.table("sections", data.get("sections", {})),
                                            data.get("elements", {}))
        self.build_nodes(self.table("nodes", data.get("nodes", {})))
        groups, deformation_names, deformation_status = self.build_elements(
            self.table("elements", data.get("elements", {})))
        if dimension == 3:
            self.add_normalisation(groups, deformation_names, deformation_status)
            # a rotation prescribed about a global axis is its ROTATION pseudo-element's angle
            self.motion_rotations = self.prescribed_rotations(data.get("inputs", {}))
            self.rotation_dofs += self.motion_rotations
            self.add_rotation_dofs(groups, deformation_names, deformation_status)
        # a kinematic input changes the status of its coordinate or deformation (`scene_ports`)
        self.kinematic_deformation_names = deformation_names
        self.kinematic_deformation_status = deformation_status
        self.motion_values, self.motion_starts = {}, {}
        ports = self.build_ports("inputs", data.get("inputs", {}), is_input=True)
        kinematic = [port for port in ports if port.quantity == "motion"]
        inputs = [port for port in ports if port.quantity != "motion"]
        actuators, inputs = self.build_actuators(data.get("actuators", {}), inputs)
        outputs = self.build_ports("outputs", data.get("outputs", {}), is_input=False)
        element_outputs = [port for port in outputs if port.deformation is not None]
        for port in outputs:
            if port.name in {p.name for p in ports}:
                self.fail(f"outputs.{port.name}", f"the input inputs.{port.name} has the same "
                                                  "name; inputs and outputs need distinct names")
        self.check_unique("coordinate", self.coordinate_names)
        self.check_unique("deformation", deformation_names)
        buckling = self.build_buckling(data.get("buckling"))
        tunable = self.build_tunable(data, header.get("tunable", []))
        nodes = tuple(Node(name=node, kind=self.node_kind[node],
                           coordinates=tuple(self.node_coordinates[node].values()),
                           axes=tuple(self.node_coordinates[node]))
                      for node in self.node_kind)
        model = Model(
            nodes=nodes,
            name=name,
            dimension=dimension,
            coordinate_names=self.coordinate_names,
            initial_coordinates=np.array(self.initial),
            coordinate_status=np.array(self.status),
            deformation_names=deformation_names,
            deformation_status=np.array(deformation_status, dtype=object),
            groups=groups,
            lumped_mass=np.array(self.mass),
            loads=np.array(self.loads),
            gravity=gravity,
            inputs=inputs,
            outputs=[port for port in outputs if port.deformation is None],
            actuators=actuators,
            kinematic_inputs=kinematic,
            element_outputs=element_outputs,
            motion_values=np.array([self.motion_values[p.name] for p in kinematic]),
            motion_starts=np.array([self.motion_starts[p.name] for p in kinematic]),
            buckling_loads=buckling,
            source=self.source,
            node_inertias=self.node_inertias,
            tunable=tunable,
            scene=copy.deepcopy(self.data),
        )
        if not self.lists_dofs and model.ndof > 0:  # none listed: flexure chooses a valid set
            chosen = choose_dofs(model)
            if chosen is not None:
                coordinate_status, deformation_status, names = chosen
                model = replace(model, coordinate_status=coordinate_status,
                                deformation_status=deformation_status, chosen_dofs=tuple(names))
        if check:
            check_exact_constraint(model)
        return model

    def build_tunable(self, data, keys):
        """The scene keys marked tunable: each must name a number the scene declares."""
        if not isinstance(keys, list) or not all(isinstance(k, str) for k in keys):
            self.fail("scene.tunable", f"expected a list of scene keys such as "
                                       f"\"nodes.3.mass\", got {keys!r}")
        for key in set(keys):
            if keys.count(key) > 1:
                self.fail("scene.tunable", f"{key!r} is listed {keys.count(key)} times; list "
                                           "each key once")
        for key in keys:
            value = data
            for part in key.split("."):
                if not isinstance(value, dict) or part not in value:
                    self.fail("scene.tunable", f"{key!r} is not a key this scene declares")
                value = value[part]
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                self.fail("scene.tunable", f"{key!r} is not a number (got {value!r})")
        return list(keys)

    def build_nodes(self, nodes):
        if not nodes:
            self.fail("nodes", "a scene needs at least one node")
        self.node_kind, self.node_coordinates = {}, {}
        self.coordinate_names, self.initial, self.status, self.mass, self.loads = [], [], [], [], []
        self.node_inertias = []
        self.rotation_dofs = []  # (node, "rx" | "ry" | "rz") listed as DOFs
        for name, node in nodes.items():
            with self.entry():  # collected, so every entry is checked
                self.build_node(name, node)
        self.raise_problems()

    def build_node(self, name, node):
        """One [nodes.NAME]: its coordinates with their statuses, masses and loads."""
        key = f"nodes.{name}"
        node = self.table(key, node)
        if self.dimension == 3 and "position" not in node:
            self.spatial_rotational_node(key, name, node)
            return
        if ("position" in node) == ("angle" in node):
            self.fail(key, "expected exactly one of 'position' (a translational node) or "
                           "'angle' (a rotational node)")
        translational = "position" in node
        if translational:
            self.check_keys(key, node, {"position", "fixed", "dof", "mass", "force"})
            axes = TRANSLATION_AXES[self.dimension]
            values = self.vector(f"{key}.position", node["position"], len(axes))
            mass = self.number(f"{key}.mass", node.get("mass", 0.0), minimum=0.0)
            force = self.vector(f"{key}.force", node.get("force", [0.0] * len(axes)), len(axes))
            masses = [mass] * len(axes)
        else:
            self.check_keys(key, node, {"angle", "fixed", "dof", "inertia", "moment"})
            axes = ROTATION_AXES[self.dimension]
            values = [self.number(f"{key}.angle", node["angle"], limit=MAX_ANGLE)]
            # A lumped rotational inertia may be negative: SPACAR's lumped model of a bar
            # puts m/2 at both ends with J = -m l^2 / 12 each (the total stays positive).
            masses = [self.number(f"{key}.inertia", node.get("inertia", 0.0))]
            force = [self.number(f"{key}.moment", node.get("moment", 0.0))]
        fixed = self.names(f"{key}.fixed", node.get("fixed", []), axes)
        dofs = self.names(f"{key}.dof", node.get("dof", []), axes)
        for both in set(fixed) & set(dofs):
            self.fail(key, f"coordinate {both!r} is both fixed and a DOF")
        self.node_kind[name] = "translational" if translational else "rotational"
        self.node_coordinates[name] = {}
        for axis, value, mass_value, load in zip(axes, values, masses, force, strict=True):
            self.node_coordinates[name][axis] = len(self.coordinate_names)
            self.coordinate_names.append(f"{name}.{axis}")
            self.initial.append(value)
            self.status.append(FIXED if axis in fixed else DOF if axis in dofs else DEPENDENT)
            self.mass.append(mass_value)
            self.loads.append(load)

    def node(self, key, name, kind=None):
        name = str(name)
        if name not in self.node_kind:
            self.fail(key, f"unknown node {name!r}")
        if kind is not None and self.node_kind[name] != kind:
            self.fail(key, f"node {name!r} is {self.node_kind[name]}, expected a {kind} node")
        return name

    def node_values(self, name):
        """The initial coordinates of node `name` (m or rad; Euler parameters in space)."""
        return np.array([self.initial[i] for i in self.node_coordinates[name].values()])

    def add_interior_node(self, name, kind, values):
        """A node the scene builder makes (`meshing`): its coordinates dependent, no lumped
        mass or load."""
        axes = (TRANSLATION_AXES if kind == "translational" else ROTATION_AXES)[self.dimension]
        self.node_kind[name] = kind
        self.node_coordinates[name] = {}
        for axis, value in zip(axes, values, strict=True):
            self.node_coordinates[name][axis] = len(self.coordinate_names)
            self.coordinate_names.append(f"{name}.{axis}")
            self.initial.append(float(value))
            self.status.append(DEPENDENT)
            self.mass.append(0.0)
            self.loads.append(0.0)

    def coordinate(self, key, table):
        node = self.node(f"{key}.node", table.get("node"))
        axis = table.get("coordinate")
        if not isinstance(axis, str) or axis not in self.node_coordinates[node]:
            self.fail(f"{key}.coordinate",
                      f"node {node!r} has no coordinate {show(axis)}; expected one of "
                      f"{', '.join(self.node_coordinates[node])}")
        return self.node_coordinates[node][axis]

    def build_buckling(self, table):
        if table is None:
            return None
        table = self.table("buckling", table)
        self.check_keys("buckling", table, {"forces"})
        forces = table.get("forces")
        if not isinstance(forces, list) or not forces:
            self.fail("buckling.forces", "expected a list of {node, force} tables")
        loads = np.zeros(len(self.coordinate_names))
        for i, entry in enumerate(forces):
            key = f"buckling.forces[{i}]"
            entry = self.table(key, entry)
            self.check_keys(key, entry, {"node", "force"})
            node = self.node(f"{key}.node", entry.get("node"), "translational")
            axes = list(self.node_coordinates[node])
            for axis, value in zip(axes, self.vector(f"{key}.force", entry.get("force"), len(axes)),
                                   strict=True):
                loads[self.node_coordinates[node][axis]] += value
        return loads
