"""The element protocol: what an element module must define, checked when it registers.

An element type is one module (`core/elements/<name>.py`) that defines, for all elements of
the type at once (arrays shaped (n_elements, ...)):

Identity and topology
    type_name (str, upper case, the scene's `type`), dimension (2 or 3), node_kinds (tuple of
    "translational" / "rotational", in the order of the scene's `nodes`), node_roles (the
    element end, "p" or "q", of each node), coordinates_per_element (int: the sum of the
    nodes' coordinates, d per translational node, 1 per planar and 4 per spatial rotational
    node).
Deformations
    deformation_names (tuple of str, e.g. ("e1", "e2")), reference(x0) -> dict of (n,) arrays
    (the reference data from the initial coordinates x0 (n, m)), deformations(x, ref, order)
    -> (e, De, D2e) up to `order` (shapes (n, k), (n, k, m), (n, k, m, m)).
Stiffness and damping
    deformation_stiffness ({deformation: the section key that makes it elastic}: a released
    deformation needs that key > 0), stiffness(ref, props) and damping(ref, props) -> (n, k, k)
    from the section properties props ({key: (n,) array}).
Mass
    inertia_point_kinds (tuple of "position" / "tangent", one per point of d components),
    inertia_points(x, ref, order) -> (p, Dp, D2p) and inertia_matrix(ref, props) -> Mp (n, P, P)
    (the kinetic energy is 1/2 pdot^T Mp pdot). An element without mass of its own returns a
    zero Mp; the assembly gives an element group mass when its sections have rho_A.
Section schema
    section_schema (tuple of `SchemaKey`: every section key the element reads, with its unit,
    default and meaning) and properties (the tuple of their names, `property_names`).
Compiled kernels (for `flexure.core.engine`)
    REFERENCE_WIDTH (int >= 1) and pack_reference(ref) -> (n, REFERENCE_WIDTH) float64 rows,
    deformations_entry and inertia_entry: C entries made by `entries.deformations_entry` /
    `entries.inertia_entry` from the element's one-element kernels.

Optional: deformation_units (a tuple of "m" or "1" per deformation, default all "m": the
unit its Newton tolerance is measured in, `mechanics.scales`), needs_orientation (True: the
scene gives a principal axis, reference(x0, y_axis)),
reference_properties (a tuple of section keys of its schema that the deformations depend on:
reference(x0, ..., properties={key: (n,) array}) takes them, as a BEAM's Ip_A),
reference_problems(x0[, y_axis]) -> [(element index, scene key, message)] for reference
configurations the element cannot take (a zero length, an axis along the beam: the scene
names the element and refuses it), section_forces(e, sigma, ref) (stresses), and
random_coordinates(rng, count) (the derivative tests' configurations).

`check_element` collects every missing or malformed attribute and raises one
`ElementProtocolError` that names the module and each problem.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import FlexureError
from ..numerics.jit import DEFORMATIONS_ENTRY, INERTIA_ENTRY

NODE_KINDS = ("translational", "rotational")
POINT_KINDS = ("position", "tangent")
ROTATION_WIDTH = {2: 1, 3: 4}  # coordinates of a rotational node: phi; four Euler parameters
MIN_LENGTH = 1e-12  # m: an element that divides by its length refuses a shorter one


class ElementProtocolError(FlexureError, TypeError):
    """An element module does not define what the element protocol asks for."""


class _Required:
    """The default of a section key that every section of the element must give."""

    def __repr__(self):
        return "REQUIRED"


REQUIRED = _Required()


@dataclass(frozen=True)
class SchemaKey:
    """One key of a section (or a node) that a scene may give.

    name: the scene key; unit: its SI unit as FMI writes it ("N", "N.m2", "N.s/m", "1");
    meaning: one line; default: the value when the section leaves it out (`REQUIRED`: it may
    not); given: whether a scene may give it (False: it is only derived from other keys, as
    a planar section's A and Wz from width and height); positive: a given value must be > 0
    (a dimension), else >= 0; damping: it is a damping coefficient (zero is a valid value
    where any other property must be > 0, e.g. for a tunable FMU parameter).
    """

    name: str
    unit: str
    meaning: str
    default: object = 0.0
    given: bool = True
    positive: bool = False
    damping: bool = False

    @property
    def required(self):
        return self.default is REQUIRED


# the material's yield stress, on every element whose von Mises stress flexure computes: the
# analyses name a stress above it (default: none given, nothing is compared)
YIELD_STRESS = SchemaKey("yield_stress", "Pa", "the material's yield stress: a von Mises "
                         "stress above it is named (default: none)", default=float("inf"),
                         positive=True)


def property_names(schema):
    """The names of a section schema's keys, in order: an element's `properties`."""
    return tuple(key.name for key in schema)


def zero_length_problems(l0):
    """[(i, "nodes", message)] for every element whose reference length l0 (n,) in m is not
    above MIN_LENGTH: for elements whose deformations divide by their length."""
    return [(i, "nodes", f"zero-length element: its end nodes coincide ({length:.3g} m)")
            for i, length in enumerate(np.asarray(l0, float)) if not length > MIN_LENGTH]


# (attribute, what it must be) of every registered element
_FUNCTIONS = ("reference", "deformations", "stiffness", "damping", "inertia_points",
              "inertia_matrix", "pack_reference")
_OPTIONAL_FUNCTIONS = ("reference_problems", "section_forces", "random_coordinates")


def element_problems(kind):
    """Every way in which `kind` (an element module) misses the protocol: a list of str."""
    problems = []

    def attribute(name, check, expected):
        if not hasattr(kind, name):
            problems.append(f"{name} is missing ({expected})")
            return None
        value = getattr(kind, name)
        if not check(value):
            problems.append(f"{name} = {value!r}: expected {expected}")
            return None
        return value

    def names(value, allowed=None):
        return (isinstance(value, tuple) and all(isinstance(v, str) for v in value)
                and (allowed is None or set(value) <= set(allowed)))

    attribute("type_name", lambda v: isinstance(v, str) and v.isidentifier() and v.isupper(),
              "an upper-case name such as 'PLBEAM'")
    dimension = attribute("dimension", lambda v: v in (2, 3) and not isinstance(v, bool),
                          "2 or 3")
    node_kinds = attribute("node_kinds", lambda v: names(v, NODE_KINDS) and len(v) > 0,
                           f"a non-empty tuple of {' / '.join(NODE_KINDS)}")
    roles = attribute("node_roles", lambda v: names(v, ("p", "q")), "a tuple of 'p' / 'q'")
    if node_kinds is not None and roles is not None and len(roles) != len(node_kinds):
        problems.append(f"node_roles has {len(roles)} entries for {len(node_kinds)} node_kinds")
    width = attribute("coordinates_per_element", lambda v: isinstance(v, int) and v > 0,
                      "a positive int")
    if None not in (dimension, node_kinds, width):
        expected = sum(dimension if k == "translational" else ROTATION_WIDTH[dimension]
                       for k in node_kinds)
        if width != expected:
            problems.append(f"coordinates_per_element = {width}, but its node_kinds have "
                            f"{expected} coordinates in {dimension}-D")
    deformations = attribute("deformation_names",
                             lambda v: names(v) and len(v) > 0 and len(set(v)) == len(v),
                             "a non-empty tuple of distinct names")
    attribute("inertia_point_kinds", lambda v: names(v, POINT_KINDS),
              f"a tuple of {' / '.join(POINT_KINDS)}")
    schema = attribute("section_schema",
                       lambda v: isinstance(v, tuple) and all(isinstance(k, SchemaKey)
                                                              for k in v),
                       "a tuple of SchemaKey")
    if schema is not None:
        keys = property_names(schema)
        for key in sorted({k for k in keys if keys.count(k) > 1}):
            problems.append(f"section_schema lists {key!r} {keys.count(key)} times")
        attribute("properties", lambda v: v == keys,
                  f"property_names(section_schema) = {keys!r}")
    stiffness = attribute("deformation_stiffness", lambda v: isinstance(v, dict),
                          "a dict {deformation: section key}")
    if None not in (stiffness, deformations) and set(stiffness) != set(deformations):
        problems.append(f"deformation_stiffness names {sorted(stiffness)}, expected every "
                        f"deformation {sorted(deformations)}")
    if None not in (stiffness, schema):
        unknown = sorted(v for v in stiffness.values() if v not in property_names(schema))
        if unknown:
            problems.append(f"deformation_stiffness uses {unknown}, which section_schema does "
                            "not declare")
    attribute("REFERENCE_WIDTH", lambda v: isinstance(v, int) and v >= 1, "an int >= 1")
    for name in _FUNCTIONS:
        attribute(name, callable, "a function")
    for name in _OPTIONAL_FUNCTIONS:
        if hasattr(kind, name):
            attribute(name, callable, "a function")
    for name, signature, maker in (("deformations_entry", DEFORMATIONS_ENTRY,
                                    "entries.deformations_entry(deformations_kernel)"),
                                   ("inertia_entry", INERTIA_ENTRY,
                                    "entries.inertia_entry(inertia_kernel)")):
        attribute(name, lambda v, s=signature: getattr(v, "signature", None) == s,
                  f"a C entry with the engine's signature, {maker}")
    if hasattr(kind, "needs_orientation"):
        attribute("needs_orientation", lambda v: isinstance(v, bool), "True or False")
    if hasattr(kind, "reference_properties"):
        keys = property_names(schema) if schema is not None else ()
        attribute("reference_properties",
                  lambda v: names(v) and set(v) <= set(keys),
                  "a tuple of the section keys (section_schema) that reference() takes")
    return problems


def check_element(kind, registered=()):
    """Raise ElementProtocolError naming `kind` and every problem unless it follows the
    protocol; `registered`: the element modules already registered, whose type names it must
    not take and whose section keys of the same name must have its units."""
    problems = element_problems(kind)
    type_name = getattr(kind, "type_name", None)
    for other in registered:
        if other is kind:
            continue
        if other.type_name == type_name:
            problems.append(f"type_name {type_name!r} is already registered by "
                            f"{other.__name__}")
        theirs = {key.name: key for key in other.section_schema}
        for key in getattr(kind, "section_schema", ()):
            if isinstance(key, SchemaKey) and key.name in theirs and (
                    theirs[key.name].unit != key.unit):
                problems.append(f"section key {key.name!r} in {key.unit}, but "
                                f"{other.type_name} reads it in {theirs[key.name].unit}: a "
                                "section key has one meaning")
    if problems:
        name = getattr(kind, "__name__", repr(kind))
        raise ElementProtocolError(f"element module {name} does not follow the element "
                                   "protocol (core/elements/protocol.py):\n" + "\n".join(
                                       f"  {p}" for p in problems))
