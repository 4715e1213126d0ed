"""The [inputs] and [outputs] of a scene: each port on one coordinate (a force; a position or
a rate of it), or about a global axis of a 3-D rotational node (a moment; an angle or a rate
of it: `flexure.core.mechanics.ports`). The quantities an output on a node reads, with their
units, are `flexure.core.mechanics.output_quantities`'.

An input of `kind = "motion"` is a kinematic input (SPACAR's INPUTX, INPUTE): it prescribes
a node's coordinate (m, or rad on a planar angle) or an element's deformation (m), which then
takes the status DOF and is no DOF of the motion: NDOF = NX - NXO - NEO - NKI
(`flexure.core.mechanics.motions`). Its optional `value` is the value it holds in a static
solution, the end of its move; its optional `start` the value the move starts from (SPACAR's
INPUTX / INPUTE value, `value` - `start` its DELINPX / DELINPE increment). `start` defaults to
the scene's coordinate (a deformation's 0, the unstressed length), `value` to `start`.

An output on an element (`element`, `deformation`, `quantity = "deformation"` or
`"stress"`) reads that deformation (m) or its stress resultant (N; a bending or torsion one is
the moment over l0): SPACAR's OUTE and OUTF (`flexure.core.mechanics.element_outputs`).
"""

from ..mechanics.output_quantities import QUANTITIES, quantity_unit
from ..model import DEPENDENT, DOF, FIXED, GLOBAL_ROTATIONS, ZERO, Port
from ..numerics.rotations import rotation_vector_derivatives
from .scene_reader import show

OUTPUT_QUANTITIES = tuple(QUANTITIES)  # an output on a node (`output_quantities`)
INPUT_KINDS = ("force", "motion")
# an element's output (SPACAR's OUTE, OUTF): its deformation, or its stress resultant
ELEMENT_QUANTITIES = {"deformation": "m", "stress": "N"}


class PortBuilding:
    """The scene builder's part for [inputs] and [outputs]; uses the builder's nodes
    (`node_kind`, `node_coordinates`, `status`, `coordinate`) and `dimension`."""

    def build_ports(self, section, table, *, is_input):
        ports = []
        for name, port in self.table(section, table).items():
            with self.entry():  # collected, so every entry is checked
                ports.append(self.build_port(section, name, port, is_input=is_input))
        self.raise_problems()
        return ports

    def build_port(self, section, name, port, *, is_input):
        """One [inputs.NAME] (a force, N or N m; a moment about a global axis, N m) or
        [outputs.NAME] (a quantity of `output_quantities`: a position, velocity, ...)."""
        key = f"{section}.{name}"
        port = self.table(key, port)
        if not name.isidentifier():
            self.fail(key, "a port name must be an identifier (letters, digits, _)")
        if is_input:
            kind = port.get("kind", "force")
            if not isinstance(kind, str) or kind not in INPUT_KINDS:
                self.fail(f"{key}.kind", f"expected one of {', '.join(INPUT_KINDS)}, got "
                                         f"{show(kind)}")
            if kind == "motion":
                return self.motion_port(key, name, port)
        elif "element" in port or "deformation" in port:
            return self.element_output(key, name, port)
        self.check_keys(key, port, {"kind", "node", "coordinate"} if is_input
                        else {"node", "coordinate", "quantity"})
        quantity = "force"
        if not is_input:
            quantity = port.get("quantity", "position")
            if not isinstance(quantity, str) or quantity not in OUTPUT_QUANTITIES:
                self.fail(f"{key}.quantity", f"expected one of {', '.join(OUTPUT_QUANTITIES)}, "
                                             f"got {show(quantity)}")
        if self.dimension == 3 and self.node_kind.get(str(port.get("node"))) == "rotational":
            return self.rotation_port(key, name, port, quantity, is_input=is_input)
        if is_input:
            return Port(name, self.coordinate(key, port), "force",
                        "N" if self._is_translation(port) else "N.m")
        unit = quantity_unit(quantity, rotation=not self._is_translation(port))
        return Port(name, self.coordinate(key, port), quantity, unit)

    def rotation_port(self, key, name, port, quantity, *, is_input):
        """A port about a global axis ("rx", "ry", "rz") of a 3-D rotational node: a moment
        input (N m), or an output of its angle (rad) or a rate of it (rad/s, ...)."""
        node = str(port["node"])
        axis = port.get("coordinate")
        if not isinstance(axis, str) or axis not in GLOBAL_ROTATIONS:
            hint = (" (its Euler parameters are not ports: a moment or an angle is about a "
                    "global axis)" if isinstance(axis, str) and axis.startswith("lambda")
                    else "")
            self.fail(f"{key}.coordinate", f"node {node!r} is a 3-D rotational node: expected "
                                           f"one of {', '.join(GLOBAL_ROTATIONS)}, the "
                                           f"rotation about the global x, y or z axis, got "
                                           f"{show(axis)}{hint}")
        euler = tuple(self.node_coordinates[node].values())
        if self.status[euler[0]] == FIXED:
            self.fail(f"{key}.node", f"node {node!r} is fixed: a moment on it or its angle "
                                     "would do nothing; name a free rotational node")
        if is_input:
            return Port(name, None, "moment", "N.m", euler=euler, axis=axis)
        return Port(name, None, quantity, quantity_unit(quantity, rotation=True), euler=euler,
                    axis=axis)

    def motion_port(self, key, name, port):
        """A kinematic input: on a coordinate (node, coordinate) or a deformation (element,
        deformation), which must be free and not listed as a DOF, and becomes a DOF whose value
        is prescribed. Its held `value` goes to `self.motion_values`, its `start` to
        `self.motion_starts` (`held_value`)."""
        on_element = "element" in port or "deformation" in port
        self.check_keys(key, port, {"kind", "element", "deformation", "value", "start"}
                        if on_element else {"kind", "node", "coordinate", "value", "start"})
        if on_element:
            return self._deformation_motion(key, name, port)
        node = self.node(f"{key}.node", port.get("node"))
        if self.dimension == 3 and self.node_kind[node] == "rotational":
            return self._rotation_motion(key, name, node, port)
        index = self.coordinate(key, port)
        axis = port["coordinate"]
        if self.status[index] == FIXED:
            self.fail(f"{key}.coordinate", f"coordinate {node}.{axis} is fixed (nodes.{node}."
                                           "fixed): a kinematic input prescribes a free "
                                           "coordinate; remove it from fixed")
        if self.status[index] != DEPENDENT:
            self.fail(f"{key}.coordinate", f"coordinate {node}.{axis} is a DOF or another "
                                           "kinematic input already: a kinematic input takes "
                                           "a dependent coordinate; remove it from "
                                           f"nodes.{node}.dof")
        self.held_value(key, name, port, self.initial[index])
        self.status[index] = DOF
        unit = "m" if self._is_translation(port) else "rad"
        return Port(name, index, "motion", unit)

    def deformation_index(self, key, port):
        """(label, index) of the deformation (element, deformation) a port names."""
        element, deformation = port.get("element"), port.get("deformation")
        label = f"{element}.{deformation}"
        names = self.kinematic_deformation_names
        if not isinstance(element, str) or not isinstance(deformation, str) \
                or label not in names:
            self.fail(f"{key}.deformation", f"no deformation {show(deformation)} of an element "
                                            f"{show(element)}; expected an element of the scene "
                                            "(a meshed one by its segment, NAME_k) and one of "
                                            "its deformations, e.g. \"e1\"")
        return label, names.index(label)

    def element_output(self, key, name, port):
        """An output of an element's deformation (m) or stress resultant (N)."""
        self.check_keys(key, port, {"element", "deformation", "quantity"})
        quantity = port.get("quantity", "deformation")
        if not isinstance(quantity, str) or quantity not in ELEMENT_QUANTITIES:
            self.fail(f"{key}.quantity", f"an output on an element reads one of "
                                         f"{', '.join(ELEMENT_QUANTITIES)}, got {show(quantity)}")
        _, index = self.deformation_index(key, port)
        return Port(name, None, quantity, ELEMENT_QUANTITIES[quantity], deformation=index)

    def prescribed_rotations(self, inputs):
        """(node, axis) of every kinematic input about a global axis of a free 3-D rotational
        node, so that its ROTATION pseudo-element is made with the DOF rotations; what is
        wrong with an input is said when the input is built (`_rotation_motion`)."""
        found = []
        for port in (inputs.values() if isinstance(inputs, dict) else []):
            if not isinstance(port, dict) or port.get("kind") != "motion":
                continue
            node, axis = str(port.get("node")), port.get("coordinate")
            if (self.node_kind.get(node) == "rotational" and axis in GLOBAL_ROTATIONS
                    and (node, axis) not in self.rotation_dofs + found
                    and self.status[self.node_coordinates[node]["lambda0"]] != FIXED):
                found.append((node, axis))
        return found

    def _rotation_motion(self, key, name, node, port):
        """A kinematic input about a global axis of a 3-D rotational node: the angle of its
        ROTATION pseudo-element (rad, the rotation-vector component), prescribed."""
        self.check_keys(key, port, {"kind", "node", "coordinate", "value", "start"})
        axis = port.get("coordinate")
        if not isinstance(axis, str) or axis not in GLOBAL_ROTATIONS:
            self.fail(f"{key}.coordinate", f"node {node!r} is a 3-D rotational node: expected "
                                           f"one of {', '.join(GLOBAL_ROTATIONS)}, got "
                                           f"{show(axis)}")
        if self.status[self.node_coordinates[node]["lambda0"]] == FIXED:
            self.fail(f"{key}.node", f"node {node!r} is fixed: a kinematic input prescribes a "
                                     "free node's rotation")
        if (node, axis) not in self.motion_rotations:
            self.fail(f"{key}.coordinate", f"the rotation {node}.{axis} is a DOF "
                                           f"(nodes.{node}.dof) or another kinematic input "
                                           "already; remove it from the node's dof")
        self.motion_rotations.remove((node, axis))  # a second input on it is refused above
        index = self.kinematic_deformation_names.index(f"{node}.{axis}")
        start = rotation_vector_derivatives(self.node_values(node), order=0)[0][0]
        self.held_value(key, name, port, start[GLOBAL_ROTATIONS.index(axis)])
        return Port(name, None, "motion", "rad", deformation=index)

    def _deformation_motion(self, key, name, port):
        """A kinematic input on an element's deformation (prescribed zero in the scene)."""
        label, index = self.deformation_index(key, port)
        element = port["element"]
        if self.kinematic_deformation_status[index] != ZERO:
            self.fail(f"{key}.deformation", f"deformation {label} is released or a DOF "
                                            f"(elements.{element}): a kinematic input takes a "
                                            "deformation the scene prescribes zero; remove it "
                                            "from released and dof")
        self.held_value(key, name, port, 0.0)
        self.kinematic_deformation_status[index] = DOF
        return Port(name, None, "motion", "m", deformation=index)

    def held_value(self, key, name, port, scene_value):
        """The input's `start` (default `scene_value`, the scene's coordinate, rotation
        component or 0 on a deformation) and `value` (default `start`: an input without a move
        holds where it starts), m or rad, into `motion_starts` and `motion_values`."""
        start = self.number(f"{key}.start", port.get("start", scene_value))
        self.motion_starts[name] = start
        self.motion_values[name] = self.number(f"{key}.value", port.get("value", start))

    def _is_translation(self, port):
        return port.get("coordinate") in ("x", "y", "z")[: self.dimension]
