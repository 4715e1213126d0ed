"""SPRING: a linear spring and damper between two translational nodes, in space.

Nodal coordinates (m): x = [x^p, y^p, z^p, x^q, y^q, z^q]. Deformations (m): the displacement
of q relative to p since the reference configuration in global axes, e1, e2, e3 along x, y, z
(De = [-I, I], D2e = 0; the nodes may coincide). Stress resultants: the force on q,
sigma = diag(kx, ky, kz) e + diag(cx, cy, cz) edot (N). No mass of its own. The planar
PLSPRING in three dimensions: its functions work in any dimension, so SPRING uses them as they
are.
"""

from . import plspring
from .protocol import SchemaKey, property_names

# the planar spring's maths and kernels, which work in any dimension
reference, deformations = plspring.reference, plspring.deformations
stiffness, damping, inertia_matrix = plspring.stiffness, plspring.damping, plspring.inertia_matrix
inertia_points, inertia_kernel = plspring.inertia_points, plspring.inertia_kernel
deformations_kernel, pack_reference = plspring.deformations_kernel, plspring.pack_reference
deformations_entry, inertia_entry = plspring.deformations_entry, plspring.inertia_entry

type_name = "SPRING"
dimension = 3
coordinates_per_element = 6
node_kinds, node_roles = plspring.node_kinds, plspring.node_roles
inertia_point_kinds = plspring.inertia_point_kinds
deformation_names = ("e1", "e2", "e3")
deformation_stiffness = {"e1": "kx", "e2": "ky", "e3": "kz"}
section_schema = (
    *plspring.section_schema[:2],
    SchemaKey("kz", "N/m", "stiffness along z: the force on q per metre of e3"),
    *plspring.section_schema[2:],
    SchemaKey("cz", "N.s/m", "damping along z: the force on q per m/s of e3", damping=True),
)
properties = property_names(section_schema)
REFERENCE_WIDTH = 3  # [offset_x, offset_y, offset_z]
