"""The element registry: one module per element type, looked up by its SPACAR name.

An element module defines `type_name`, `dimension`, `node_kinds`, `node_roles`,
`deformation_names`, `deformation_stiffness` (the section property behind each deformation),
`coordinates_per_element`, `inertia_point_kinds`, `properties` (the section properties used)
and the pure functions `reference`, `deformations`, `stiffness`, `damping`, `inertia_points` and
`inertia_matrix`, each working on all elements of the type at once. Elements may set
`needs_orientation` (the scene gives a principal axis: reference(x0, y_axis)) and define
`random_coordinates(rng, count)` for the derivative tests. The normalisation constraint of
3-D rotational nodes (`euler`) follows the same interface but is not registered: the scene
builder adds it, a scene cannot name it.

The arrays these functions return may be shared between calls (a constant second derivative
of the inertia points is returned from the reference data, read-only): callers read them and
never modify them in place.
"""

from . import beam, plbeam, pltruss, truss

ELEMENT_TYPES = {module.type_name: module for module in (pltruss, plbeam, truss, beam)}


def element_type(name):
    """The element module for a SPACAR element name such as "PLBEAM" (KeyError if unknown)."""
    return ELEMENT_TYPES[name.upper()]
