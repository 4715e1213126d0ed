"""The element registry: one module per element type, looked up by its SPACAR name.

An element module defines `type_name`, `dimension`, `node_kinds`, `node_roles`,
`deformation_names`, `deformation_stiffness` (the section property behind each deformation),
`coordinates_per_element`, `inertia_point_kinds`, `properties` (the section properties used)
and the pure functions `reference`, `deformations`, `stiffness`, `damping`, `inertia_points` and
`inertia_matrix`, each working on all elements of the type at once.
"""

from . import plbeam, pltruss

ELEMENT_TYPES = {module.type_name: module for module in (pltruss, plbeam)}


def element_type(name):
    """The element module for a SPACAR element name such as "PLBEAM" (KeyError if unknown)."""
    return ELEMENT_TYPES[name.upper()]
