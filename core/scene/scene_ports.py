"""The [inputs] and [outputs] of a scene: each port on one coordinate (a force; a position or
velocity), or about a global axis of a 3-D rotational node (a moment; an angle or angular
velocity: `flexure.core.mechanics.ports`)."""

from ..model import FIXED, GLOBAL_ROTATIONS, Port
from .scene_reader import show

OUTPUT_QUANTITIES = {"position": "m", "velocity": "m/s"}


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
        [outputs.NAME] (a position or velocity; an angle or angular velocity)."""
        key = f"{section}.{name}"
        port = self.table(key, port)
        if not name.isidentifier():
            self.fail(key, "a port name must be an identifier (letters, digits, _)")
        self.check_keys(key, port, {"node", "coordinate"} if is_input
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
        unit = OUTPUT_QUANTITIES[quantity]
        if not self._is_translation(port):
            unit = unit.replace("m", "rad")
        return Port(name, self.coordinate(key, port), quantity, unit)

    def rotation_port(self, key, name, port, quantity, *, is_input):
        """A port about a global axis ("rx", "ry", "rz") of a 3-D rotational node: a moment
        input (N m), or an angle (rad) or angular velocity (rad/s) output."""
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
        unit = {"position": "rad", "velocity": "rad/s"}[quantity]
        return Port(name, None, quantity, unit, euler=euler, axis=axis)

    def _is_translation(self, port):
        return port.get("coordinate") in ("x", "y", "z")[: self.dimension]
