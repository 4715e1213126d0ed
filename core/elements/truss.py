"""TRUSS: the spatial truss element (SPACAR), one deformation: the elongation.

Nodal coordinates of one element, in this order (m):

    x = [x^p, y^p, z^p, x^q, y^q, z^q]

Deformation (m): e1 = |l| - l0, l = r^q - r^p. Stress resultant: the normal force
sigma1 = EA / l0 e1 + EdA / l0 e1dot (N). Distributed mass: linear interpolation of the
position, the consistent mass rho A l0 [[1/3, 1/6], [1/6, 1/3]] on the two nodal positions.
The planar PLTRUSS in three dimensions: its functions work in any dimension, so TRUSS uses
them as they are; every function works on all elements at once.
"""

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
    stiffness,
)

type_name = "TRUSS"
dimension = 3
node_kinds = ("translational", "translational")
node_roles = ("p", "q")
deformation_names = ("e1",)
deformation_stiffness = {"e1": "EA"}  # property per deformation
coordinates_per_element = 6
inertia_point_kinds = ("position", "position")
properties = ("EA", "EdA", "rho_A", "A")  # section properties used

__all__ = ["REFERENCE_WIDTH", "damping", "deformations", "deformations_entry",
           "deformations_kernel", "inertia_entry", "inertia_kernel", "inertia_matrix",
           "inertia_points", "pack_reference", "reference", "stiffness"]
