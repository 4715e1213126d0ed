"""TRUSS: the spatial truss element (SPACAR), one deformation: the elongation.

Nodal coordinates of one element, in this order (m):

    x = [x^p, y^p, z^p, x^q, y^q, z^q]

Deformation (m): e1 = |l| - l0, l = r^q - r^p. Stress resultant: the normal force
sigma1 = EA / l0 e1 + EdA / l0 e1dot (N). Distributed mass: linear interpolation of the
position, the consistent mass rho A l0 [[1/3, 1/6], [1/6, 1/3]] on the two nodal positions.
The planar PLTRUSS in three dimensions: its functions work in any dimension, so TRUSS uses
them as they are; every function works on all elements at once.
"""

from . import pltruss
from .pltruss import (
    REFERENCE_WIDTH,
    damping,
    deformations,
    deformations_entry,
    deformations_kernel,
    inertia_entry,
    inertia_kernel,
    inertia_matrix,
    inertia_points,
    pack_reference,
    reference,
    reference_problems,
    stiffness,
)
from .protocol import SchemaKey, property_names

type_name = "TRUSS"
dimension = 3
coordinates_per_element = 6
# the planar truss's nodes, deformation and inertia points, in three dimensions
node_kinds, node_roles = pltruss.node_kinds, pltruss.node_roles
deformation_names = pltruss.deformation_names
deformation_stiffness = pltruss.deformation_stiffness
inertia_point_kinds = pltruss.inertia_point_kinds
# its section keys, where the area A is one a scene may give (the planar scenes derive it)
section_schema = (*pltruss.section_schema[:-1],
                  SchemaKey("A", "m2", "cross-section area, for the normal stress"))
properties = property_names(section_schema)

__all__ = ["REFERENCE_WIDTH", "damping", "deformations", "deformations_entry",
           "deformations_kernel", "inertia_entry", "inertia_kernel", "inertia_matrix",
           "inertia_points", "pack_reference", "reference", "reference_problems", "stiffness"]
