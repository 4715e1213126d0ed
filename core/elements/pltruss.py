"""PLTRUSS: the planar truss element (SPACAR), one deformation: the elongation.

Nodal coordinates of one element, in this order (m):

    x = [x^p, y^p, x^q, y^q]

Deformation (m):

    e1 = |l| - l0,   l = r^q - r^p

Stress resultant: the normal force sigma1 = EA / l0 * e1 + EdA / l0 * e1dot (N).
Distributed mass: the position is interpolated linearly between p and q, which gives the
consistent mass rho A l0 [[1/3, 1/6], [1/6, 1/3]] on the two nodal positions.

Every function works on all elements of this type at once: arrays shaped (n_elements, ...),
and in any dimension (the spatial TRUSS uses them as they are).
"""

import numpy as np

from ..numerics.jit import kernel
from . import entries
from .protocol import YIELD_STRESS, SchemaKey, property_names, zero_length_problems

type_name = "PLTRUSS"
dimension = 2
node_kinds = ("translational", "translational")
node_roles = ("p", "q")
deformation_names = ("e1",)
deformation_stiffness = {"e1": "EA"}  # the section key that makes each one elastic
coordinates_per_element = 4
inertia_point_kinds = ("position", "position")
section_schema = (
    SchemaKey("EA", "N", "axial stiffness E A"),
    SchemaKey("EdA", "N.s", "axial damping, the counterpart of EA", damping=True),
    SchemaKey("rho_A", "kg/m", "mass per length"),
    YIELD_STRESS,
    SchemaKey("A", "m2", "cross-section area, for the normal stress (from width and height)",
              given=False),
)
properties = property_names(section_schema)


def reference(x0):
    """Reference data from the initial nodal coordinates x0 (n, 4): the length l0 (m) and the
    dimension of the space (2; 3 for the spatial TRUSS)."""
    d = x0.shape[1] // 2
    return {"l0": np.linalg.norm(x0[:, d:] - x0[:, :d], axis=1), "dimension": d}


def reference_problems(x0):
    """[(element index, "nodes", message)] of the elements whose end nodes coincide."""
    return zero_length_problems(reference(x0)["l0"])


def deformations(x, ref, order=2):
    """Elongation e (n, 1) m, its first (n, 1, 4) and second (n, 1, 4, 4) derivatives.

    order = 0, 1 or 2 returns (e,), (e, De) or (e, De, D2e). With l = r^q - r^p and the unit
    vector u = l / |l|: De = [-u, u], D2e = [[P, -P], [-P, P]], P = (I - u u^T) / |l|.
    """
    n, m = x.shape
    d = m // 2
    l_vec = x[:, d:] - x[:, :d]
    length = np.sqrt(np.add.reduce(l_vec * l_vec, axis=1))
    e = (length - ref["l0"])[:, None]
    if order == 0:
        return (e,)
    unit = l_vec / length[:, None]
    De = np.empty((n, 1, m))
    De[:, 0, d:] = unit
    np.negative(unit, out=De[:, 0, :d])
    if order == 1:
        return e, De
    projector = (np.identity(d) - unit[:, :, None] * unit[:, None, :]) / length[:, None, None]
    D2e = np.empty((n, 1, m, m))
    D2e[:, 0, :d, :d] = D2e[:, 0, d:, d:] = projector
    np.negative(projector, out=D2e[:, 0, :d, d:])
    D2e[:, 0, d:, :d] = D2e[:, 0, :d, d:]
    return e, De, D2e


def stiffness(ref, props):
    """Deformation stiffness (n, 1, 1): EA / l0 in N/m."""
    return (props["EA"] / ref["l0"])[:, None, None]


def damping(ref, props):
    """Deformation damping (n, 1, 1): EdA / l0 in N s/m."""
    return (props["EdA"] / ref["l0"])[:, None, None]


def inertia_points(x, ref, order=2):
    """The points whose motion carries the element's mass: the two nodal positions.

    Returns p (n, 4), Dp (n, 4, 4) and D2p (n, 4, 4, 4) (zero: the map is linear).
    """
    n, m = x.shape
    p = x.copy()
    if order == 0:
        return (p,)
    Dp = np.broadcast_to(np.eye(m), (n, m, m))
    if order == 1:
        return p, Dp
    return p, Dp, np.zeros((n, m, m, m))


def inertia_matrix(ref, props):
    """Consistent mass on the inertia points (n, 4, 4) in kg: linear interpolation."""
    shape = np.array([[1.0 / 3.0, 1.0 / 6.0], [1.0 / 6.0, 1.0 / 3.0]])
    mass = props["rho_A"] * ref["l0"]
    return mass[:, None, None] * np.kron(shape, np.eye(ref["dimension"]))[None]


def section_forces(e, sigma, ref):
    """The normal force N (n,) in N of each truss, as a dict: {"N": sigma1}."""
    return {"N": sigma[:, 0]}


# -- compiled kernel: one element, the formulas above in scalars (any dimension) ----------

REFERENCE_WIDTH = 1  # [l0]


def pack_reference(ref):
    """(n, 1) float64: l0 (m) per element."""
    return np.ascontiguousarray(np.asarray(ref["l0"], float)[:, None])


@kernel
def deformations_kernel(x, ref, order, e, De, D2e):
    """One element: e (1,) and, by order, De (1, 2d) and D2e (1, 2d, 2d), every entry written.

    x (2d,) local coordinates [r^p, r^q], ref (1,) = [l0]. No allocation."""
    d = x.size // 2
    length2 = 0.0
    for a in range(d):
        la = x[d + a] - x[a]
        length2 += la * la
    length = np.sqrt(length2)
    e[0] = length - ref[0]
    if order == 0:
        return
    for a in range(d):
        u = (x[d + a] - x[a]) / length
        De[0, a] = -u
        De[0, d + a] = u
    if order == 1:
        return
    for a in range(d):
        for b in range(d):
            proj = ((1.0 if a == b else 0.0) - De[0, d + a] * De[0, d + b]) / length
            D2e[0, a, b] = D2e[0, d + a, d + b] = proj
            D2e[0, a, d + b] = D2e[0, d + a, b] = -proj


@kernel
def inertia_kernel(x, v, ref, order, p, Dp, acc):
    """One element: the points p = x (2d,), Dp = I and acc = (D2p v) v = 0 (linear map)."""
    m = x.size
    for i in range(m):
        p[i] = x[i]
    if order == 0:
        return
    for i in range(m):
        for j in range(m):
            Dp[i, j] = 1.0 if i == j else 0.0
    if order == 1:
        return
    for i in range(m):
        acc[i] = 0.0


deformations_entry = entries.deformations_entry(deformations_kernel)
inertia_entry = entries.inertia_entry(inertia_kernel)
