"""The 3-D rotational nodes of a scene: four Euler parameters each, fixed as a whole or free;
the normalisation constraint of every free one (the EULER pseudo-element, "NODE.norm", always
prescribed zero) and the rotations it lists as DOFs (the ROTATION pseudo-element, "NODE.rz",
a DOF deformation: `flexure.core.elements.rotation`)."""

import numpy as np

from ..elements import euler, rotation
from ..model import DEPENDENT, DOF, FIXED, GLOBAL_ROTATIONS, ZERO, ElementGroup
from ..numerics.rotations import from_rotation_vector
from .scene_reader import MAX_ANGLE

EULER_AXES = ("lambda0", "lambda1", "lambda2", "lambda3")


class RotationalNodeBuilding:
    """The scene builder's part for 3-D rotational nodes; uses the builder's node tables
    (`node_kind`, `node_coordinates`, `coordinate_names`, `initial`, `status`, `mass`,
    `loads`, `node_inertias`, `rotation_dofs`)."""

    def spatial_rotational_node(self, key, name, node):
        """A 3-D rotational node: four Euler parameters, fixed as a whole or free; its rotations
        about global axes listed as DOFs (`dof = ["rz"]`) become ROTATION pseudo-elements
        (`add_rotation_dofs`)."""
        if "rotation" not in node:
            self.fail(key, "expected exactly one of 'position' (a translational node) or "
                           "'rotation' (a rotational node: a rotation vector, rad)")
        self.check_keys(key, node, {"rotation", "fixed", "inertia", "dof"})
        rotation = np.array(self.vector(f"{key}.rotation", node["rotation"], 3, limit=MAX_ANGLE))
        if np.linalg.norm(rotation) > MAX_ANGLE:
            self.fail(f"{key}.rotation", f"expected a rotation vector of magnitude <= "
                                         f"{MAX_ANGLE:g} rad, got {rotation.tolist()!r}")
        lam = from_rotation_vector(rotation)
        fixed = node.get("fixed", False)
        if fixed in (["rotation"], "rotation"):
            fixed = True
        if not isinstance(fixed, bool):
            self.fail(f"{key}.fixed", "a 3-D rotational node is fixed as a whole: expected true "
                                      f"or false, got {fixed!r}")
        dofs = self.names(f"{key}.dof", node.get("dof", []), GLOBAL_ROTATIONS)
        if fixed and dofs:
            self.fail(f"{key}.dof", f"node {name!r} is fixed: its rotations cannot be DOFs")
        inertia = node.get("inertia")
        index = []
        self.node_kind[name] = "rotational"
        self.node_coordinates[name] = {}
        for axis, value in zip(EULER_AXES, lam, strict=True):
            index.append(len(self.coordinate_names))
            self.node_coordinates[name][axis] = index[-1]
            self.coordinate_names.append(f"{name}.{axis}")
            self.initial.append(float(value))
            self.status.append(FIXED if fixed else DEPENDENT)
            self.mass.append(0.0)
            self.loads.append(0.0)
        if inertia is not None:
            if isinstance(inertia, list) and len(inertia) == 3 and all(
                    isinstance(row, list) for row in inertia):
                J = np.array([self.vector(f"{key}.inertia[{i}]", row, 3)
                              for i, row in enumerate(inertia)])
                if not np.allclose(J, J.T):
                    self.fail(f"{key}.inertia", "the inertia tensor must be symmetric")
            else:
                J = np.diag(self.vector(f"{key}.inertia", inertia, 3))
            if not fixed:
                self.node_inertias.append((np.array(index), J))
        self.rotation_dofs += [(name, axis) for axis in dofs]

    def add_normalisation(self, groups, deformation_names, deformation_status):
        """One EULER pseudo-element (lambda . lambda = 1) per free 3-D rotational node."""
        names, coords = [], []
        for name, kind in self.node_kind.items():
            index = list(self.node_coordinates[name].values())
            if kind == "rotational" and self.status[index[0]] != FIXED:
                names.append(name)
                coords.append(index)
        if not names:
            return
        start = len(deformation_names)
        for name in names:
            deformation_names.append(f"{name}.norm")
            deformation_status.append(ZERO)
        coords = np.array(coords, dtype=int)
        groups.append(ElementGroup(
            kind=euler, names=tuple(names), coordinate_index=coords,
            deformation_index=np.arange(start, start + len(names))[:, None],
            reference=euler.reference(np.array(self.initial)[coords]), properties={}))

    def add_rotation_dofs(self, groups, deformation_names, deformation_status):
        """One ROTATION pseudo-element per rotation a 3-D rotational node lists as a DOF: its
        deformation "NODE.rz" (the rotation-vector component, rad) with the status DOF."""
        if not self.rotation_dofs:
            return
        start = len(deformation_names)
        for name, axis in self.rotation_dofs:
            deformation_names.append(f"{name}.{axis}")
            deformation_status.append(DOF)
        coords = np.array([list(self.node_coordinates[name].values())
                           for name, _ in self.rotation_dofs], dtype=int)
        groups.append(ElementGroup(
            kind=rotation, names=tuple(f"{name}.{axis}" for name, axis in self.rotation_dofs),
            coordinate_index=coords,
            deformation_index=np.arange(start, start + len(self.rotation_dofs))[:, None],
            reference=rotation.reference(np.array(self.initial)[coords],
                                         [axis for _, axis in self.rotation_dofs]),
            properties={}))
