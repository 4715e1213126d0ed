"""PLSPRING: a linear spring and damper between two translational nodes, in the plane.

Nodal coordinates of one element, in this order (m):

    x = [x^p, y^p, x^q, y^q]

Deformations (m): the displacement of q relative to p since the reference configuration, in
global axes,

    e1 = (x^q - x^p) - (x^q_0 - x^p_0),    e2 = (y^q - y^p) - (y^q_0 - y^p_0),

so De = [-I, I] and D2e = 0: the element is linear, and its nodes may coincide (a bushing, a
support stiffness, the compliance of a joint). Stress resultants: the force on q (on p its
opposite), sigma = diag(kx, ky) e + diag(cx, cy) edot in N, from the section's stiffness
(N/m) and damping (N s/m) per global axis. Each deformation is elastic (released, which needs
its stiffness > 0), rigid (zero: the nodes move together along that axis, as a joint) or a DOF,
as any element's.

Global axes make the spring the one a support or bushing has when the mechanism turns little;
it does not turn with the nodes. It has no mass of its own (lumped masses go on its nodes): its
inertia points are its two nodal positions with a zero mass matrix, which also draw it.

Every function works on all elements at once and in any dimension (the spatial SPRING uses
them as they are, with kz and cz).
"""

import numpy as np

from ..numerics.jit import kernel
from . import entries, pltruss
from .protocol import SchemaKey, property_names

type_name = "PLSPRING"
dimension = 2
node_kinds = ("translational", "translational")
node_roles = ("p", "q")
deformation_names = ("e1", "e2")
deformation_stiffness = {"e1": "kx", "e2": "ky"}  # the section key that makes each elastic
coordinates_per_element = 4
inertia_point_kinds = ("position", "position")
section_schema = (
    SchemaKey("kx", "N/m", "stiffness along x: the force on q per metre of e1"),
    SchemaKey("ky", "N/m", "stiffness along y: the force on q per metre of e2"),
    SchemaKey("cx", "N.s/m", "damping along x: the force on q per m/s of e1", damping=True),
    SchemaKey("cy", "N.s/m", "damping along y: the force on q per m/s of e2", damping=True),
)
properties = property_names(section_schema)
AXES = "xyz"
# the inertia points are the two nodal positions, as a truss's
inertia_points, inertia_kernel = pltruss.inertia_points, pltruss.inertia_kernel
inertia_entry = pltruss.inertia_entry


def reference(x0):
    """Reference data from the initial coordinates x0 (n, 2d): the offset r^q_0 - r^p_0 (n, d)
    in m (zero for coincident nodes)."""
    d = x0.shape[1] // 2
    return {"offset": x0[:, d:] - x0[:, :d]}


def deformations(x, ref, order=2):
    """e (n, d) m, De (n, d, 2d) and D2e (n, d, 2d, 2d) (zero) up to `order` (0, 1 or 2)."""
    n, m = x.shape
    d = m // 2
    e = x[:, d:] - x[:, :d] - ref["offset"]
    if order == 0:
        return (e,)
    De = np.broadcast_to(np.hstack([-np.eye(d), np.eye(d)]), (n, d, m))
    if order == 1:
        return e, De
    return e, De, np.zeros((n, d, m, m))


def _diagonal(ref, props, prefix):
    """(n, d, d) diag(prefix_x, prefix_y[, prefix_z]) of the section properties."""
    n, d = ref["offset"].shape
    matrix = np.zeros((n, d, d))
    for a in range(d):
        matrix[:, a, a] = props[f"{prefix}{AXES[a]}"]
    return matrix


def stiffness(ref, props):
    """Deformation stiffness (n, d, d): diag(kx, ky[, kz]) in N/m."""
    return _diagonal(ref, props, "k")


def damping(ref, props):
    """Deformation damping (n, d, d): diag(cx, cy[, cz]) in N s/m."""
    return _diagonal(ref, props, "c")


def inertia_matrix(ref, props):
    """No mass of its own: a zero (n, 2d, 2d) on the two nodal positions (kg)."""
    n, d = ref["offset"].shape
    return np.zeros((n, 2 * d, 2 * d))


# -- compiled kernel: one element, the formulas above in scalars (any dimension) ----------

REFERENCE_WIDTH = 2  # [offset_x, offset_y]; the spatial SPRING's is 3


def pack_reference(ref):
    """(n, d) float64: the offset r^q_0 - r^p_0 (m) per element."""
    return np.ascontiguousarray(ref["offset"], dtype=float)


@kernel
def deformations_kernel(x, ref, order, e, De, D2e):
    """One element: e (d,) and, by order, De (d, 2d) = [-I, I] and D2e (d, 2d, 2d) = 0, every
    entry written. x (2d,) local coordinates [r^p, r^q], ref (d,) the offset. No allocation."""
    d = x.size // 2
    for a in range(d):
        e[a] = x[d + a] - x[a] - ref[a]
    if order == 0:
        return
    for a in range(d):
        for i in range(2 * d):
            De[a, i] = 0.0
        De[a, a] = -1.0
        De[a, d + a] = 1.0
    if order == 1:
        return
    for a in range(d):
        for i in range(2 * d):
            for j in range(2 * d):
                D2e[a, i, j] = 0.0


deformations_entry = entries.deformations_entry(deformations_kernel)
