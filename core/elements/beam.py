"""BEAM: the spatial beam element (SPACAR), six deformations.

Nodal coordinates of one element, in this order (m, and dimensionless Euler parameters):

    x = [x^p, y^p, z^p, lambda^p (4), x^q, y^q, z^q, lambda^q (4)]

The element frame (n_x', n_y', n_z'): n_x' along the initial l = r^q - r^p, n_y' the principal
axis the scene gives (its part normal to n_x'), n_z' = n_x' x n_y'. Each node carries that
frame rotated with it: n^p = R(lambda^p) a^p with a^p the frame in the node's body frame at
the reference configuration (so the deformations are zero there). With l = r^q - r^p:

    e2 = l0 / 2 [(n_z'^p . n_y'^q) - (n_y'^p . n_z'^q)]             torsion (m)
    e3 = -(n_z'^p . l),   e4 = (n_z'^q . l)                         bending in x'z' (m)
    e5 =  (n_y'^p . l),   e6 = -(n_y'^q . l)                        bending in x'y' (m)
    e1 = |l| - l0 + (2 e3^2 + e3 e4 + 2 e4^2 + 2 e5^2 + e5 e6 + 2 e6^2) / (30 l0)

as in the course notes, with the second-order terms of the planar PLBEAM for both bending
planes (the consistent geometric stiffness, 10 EI / l0^2 per clamped-guided spring). The
torsion-related second-order term of SPACAR's elongation (the shortening of a twisted beam,
quadratic in e2) is left out: it matters only for buckling under large torsion, and leaving it
out keeps a planar motion of a spatial model identical to the planar model's.

Stress resultants (all in N, as the deformations are lengths):

    sigma1 = EA / l0 e1                               normal force
    sigma2 = GIt / l0^3 e2                            torque / l0 (pure torsion: GIt / l)
    [sigma3, sigma4] = EIy' / l0^3 [[4, -2], [-2, 4]] [e3, e4]
    [sigma5, sigma6] = EIz' / l0^3 [[4, -2], [-2, 4]] [e5, e6]

plus the same with EdA, GdIt, EdIy', EdIz' for damping. EIy' belongs to bending about y'
(deflection along z', e3 and e4), EIz' to bending about z' (deflection along y', e5, e6); a
planar motion in the x'y' plane is the planar PLBEAM with EI = EIz'.

Distributed mass: the position along the beam is the cubic Hermite interpolation between r^p,
r^q and the end tangents l0 n_x'^p, l0 n_x'^q, which gives the consistent mass
rho A l0 / 420 [[156, 22, 54, -13], ...] on those four points (3 components each), as PLBEAM.
Rotational inertia of the section, rho (Iy' + Iz') about x', rho Iy' about y' and rho Iz'
about z' per unit length: the section's kinetic energy 1/2 omega^T J omega equals
1/2 (rho Iz' |n_y'_dot|^2 + rho Iy' |n_z'_dot|^2) (as |omega x n|^2 sums to it), so with the
section axes n_y', n_z' interpolated linearly between the nodes it is the consistent mass
l0 [[1/3, 1/6], [1/6, 1/3]] times rho Iz' on (n_y'^p, n_y'^q) and times rho Iy' on
(n_z'^p, n_z'^q): four more inertia points (linearly interpolated rotations: the classical
consistent torsional inertia rho Ip l0 / 6 [[2, 1], [1, 2]]).

Every function works on all elements of this type at once: arrays shaped (n_elements, ...).
"""

import numpy as np

from ..rotations import from_rotation_vector, rotate, rotation_matrix
from .plbeam import HERMITE_MASS

type_name = "BEAM"
dimension = 3
node_kinds = ("translational", "rotational", "translational", "rotational")
node_roles = ("p", "p", "q", "q")
deformation_names = ("e1", "e2", "e3", "e4", "e5", "e6")
deformation_stiffness = {"e1": "EA", "e2": "GIt", "e3": "EIy", "e4": "EIy", "e5": "EIz",
                         "e6": "EIz"}
coordinates_per_element = 14
inertia_point_kinds = ("position", "tangent", "position", "tangent",  # Hermite
                       "tangent", "tangent", "tangent", "tangent")  # n_y'^p n_z'^p n_y'^q n_z'^q
properties = ("EA", "GIt", "EIy", "EIz", "EdA", "GdIt", "EdIy", "EdIz", "rho_A", "rho_Iy",
              "rho_Iz", "A", "Wy", "Wz", "Wt", "circular")
needs_orientation = True  # the scene gives the principal y' axis of every beam

_P, _LP, _Q, _LQ = slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 14)
_DL = np.zeros((3, 14))
_DL[:, _P] = -np.eye(3)
_DL[:, _Q] = np.eye(3)


def default_y_axis(l_vec):
    """A y' axis normal to l when the scene gives none: the global axis least along l."""
    axes = np.eye(3)[np.argmin(np.abs(l_vec), axis=1)]
    return axes


def reference(x0, y_axis=None):
    """Reference data from the initial coordinates x0 (n, 14) and the y' axes (n, 3).

    l0 (m) and the element frame in the body frames of p and q: ax_p, ay_p, az_p, ax_q, ay_q,
    az_q (n, 3). Raises ValueError when a y' axis is along the beam.
    """
    l_vec = x0 @ _DL.T
    l0 = np.linalg.norm(l_vec, axis=1)
    n_x = l_vec / np.where(l0 > 0, l0, 1.0)[:, None]
    y = default_y_axis(n_x) if y_axis is None else np.asarray(y_axis, float)
    y = y - np.einsum("na,na->n", y, n_x)[:, None] * n_x
    size = np.linalg.norm(y, axis=1)
    if np.any(size < 1e-9):
        raise ValueError("the y' axis of a beam must not lie along the beam")
    n_y = y / size[:, None]
    n_z = np.cross(n_x, n_y)
    ref = {"l0": l0}
    for node, cols in (("p", _LP), ("q", _LQ)):
        R = rotation_matrix(x0[:, cols])
        for axis, vector in (("x", n_x), ("y", n_y), ("z", n_z)):
            ref[f"a{axis}_{node}"] = np.einsum("nkm,nk->nm", R, vector)
    return ref


def random_coordinates(rng, count):
    """Reference coordinates x0 (unit Euler parameters) and a perturbed x, for tests."""
    r_p = rng.uniform(-0.1, 0.1, (count, 3))
    r_q = r_p + 0.3 + rng.uniform(-0.1, 0.1, (count, 3))
    lam_p = from_rotation_vector(rng.uniform(-2.0, 2.0, (count, 3)))
    lam_q = from_rotation_vector(rng.uniform(-2.0, 2.0, (count, 3)))
    x0 = np.concatenate([r_p, lam_p, r_q, lam_q], axis=1)
    return x0, x0 + rng.normal(scale=0.02, size=x0.shape)


def _node_vector(x, body, cols, order):
    """u = R(lambda) a of one node with its Jacobian (n, 3, 14) and Hessian (n, 3, 14, 14)."""
    result = rotate(x[:, cols], body, order)
    if order == 0:
        return result[0], None, None
    n = x.shape[0]
    U = np.zeros((n, 3, 14))
    U[:, :, cols] = result[1]
    if order == 1:
        return result[0], U, None
    U2 = np.zeros((n, 3, 14, 14))
    U2[:, :, cols, cols] = result[2]
    return result[0], U, U2


def _dot(a, b, order):
    """(u . v, its gradient (n, 14), its Hessian (n, 14, 14)) of two vector fields."""
    u, U, U2 = a
    v, V, V2 = b
    e = np.einsum("nk,nk->n", u, v)
    if order == 0:
        return e, None, None
    De = np.einsum("nk,nki->ni", u, V) + np.einsum("nk,nki->ni", v, U)
    if order == 1:
        return e, De, None
    cross = np.einsum("nki,nkj->nij", U, V)
    D2e = cross + np.swapaxes(cross, 1, 2)
    for w, W2 in ((u, V2), (v, U2)):
        if W2 is not None:
            D2e += np.einsum("nk,nkij->nij", w, W2)
    return e, De, D2e


def deformations(x, ref, order=2):
    """Deformations e (n, 6) m, first (n, 6, 14) and second (n, 6, 14, 14) derivatives."""
    n = x.shape[0]
    l0 = ref["l0"]
    l_vec = x @ _DL.T
    line = (l_vec, np.broadcast_to(_DL, (n, 3, 14)), None)
    ny_p = _node_vector(x, ref["ay_p"], _LP, order)
    nz_p = _node_vector(x, ref["az_p"], _LP, order)
    ny_q = _node_vector(x, ref["ay_q"], _LQ, order)
    nz_q = _node_vector(x, ref["az_q"], _LQ, order)
    twist_a, twist_b = _dot(nz_p, ny_q, order), _dot(ny_p, nz_q, order)
    half = 0.5 * l0
    torsion = tuple(None if a is None else half.reshape((-1,) + (1,) * (a.ndim - 1)) * (a - b)
                    for a, b in zip(twist_a, twist_b, strict=True))
    flip = lambda terms: tuple(None if t is None else -t for t in terms)  # noqa: E731
    bend = [torsion, flip(_dot(nz_p, line, order)), _dot(nz_q, line, order),
            _dot(ny_p, line, order), flip(_dot(ny_q, line, order))]  # e2 ... e6
    (e2, e3, e4, e5, e6) = (b[0] for b in bend)
    length = np.linalg.norm(l_vec, axis=1)
    c = 1.0 / (30.0 * l0)
    e1 = length - l0 + c * (2 * e3**2 + e3 * e4 + 2 * e4**2 + 2 * e5**2 + e5 * e6 + 2 * e6**2)
    e = np.stack([e1, e2, e3, e4, e5, e6], axis=1)
    if order == 0:
        return (e,)
    unit = l_vec / length[:, None]
    slopes = {3: c * (4 * e3 + e4), 4: c * (e3 + 4 * e4), 5: c * (4 * e5 + e6),
              6: c * (e5 + 4 * e6)}
    De_bend = [b[1] for b in bend]
    De1 = unit @ _DL + sum(slopes[k][:, None] * De_bend[k - 2] for k in (3, 4, 5, 6))
    De = np.stack([De1, *De_bend], axis=1)
    if order == 1:
        return e, De
    D2_bend = [b[2] for b in bend]
    projector = (np.eye(3)[None] - unit[:, :, None] * unit[:, None, :]) / length[:, None, None]
    outer = lambda a, b: a[:, :, None] * b[:, None, :]  # noqa: E731
    D2e1 = np.einsum("ai,nab,bj->nij", _DL, projector, _DL)
    for i, j in ((3, 4), (5, 6)):
        Di, Dj = De_bend[i - 2], De_bend[j - 2]
        D2e1 += c[:, None, None] * (4 * outer(Di, Di) + outer(Di, Dj) + outer(Dj, Di)
                                    + 4 * outer(Dj, Dj))
    for k in (3, 4, 5, 6):
        D2e1 += slopes[k][:, None, None] * D2_bend[k - 2]
    return e, De, np.stack([D2e1, *D2_bend], axis=1)


def stiffness(ref, props):
    """Deformation stiffness (n, 6, 6) in N/m, see the module docstring."""
    return _constitutive(ref["l0"], props["EA"], props["GIt"], props["EIy"], props["EIz"])


def damping(ref, props):
    """Deformation damping (n, 6, 6) in N s/m from EdA, GdIt, EdIy, EdIz."""
    return _constitutive(ref["l0"], props["EdA"], props["GdIt"], props["EdIy"], props["EdIz"])


def _constitutive(l0, axial, torsional, flexural_y, flexural_z):
    bending = np.array([[4.0, -2.0], [-2.0, 4.0]])
    matrix = np.zeros((l0.size, 6, 6))
    matrix[:, 0, 0] = axial / l0
    matrix[:, 1, 1] = torsional / l0**3
    matrix[:, 2:4, 2:4] = (flexural_y / l0**3)[:, None, None] * bending
    matrix[:, 4:6, 4:6] = (flexural_z / l0**3)[:, None, None] * bending
    return matrix


# The inertia points: (coordinate slice, body vector, scaled by l0?) after r^p and r^q.
_ROTATED_POINTS = (("ax_p", _LP, True), ("ax_q", _LQ, True), ("ay_p", _LP, False),
                   ("az_p", _LP, False), ("ay_q", _LQ, False), ("az_q", _LQ, False))
_POINT_ROWS = {"ax_p": 3, "ax_q": 9, "ay_p": 12, "az_p": 15, "ay_q": 18, "az_q": 21}


def inertia_points(x, ref, order=2):
    """The inertia points (n, 24) and their derivatives (n, 24, 14), (n, 24, 14, 14):

    [r^p, l0 n_x'^p, r^q, l0 n_x'^q] (the Hermite points) and [n_y'^p, n_z'^p, n_y'^q, n_z'^q]
    (the section axes, for the rotational inertia).
    """
    l0 = ref["l0"]
    n = x.shape[0]
    p = np.zeros((n, 24))
    p[:, 0:3], p[:, 6:9] = x[:, _P], x[:, _Q]
    Dp = np.zeros((n, 24, 14)) if order >= 1 else None
    D2p = np.zeros((n, 24, 14, 14)) if order >= 2 else None
    if order >= 1:
        Dp[:, 0:3, _P] = np.eye(3)
        Dp[:, 6:9, _Q] = np.eye(3)
    for key, cols, scaled in _ROTATED_POINTS:
        rows = slice(_POINT_ROWS[key], _POINT_ROWS[key] + 3)
        u = rotate(x[:, cols], ref[key], order)
        scale = l0 if scaled else np.ones_like(l0)
        p[:, rows] = scale[:, None] * u[0]
        if order >= 1:
            Dp[:, rows, cols] = scale[:, None, None] * u[1]
        if order >= 2:
            D2p[:, rows, cols, cols] = scale[:, None, None, None] * u[2]
    return (p,) if order == 0 else (p, Dp) if order == 1 else (p, Dp, D2p)


def inertia_matrix(ref, props):
    """Consistent mass (n, 24, 24) on the inertia points of `inertia_points`: the Hermite mass
    rho A l0 on the first 12 (kg), the linear-interpolation mass of the section axes,
    l0 [[1/3, 1/6], [1/6, 1/3]] times rho Iz' on n_y' and rho Iy' on n_z' (kg m^2)."""
    l0 = ref["l0"]
    n = l0.size
    matrix = np.zeros((n, 24, 24))
    matrix[:, :12, :12] = (props["rho_A"] * l0)[:, None, None] * np.kron(HERMITE_MASS, np.eye(3))
    linear = np.array([[1.0 / 3.0, 1.0 / 6.0], [1.0 / 6.0, 1.0 / 3.0]])
    for first, second, inertia in (("ay_p", "ay_q", props["rho_Iz"]),
                                   ("az_p", "az_q", props["rho_Iy"])):
        rows = [_POINT_ROWS[first] + k for k in range(3)] + [_POINT_ROWS[second] + k
                                                              for k in range(3)]
        block = (inertia * l0)[:, None, None] * np.kron(linear, np.eye(3))[None]
        matrix[:, np.array(rows)[:, None], np.array(rows)[None, :]] = block
    return matrix


def section_forces(e, sigma, ref):
    """Normal force, torque and end bending moments from deformations and stress resultants.

    e, sigma (n, 6). Returns a dict of (n,) arrays: N (N), T (N m), My_p, My_q, Mz_p, Mz_q
    (N m). The end moments are the work conjugates of the end rotations, l0 times the
    bending stress resultants plus the share of the normal force through the second-order
    terms of e1: M = l0 (sigma_k + sigma1 d e1 / d e_k).
    """
    l0 = ref["l0"]
    c = 1.0 / (30.0 * l0)
    e3, e4, e5, e6 = e[:, 2], e[:, 3], e[:, 4], e[:, 5]
    s1 = sigma[:, 0]
    slopes = (c * (4 * e3 + e4), c * (e3 + 4 * e4), c * (4 * e5 + e6), c * (e5 + 4 * e6))
    moments = [l0 * (sigma[:, k] + s1 * slope) for k, slope in zip((2, 3, 4, 5), slopes,
                                                                     strict=True)]
    return {"N": s1, "T": l0 * sigma[:, 1], "My_p": moments[0], "My_q": moments[1],
            "Mz_p": moments[2], "Mz_q": moments[3]}
