"""ROTATION: the rotation of a 3-D rotational node about a global axis, as a pseudo-element
whose one deformation is a DOF.

Nodal coordinates: the node's Euler parameters x = [lambda0, lambda1, lambda2, lambda3]. Its
single "deformation" is the rotation-vector component about the global axis k (x, y or z) of
the element, rad (`flexure.core.numerics.rotations.rotation_vector_derivatives`):

    e = phi_k(lambda),     D e = d phi_k / d lambda,     D2 e = d2 phi_k / d lambda2,

the same function as an angle output about that axis, and the scene's `rotation = [rx, ry,
rz]` read back. The scene builder adds one per rotation a 3-D rotational node lists as a DOF
(`dof = ["rz"]`), with the status DOF, so the DOF vector holds the angle itself (rad) and the
kinematics, DF, D2F, the tangent and the engine treat it like any DOF deformation (SPACAR's
relative DOFs). It has no stiffness, damping or mass. It is not in the element registry: a
scene cannot name it as an element. The angle is continuous for rotations below pi (the
rotation vector's angle is taken in [0, pi]).
"""

import numpy as np

from ..numerics.jit import kernel
from ..numerics.rotation_kernels import rotation_vector_component
from ..numerics.rotations import rotation_vector_derivatives
from . import entries

type_name = "ROTATION"
dimension = 3
node_kinds = ("rotational",)
node_roles = ("p",)
deformation_names = ("angle",)
deformation_stiffness = {"angle": "none"}
coordinates_per_element = 4
inertia_point_kinds = ()
properties = ()
AXES = ("rx", "ry", "rz")


def reference(x0, axes):
    """The global axis of each element (0, 1, 2 for "rx", "ry", "rz"), as floats."""
    return {"axis": np.array([AXES.index(axis) for axis in axes], dtype=float)}


def deformations(x, ref, order=2):
    """e = phi_k (n, 1), its first (n, 1, 4) and second (n, 1, 4, 4) derivatives."""
    k = ref["axis"].astype(int)
    rows = np.arange(x.shape[0])
    found = rotation_vector_derivatives(x, order=order)
    result = [found[0][rows, k][:, None]]
    for derivative in found[1:]:
        result.append(derivative[rows, k][:, None])
    return tuple(result)


def stiffness(ref, props):
    """No stiffness: the angle is a DOF that carries no stress."""
    return np.zeros((ref["axis"].size, 1, 1))


def damping(ref, props):
    """No damping."""
    return stiffness(ref, props)


# -- compiled kernel ------------------------------------------------------------------------

REFERENCE_WIDTH = 1  # the axis


def pack_reference(ref):
    """(n, 1) float64: the axis of each element."""
    return np.ascontiguousarray(np.asarray(ref["axis"], float)[:, None])


@kernel
def deformations_kernel(x, ref, order, e, De, D2e):
    """One element: e = phi_k (1,) and, by order, its derivatives De (1, 4), D2e (1, 4, 4)."""
    e[0] = rotation_vector_component(x, int(ref[0]), order, De[0], D2e[0])


deformations_entry = entries.deformations_entry(deformations_kernel)
