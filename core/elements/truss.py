"""TRUSS: the spatial truss element (SPACAR), one deformation: the elongation.

Nodal coordinates of one element, in this order (m):

    x = [x^p, y^p, z^p, x^q, y^q, z^q]

Deformation (m): e1 = |l| - l0, l = r^q - r^p. Stress resultant: the normal force
sigma1 = EA / l0 e1 + EdA / l0 e1dot (N). Distributed mass: linear interpolation of the
position, the consistent mass rho A l0 [[1/3, 1/6], [1/6, 1/3]] on the two nodal positions.
The planar PLTRUSS in three dimensions; every function works on all elements at once.
"""

import numpy as np

type_name = "TRUSS"
dimension = 3
node_kinds = ("translational", "translational")
node_roles = ("p", "q")
deformation_names = ("e1",)
deformation_stiffness = {"e1": "EA"}  # property per deformation
coordinates_per_element = 6
inertia_point_kinds = ("position", "position")
properties = ("EA", "EdA", "rho_A", "A")  # section properties used

_DL = np.hstack([-np.eye(3), np.eye(3)])  # d l / d x


def reference(x0):
    """Reference data from the initial nodal coordinates x0 (n, 6): the length l0 (m)."""
    return {"l0": np.linalg.norm(x0 @ _DL.T, axis=1)}


def deformations(x, ref, order=2):
    """Elongation e (n, 1) m, its first (n, 1, 6) and second (n, 1, 6, 6) derivatives."""
    l_vec = x @ _DL.T
    length = np.linalg.norm(l_vec, axis=1)
    e = (length - ref["l0"])[:, None]
    if order == 0:
        return (e,)
    unit = l_vec / length[:, None]
    De = (unit @ _DL)[:, None, :]
    if order == 1:
        return e, De
    projector = (np.eye(3)[None] - unit[:, :, None] * unit[:, None, :]) / length[:, None, None]
    return e, De, np.einsum("ai,nab,bj->nij", _DL, projector, _DL)[:, None]


def stiffness(ref, props):
    """Deformation stiffness (n, 1, 1): EA / l0 in N/m."""
    return (props["EA"] / ref["l0"])[:, None, None]


def damping(ref, props):
    """Deformation damping (n, 1, 1): EdA / l0 in N s/m."""
    return (props["EdA"] / ref["l0"])[:, None, None]


def inertia_points(x, ref, order=2):
    """The two nodal positions p (n, 6), Dp (n, 6, 6) = I and D2p = 0 (a linear map)."""
    n = x.shape[0]
    if order == 0:
        return (x.copy(),)
    Dp = np.broadcast_to(np.eye(6), (n, 6, 6))
    if order == 1:
        return x.copy(), Dp
    return x.copy(), Dp, np.zeros((n, 6, 6, 6))


def inertia_matrix(ref, props):
    """Consistent mass on the inertia points (n, 6, 6) in kg: linear interpolation."""
    shape = np.array([[1.0 / 3.0, 1.0 / 6.0], [1.0 / 6.0, 1.0 / 3.0]])
    mass = props["rho_A"] * ref["l0"]
    return mass[:, None, None] * np.kron(shape, np.eye(3))[None]
