"""The model: nodal coordinates, element groups, masses, loads, inputs and outputs.

A `Model` is a plain container built by `flexure.core.scene.building`; it holds only what a scene
declares. Coordinates are numbered in node order ("3.x", "4.phi"); deformations in element
order ("leaf_left.e2"). The node table (`Model.nodes`, with `coordinate_node`,
`coordinate_axis` and `translations` per coordinate) says which node a coordinate belongs to
and along which axis; the names are labels for people, never parsed. Each coordinate is
fixed, dependent or a DOF; each deformation is zero (prescribed), released or a DOF. The DOF
vector q lists the DOF coordinates first, then the DOF deformations, each in model order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import ModuleType

import numpy as np

from .live_models import DERIVED

FIXED, DEPENDENT, DOF = "fixed", "dependent", "dof"
ZERO, RELEASED = "zero", "released"


TRANSLATIONS = ("x", "y", "z")  # the axes of a translational node's coordinates


@dataclass(frozen=True)
class Node:
    """A node of the model: its name, its kind ("translational" or "rotational"), the indices
    of its coordinates and their axes ("x", "y", "z"; "phi" in the plane; "lambda0" ...
    "lambda3", the Euler parameters, in space)."""

    name: str
    kind: str
    coordinates: tuple
    axes: tuple

    @property
    def units(self) -> tuple[str, ...]:
        """The unit of each coordinate: m on translations, rad on a planar rotation, 1 on
        Euler parameters."""
        if self.kind == "translational":
            return ("m",) * len(self.axes)
        return ("rad",) if self.axes == ("phi",) else ("1",) * len(self.axes)


@dataclass(frozen=True)
class ElementGroup:
    """All elements of one type: their coordinate and deformation indices and properties.

    coordinate_index (n, m) and deformation_index (n, k) map each element's local coordinates
    and deformations into the model's vectors; `reference` and `properties` hold arrays (n,).
    """

    kind: ModuleType
    names: tuple[str, ...]
    coordinate_index: np.ndarray
    deformation_index: np.ndarray
    # derived from the initial coordinates when built: digested by identity (`live_models`)
    reference: dict = field(metadata={DERIVED: True})
    properties: dict

    def local(self, vector: np.ndarray) -> np.ndarray:
        """The element-local slices of a model coordinate vector.

        Parameters
        ----------
        vector : ndarray (NX,)
            A vector on the model's coordinates (any unit).

        Returns
        -------
        ndarray (n, m)
            Its entries at each element's m local coordinates.
        """
        return vector[self.coordinate_index]


GLOBAL_ROTATIONS = ("rx", "ry", "rz")  # a 3-D rotational node's rotations about global x, y, z


@dataclass(frozen=True)
class Port:
    """A named input or output of the model.

    On one model coordinate (SPACAR's INPUTF / OUTX): `coordinate` its index; an input is a
    force on it (N, or N m on a planar angle), an output its position or velocity (m, m/s,
    rad, rad/s). About a global axis of a 3-D rotational node: `euler` the indices of the
    node's four Euler parameters, `axis` "rx", "ry" or "rz" and `coordinate` None; an input is
    a moment about that axis (N m), an output the rotation-vector component about it (rad) or
    the angular velocity about it (rad/s). `flexure.core.mechanics.ports` has their maths.
    An input a voice-coil actuator drives is its amplifier's drive signal, quantity "drive"
    and unit "V" (`Actuator`): the actuator's force or moment acts on the port.
    A kinematic input (SPACAR's INPUTX / INPUTE), quantity "motion", prescribes the value of
    one coordinate (m, rad) or, with `deformation` its index, of one deformation (m); it is
    kept in `Model.kinematic_inputs`, not in `Model.inputs`
    (`flexure.core.mechanics.motions`).
    """

    name: str
    coordinate: int | None
    quantity: str = "force"  # "force", "moment", "drive" or "motion" for inputs; for outputs
    unit: str = "N"          # one of `mechanics.output_quantities`, "deformation", "stress"
    euler: tuple = ()
    axis: str = ""
    # a kinematic input (quantity "motion") on a deformation: its index (coordinate None)
    deformation: int | None = None

    @property
    def about_axis(self) -> bool:
        """Whether the port is a rotation about a global axis of a 3-D rotational node."""
        return bool(self.euler)

    @property
    def location(self) -> int | tuple[tuple[int, ...], str]:
        """What the port acts on or measures, comparable between ports: the coordinate
        index, or (the Euler parameter indices, the axis)."""
        return (self.euler, self.axis) if self.euler else self.coordinate


VOLTAGE, CURRENT = "voltage", "current"  # the drives of an actuator's amplifier


@dataclass(frozen=True)
class Actuator:
    """A voice-coil actuator (VCM) that drives one input (`flexure.core.mechanics.actuators`
    has its equations): the input's value becomes the drive signal of its amplifier, and the
    actuator's force (or moment, on a port about a global axis) acts on the input's port.

    force_constant Km (N/A, equal to the back-EMF constant in V s/m; N m/A, V s/rad on an
    angle or about a global axis),
    resistance R (ohm) and inductance L (H) of the coil; drive "voltage" (the amplifier sets
    the coil voltage) or "current"; amplifier_gain G (V/V or A/V) from the drive signal to the
    amplifier's output, which is clipped at +- saturation (V or A; inf: no limit).
    """

    name: str
    input: int  # index into Model.inputs
    force_constant: float
    resistance: float
    inductance: float
    drive: str = VOLTAGE
    amplifier_gain: float = 1.0
    saturation: float = float("inf")


@dataclass
class Model:
    """A flexible multibody model in the SPACAR formulation. SI units throughout."""

    name: str
    dimension: int
    coordinate_names: list[str]
    initial_coordinates: np.ndarray
    coordinate_status: np.ndarray
    deformation_names: list[str]
    deformation_status: np.ndarray
    groups: list[ElementGroup]
    lumped_mass: np.ndarray  # (NX,) kg on translations, kg m^2 on rotations
    loads: np.ndarray  # (NX,) constant nodal forces, N and N m
    gravity: np.ndarray  # (dimension,) m/s^2
    inputs: list[Port] = field(default_factory=list)
    outputs: list[Port] = field(default_factory=list)
    buckling_loads: np.ndarray | None = None  # (NX,) reference load of the buckling analysis
    source: str = "<dict>"
    # 3-D: rigid-body inertias of rotational nodes, [(Euler parameter indices (4,), J (3, 3)
    # kg m^2 in the node's body frame)], see flexure.core.elements.rotary_inertia
    node_inertias: list = field(default_factory=list)
    # Scene keys a user may tune without rebuilding the scene ("nodes.3.mass"), [scene] tunable
    tunable: list = field(default_factory=list)
    # The DOFs flexure chose because the scene lists none (`constraints.choose_dofs`); empty
    # when the scene lists its own
    chosen_dofs: tuple = ()
    # The node table: every node with its coordinates, in coordinate order
    nodes: tuple = ()
    # The voice-coil actuators ([actuators.NAME]); an input without one is a force (N, N m)
    actuators: list = field(default_factory=list)
    # The kinematic inputs ([inputs.NAME] kind = "motion"): Ports of quantity "motion", each on
    # a coordinate or deformation whose status is DOF (it is in q), with its held value
    kinematic_inputs: list = field(default_factory=list)
    motion_values: np.ndarray | None = None  # (n_kinematic,) m or rad: the scene's `value`s
    # (n_kinematic,) m or rad: where each input's move starts (the scene's `start`s, SPACAR's
    # INPUTX / INPUTE values); value - start is its increment over a run (DELINPX, DELINPE)
    motion_starts: np.ndarray | None = None
    # The outputs on elements (SPACAR's OUTE, OUTF): Ports of quantity "deformation" (m) or
    # "stress" (N) with their deformation's index; apart from `outputs`, which the engine reads
    element_outputs: list = field(default_factory=list)
    # The scene dictionary the model was built from (overrides applied; the scene's own
    # statuses, before meshing and DOF choice): what `to_toml` writes back
    scene: dict | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        # what each coordinate is, from the node table: its node and its axis
        self.coordinate_node = np.empty(self.nx, dtype=object)
        self.coordinate_axis = np.empty(self.nx, dtype=object)
        for node in self.nodes:
            self.coordinate_node[list(node.coordinates)] = node.name
            self.coordinate_axis[list(node.coordinates)] = node.axes
        # coordinates of translational nodes (m), the rest rotations (rad or Euler parameters)
        self.translations = np.flatnonzero(
            np.isin(self.coordinate_axis.astype(str), TRANSLATIONS))
        status = self.coordinate_status
        self.fixed_coordinates = np.flatnonzero(status == FIXED)
        self.free_coordinates = np.flatnonzero(status != FIXED)
        self.dof_coordinates = np.flatnonzero(status == DOF)
        dstatus = self.deformation_status
        self.rigid_deformations = np.flatnonzero(dstatus == ZERO)
        self.released_deformations = np.flatnonzero(dstatus == RELEASED)
        self.dof_deformations = np.flatnonzero(dstatus == DOF)
        # Deformations that carry a constitutive stress: released ones and DOF ones, but not a
        # kinematic input's: prescribed, it is a constraint (with a value), its stress
        # resultant a reaction, as a deformation prescribed zero
        prescribed = [port.deformation for port in self.kinematic_inputs
                      if port.deformation is not None]
        self.stressed_deformations = np.setdiff1d(np.flatnonzero(dstatus != ZERO), prescribed)

    @property
    def nx(self) -> int:
        """NX: the number of nodal coordinates."""
        return len(self.coordinate_names)

    @property
    def nxo(self) -> int:
        """NXO: the number of fixed coordinates (absolute constraints)."""
        return self.fixed_coordinates.size

    @property
    def neo(self) -> int:
        """NEO: the number of deformations prescribed zero (relative constraints)."""
        return self.rigid_deformations.size

    @property
    def ndof(self) -> int:
        """NX - NXO - NEO: the length of q, the DOFs and the kinematic inputs together (a
        kinematic input is a coordinate or deformation of status DOF whose value is
        prescribed); the DOFs proper number ndof - len(kinematic_inputs) (`dof_count`)."""
        return self.nx - self.nxo - self.neo

    @property
    def prescribed_dofs(self) -> np.ndarray:
        """int (n_kinematic,): the position in q of each kinematic input, in their order."""
        where = {("x", int(c)): j for j, c in enumerate(self.dof_coordinates)}
        n_x = self.dof_coordinates.size
        where.update({("e", int(d)): n_x + j for j, d in enumerate(self.dof_deformations)})
        return np.array([where[("x", p.coordinate) if p.deformation is None
                               else ("e", p.deformation)] for p in self.kinematic_inputs],
                        dtype=int)

    @property
    def free_dofs(self) -> np.ndarray:
        """int: the positions in q of the DOFs proper (q without the kinematic inputs)."""
        return np.setdiff1d(np.arange(self.declared_dof_count), self.prescribed_dofs)

    @property
    def coil_actuators(self) -> list[Actuator]:
        """The voltage-driven actuators, in scene order: each has one electrical state, its
        coil current (A), after [q - q_ref, qdot] in the integrators' state."""
        return [a for a in self.actuators if a.drive == VOLTAGE]

    @property
    def free_dof_names(self) -> list[str]:
        """Names of the DOFs proper (q without the kinematic inputs), in the order of q."""
        names = self.dof_names
        return [names[j] for j in self.free_dofs]

    @property
    def dof_names(self) -> list[str]:
        """Names of the DOFs, in the order of q."""
        return [self.coordinate_names[i] for i in self.dof_coordinates] + [
            self.deformation_names[i] for i in self.dof_deformations
        ]

    @property
    def declared_dof_count(self) -> int:
        """The number of DOFs the scene declares (coordinates plus deformations)."""
        return self.dof_coordinates.size + self.dof_deformations.size

    def dof_count(self) -> dict[str, int]:
        """The SPACAR count in the course notes' convention.

        A 3-D rotational node has four Euler parameters and, when free, one normalisation
        constraint (a rigid deformation "NODE.norm"); the course notes count it as three
        coordinates and no constraint. So here NX counts 3 per rotational node, NXO 3 per
        fixed one and NEO leaves the normalisation constraints out; NDOF is the same either
        way: (NX - n) - (NXO - n_fixed) - (NEO - n_free) = NX - NXO - NEO. The internal counts
        are the properties nx, nxo, neo.

        A kinematic input prescribes one coordinate or deformation: it takes one DOF,
        NDOF = NX - NXO - NEO - NKI, and is counted as "nki" (the key only in a model that has
        kinematic inputs, so that the count of every other model reads as before).

        Returns
        -------
        dict of str to int
            "nx", "nxo", "neo", ("nki") and "ndof".
        """
        euler = [i for i, name in enumerate(self.coordinate_names) if name.endswith(".lambda0")]
        fixed = sum(1 for i in euler if self.coordinate_status[i] == FIXED)
        norms = sum(1 for i in self.rigid_deformations
                    if self.deformation_names[i].endswith(".norm"))
        count = {"nx": self.nx - len(euler), "nxo": self.nxo - fixed, "neo": self.neo - norms}
        if self.kinematic_inputs:
            count["nki"] = len(self.kinematic_inputs)
        return count | {"ndof": self.ndof - len(self.kinematic_inputs)}

    def coordinate_index(self, name: str) -> int:
        """The index of a coordinate in the model's coordinate vectors.

        Parameters
        ----------
        name : str
            The coordinate, "NODE.COORD" ("3.x", "4.phi", "5.lambda0").

        Returns
        -------
        int
            Its index into x (NX,).

        Raises
        ------
        KeyError
            The model has no such coordinate (the message names it).
        """
        try:
            return self.coordinate_names.index(name)
        except ValueError:
            raise KeyError(f"model {self.name!r} has no coordinate {name!r}") from None
