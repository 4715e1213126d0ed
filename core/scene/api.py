"""Building a scene in Python, in the spirit of SPACAR Light: nodes, sections, elements,
releases, inputs and outputs added one call each, then `build()` to a Model.

    from flexure.core import Scene

    s = Scene("stage", dimension=2)
    s.section("leaf", E=2.1e11, width=0.018, height=0.0005, rho=7850.0)
    s.section("bar", rho_A=2.06)
    s.node("1", position=[0.0, 0.0], fixed=["x", "y"])
    s.node("2", angle=0.0, fixed=["phi"])
    ...
    s.element("leaf_left", "PLBEAM", ["1", "2", "3", "4"], section="leaf",
              released=["e2", "e3"])
    s.input("F", node="3", coordinate="x")
    s.output("x", node="3", coordinate="x")
    model = s.build()          # the same Model the TOML scene builds, checked the same way
    text = s.to_toml()         # the scene file; load_scene of it gives the same Model again

A `Scene` holds the scene dictionary of the TOML format (docs/scene-format.md) and nothing
else: every key a call takes is that format's key (SI units: m, rad, kg, N, s, Pa), and every
check is `build_model`'s, made when `build()` runs, so a mistake reads as it would in a file
("<scene stage>: nodes.3.mass: expected a value >= 0.0, got -0.2"). A call refuses only what
would lose a value: a name given twice. `to_toml(model)` writes back the scene a model was
built from (`Model.scene`).
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from ..errors import SceneError
from .building import build_model
from .scene_writer import scene_toml

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

__all__ = ["Scene", "to_toml"]


class Scene:
    """A scene being built in Python; `build()` makes its Model, `to_toml()` its file.

    The methods that add an entry (`section`, `node`, `element`, `input`, `actuator`,
    `output`) take its name first and that table's keys of the scene format after. Each
    returns this scene, so calls can be chained, and raises SceneError when an entry of that
    name was added already (change it in `scene.data` instead). `release` and
    `buckling_load` return this scene too.

    Parameters
    ----------
    name : str
        The scene's name ([scene] name).
    dimension : int
        2 (planar) or 3 (spatial).
    gravity : sequence of float, optional
        The gravitational acceleration, m/s^2, one component per dimension (default none).
    description : str
        A line that says what the scene is.
    tunable : sequence of str
        Dotted scene keys a user may tune without rebuilding ([scene] tunable).
    """

    def __init__(self, name: str, *, dimension: int = 2,
                 gravity: Sequence[float] | None = None, description: str = "",
                 tunable: Sequence[str] = ()) -> None:
        header = {"name": name, "dimension": dimension}
        if description:
            header["description"] = description
        if gravity is not None:
            header["gravity"] = list(gravity)
        if tunable:
            header["tunable"] = list(tunable)
        self.data = {"scene": header, "sections": {}, "nodes": {}, "elements": {}}

    @property
    def source(self) -> str:
        """How messages name this scene."""
        return f"<scene {self.data['scene']['name']}>"

    def section(self, name: str, **properties: Any) -> Scene:
        """Add a [sections.NAME].

        Parameters
        ----------
        name : str
        **properties : float or str
            E (Pa), width, height, diameter (m), rho (kg/m^3), or the properties directly
            (EA N, EI N m^2, rho_A kg/m, damping EdA N s, ...): the scene format's keys.

        Returns
        -------
        Scene
            This scene.
        """
        return self._add("sections", name, properties)

    def node(self, name: str, **keys: Any) -> Scene:
        """Add a [nodes.NAME].

        Parameters
        ----------
        name : str
        **keys
            position (m) for a translational node, angle (rad, planar) or rotation (rotation
            vector, rad, spatial) for a rotational one; fixed, dof (a spatial rotational
            node's "rx", "ry", "rz"), mass (kg), inertia (kg m^2), force (N), moment (N m,
            planar).

        Returns
        -------
        Scene
            This scene.
        """
        return self._add("nodes", name, keys)

    def element(self, name: str, type: str, nodes: Sequence[str], *, section: str,
                **keys: Any) -> Scene:
        """Add an [elements.NAME].

        Parameters
        ----------
        name : str
        type : str
            A registered element type (`flexure.core.elements.ELEMENT_TYPES`): PLTRUSS,
            PLBEAM, PLSPRING, TRUSS, BEAM, SPRING.
        nodes : sequence of str
            Its nodes, in the element's order.
        section : str
            The name of its section.
        **keys
            released, dof, segments, y_axis (BEAM) as in the scene format.

        Returns
        -------
        Scene
            This scene.
        """
        return self._add("elements", name, {"type": type, "nodes": list(nodes),
                                            "section": section, **keys})

    def release(self, element: str, *deformations: str) -> Scene:
        """Release deformations of an element already added (SPACAR's RLSE).

        Parameters
        ----------
        element : str
            The element's name.
        *deformations : str
            Its deformations to release ("e2", "e3").

        Returns
        -------
        Scene
            This scene.

        Raises
        ------
        SceneError
            No element of that name was added yet.
        """
        table = self._existing("elements", element)
        released = list(table.get("released", []))
        table["released"] = released + [d for d in deformations if d not in released]
        return self

    def input(self, name: str, *, node: str | None = None, coordinate: str | None = None,
              **keys: Any) -> Scene:
        """Add an [inputs.NAME]: a force (N, or N m on a planar angle) on one coordinate, or
        on a 3-D rotational node a moment (N m) about a global axis; with kind="motion" a
        kinematic input that prescribes the coordinate, or (element=, deformation=) a
        deformation (docs/scene-format.md).

        Parameters
        ----------
        name : str
        node : str, optional
            The node it acts on.
        coordinate : str, optional
            "x", "y", "z", "phi"; "rx", "ry", "rz" about a global axis.
        **keys
            kind ("force" or "motion"), element, deformation, value (m or rad: what a static
            solution holds, the end of the move), start (m or rad: where the move starts).

        Returns
        -------
        Scene
            This scene.
        """
        given = {"node": node, "coordinate": coordinate}
        return self._add("inputs", name, {k: v for k, v in given.items() if v is not None} | keys)

    def actuator(self, name: str, *, input: str, **keys: Any) -> Scene:
        """Add an [actuators.NAME]: a voice-coil actuator driving an input.

        Parameters
        ----------
        name : str
        input : str
            The input it drives, which becomes its drive signal (V).
        **keys
            force_constant (N/A), resistance (ohm), inductance (H), drive ("voltage" or
            "current"), amplifier_gain (V/V or A/V), saturation (V or A).

        Returns
        -------
        Scene
            This scene.
        """
        return self._add("actuators", name, {"input": input, **keys})

    def output(self, name: str, *, node: str, coordinate: str,
               quantity: str = "position") -> Scene:
        """Add an [outputs.NAME]: the position or a rate of one coordinate, or on a 3-D
        rotational node the angle or a rate of it about a global axis.

        Parameters
        ----------
        name : str
        node : str
            The node it measures.
        coordinate : str
            "x", "y", "z", "phi"; "rx", "ry", "rz" about a global axis.
        quantity : str
            A quantity of `flexure.core.mechanics.output_quantities` (its table lists them
            with their units): "position" (m, rad), "velocity" (m/s, rad/s), ...

        Returns
        -------
        Scene
            This scene.
        """
        return self._add("outputs", name, {"node": node, "coordinate": coordinate,
                                           "quantity": quantity})

    def buckling_load(self, node: str, force: Sequence[float]) -> Scene:
        """Add a force to the buckling analysis' reference load ([buckling] forces).

        Parameters
        ----------
        node : str
            A translational node.
        force : sequence of float
            The force on it, N, one component per dimension.

        Returns
        -------
        Scene
            This scene.
        """
        forces = self.data.setdefault("buckling", {"forces": []})["forces"]
        forces.append({"node": node, "force": list(force)})
        return self

    def build(self, *, check: bool = True) -> Model:
        """The Model: `build_model` of a copy of this scene's dictionary, checked as a scene
        file is.

        Parameters
        ----------
        check : bool
            As in `build_model`.

        Returns
        -------
        Model
            A new one at each call: later changes to the scene do not reach it.

        Raises
        ------
        SceneError, ConstraintError
            As `build_model` raises them, the message naming the scene as a file would be
            named: "<scene NAME>: nodes.3.mass: ...".
        """
        return build_model(copy.deepcopy(self.data), source=self.source,
                           default_name=self.data["scene"]["name"], check=check)

    def to_toml(self, header: str = "") -> str:
        """The scene file's text, `scene_toml` of this scene's dictionary (`load_scene` of
        it builds the same Model).

        Parameters
        ----------
        header : str
            As in `scene_toml`.

        Returns
        -------
        str
        """
        return scene_toml(self.data, header)

    def _add(self, table, name, entry):
        entries = self.data.setdefault(table, {})
        if name in entries:
            raise SceneError(f"{self.source}: {table}.{name}: given twice; change it in "
                             f"scene.data['{table}']['{name}'] instead")
        entries[name] = copy.deepcopy(entry)
        return self

    def _existing(self, table, name):
        entries = self.data.get(table, {})
        if name not in entries:
            raise SceneError(f"{self.source}: {table}.{name}: not added yet; known: "
                             f"{', '.join(entries) or 'none'}")
        return entries[name]


def to_toml(model: Model, header: str = "") -> str:
    """The scene file of the scene `model` was built from (after its overrides, before
    meshing and DOF choice, which building it again repeats): `scene_toml` of `Model.scene`.

    Parameters
    ----------
    model : Model
        A model built from a scene.
    header : str
        As in `scene_toml`.

    Returns
    -------
    str

    Raises
    ------
    SceneError
        `model` was not built from a scene.
    """
    if getattr(model, "scene", None) is None:
        raise SceneError(f"{getattr(model, 'source', '<to_toml>')}: to_toml: expected a Model "
                         f"built from a scene, got {type(model).__name__} without one")
    return scene_toml(model.scene, header)
