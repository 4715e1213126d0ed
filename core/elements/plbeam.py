"""PLBEAM: the planar beam element (SPACAR), three deformations.

Nodal coordinates of one element, in this order (m, rad):

    x = [x^p, y^p, phi^p, x^q, y^q, phi^q]

With l = r^q - r^p and n_y^p, n_y^q the element's initial y axis rotated with the nodes:

    e2 = -(n_y^p . l)                                          bending at p (m)
    e3 =  (n_y^q . l)                                          bending at q (m)
    e1 = |l| - l0 + (2 e2^2 + e2 e3 + 2 e3^2) / (30 l0)        elongation (m)

The second-order terms in e1 are those of the cubic bending line; they give the consistent
geometric stiffness, hence 10 EI / l0^2 per clamped-guided spring with one element.

Stress resultants: sigma1 = EA / l0 e1 (N), and the bending moments
[sigma2, sigma3] = EI / l0^3 [[4, -2], [-2, 4]] [e2, e3] (N, as e2 and e3 are lengths: a
moment over l0, where SPACAR's are N m). With a shear stiffness GAs (N) the bending matrix is
the Timoshenko beam's, EI / (l0^3 (1 + Phi)) [[4 + Phi, Phi - 2], [Phi - 2, 4 + Phi]] with
Phi = 12 EI / (GAs l0^2) (`timoshenko`, derived there); the deformations, their second-order
terms in e1 (the geometric stiffness of the cubic bending line) and the mass do not change.
Without GAs (infinite, the default) Phi = 0: the matrix above, to the bit.

The end bending moments (N m) are the work conjugates of the end rotations (e2 = l0 theta^p to
first order), with the normal force's share through the second-order terms of e1:
M^p = l0 (sigma2 + sigma1 d e1 / d e2), M^q likewise (`section_forces`).

Distributed mass: the position along the beam is the cubic (Hermite) interpolation between the
end positions r^p, r^q and the end tangents l0 t^p, l0 t^q (t the initial element x axis rotated
with the node), which gives the consistent mass rho A l0 / 420 [[156, 22, 54, -13], ...] on
those eight inertia points. The cross-section's own rotational inertia is neglected.

Every function works on all elements of this type at once: arrays shaped (n_elements, ...).
"""

import numpy as np

from ..numerics.jit import kernel
from . import entries
from .protocol import YIELD_STRESS, SchemaKey, property_names, zero_length_problems
from .timoshenko import bending_block, shear_ratio

type_name = "PLBEAM"
dimension = 2
node_kinds = ("translational", "rotational", "translational", "rotational")
node_roles = ("p", "p", "q", "q")
deformation_names = ("e1", "e2", "e3")
deformation_stiffness = {"e1": "EA", "e2": "EI", "e3": "EI"}  # the key that makes each elastic
coordinates_per_element = 6
inertia_point_kinds = ("position", "tangent", "position", "tangent")
section_schema = (
    SchemaKey("EA", "N", "axial stiffness E A"),
    SchemaKey("EI", "N.m2", "bending stiffness E I in the plane"),
    SchemaKey("GAs", "N", "shear stiffness G kappa A in the plane (default: none, rigid in "
              "shear): the bending stiffness becomes the Timoshenko beam's", default=np.inf,
              positive=True),
    SchemaKey("EdA", "N.s", "axial damping, the counterpart of EA", damping=True),
    SchemaKey("EdI", "N.m2.s", "bending damping, the counterpart of EI", damping=True),
    SchemaKey("rho_A", "kg/m", "mass per length"),
    YIELD_STRESS,
    SchemaKey("A", "m2", "cross-section area, for the stresses (from width and height)",
              given=False),
    SchemaKey("Wz", "m3", "section modulus width height^2 / 6, for the bending stress (from "
              "width and height)", given=False),
)
properties = property_names(section_schema)

_DL = np.array([[-1.0, 0.0, 0.0, 1.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0, 1.0, 0.0]])
_PHI_P, _PHI_Q = 2, 5
_SIGN = np.array([-1.0, 1.0])  # e2 = -(n_y^p . l), e3 = +(n_y^q . l)
_BEND_MIX = np.array([[4.0, 1.0], [1.0, 4.0]])  # 2 e2^2 + e2 e3 + 2 e3^2 = 1/2 b^T W b
HERMITE_MASS = np.array(
    [[156.0, 22.0, 54.0, -13.0], [22.0, 4.0, 13.0, -3.0], [54.0, 13.0, 156.0, -22.0],
     [-13.0, -3.0, -22.0, 4.0]]
) / 420.0
_EYE2 = np.eye(2)
# z = [l_x, l_y, phi^p, phi^q] = _Z_OF_X x; a Hessian H in z is _Z_OF_X^T H _Z_OF_X in x
_Z_OF_X = np.array([[-1.0, 0.0, 0.0, 1.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0, 1.0, 0.0],
                    [0.0, 0.0, 1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]])
_HESSIAN_Z_TO_X = np.einsum("ai,bj->abij", _Z_OF_X, _Z_OF_X).reshape(16, 36)
_DP_TRANSLATION = np.zeros((8, 6))  # d p / d x of the position points: constant
_DP_TRANSLATION[[0, 1, 4, 5], [0, 1, 3, 4]] = 1.0


def reference(x0):
    """Reference data from the initial coordinates x0 (n, 6).

    l0 (m); offset_p, offset_q (rad): the angle of the element's initial x axis minus the
    initial node angle, so that the current x axis at a node has angle phi + offset;
    offsets (n, 2): [offset_p, offset_q]; c = 1 / (30 l0) (1/m), the factor of the
    second-order terms in e1.
    """
    l_vec = x0 @ _DL.T
    angle = np.arctan2(l_vec[:, 1], l_vec[:, 0])
    l0 = np.linalg.norm(l_vec, axis=1)
    offsets = angle[:, None] - x0[:, _PHI_P::3]  # the node angles are columns 2 and 5
    with np.errstate(divide="ignore"):  # a zero length is refused (`reference_problems`)
        c = 1.0 / (30.0 * l0)
    return {"l0": l0, "offset_p": offsets[:, 0], "offset_q": offsets[:, 1], "offsets": offsets,
            "c": c}


def reference_problems(x0):
    """[(element index, "nodes", message)] of the beams whose end nodes coincide."""
    return zero_length_problems(np.linalg.norm(x0 @ _DL.T, axis=1))


def _angles(x, ref):
    """The current angles (n, 2) of the element's x axis at [p, q] (rad)."""
    return x[:, _PHI_P::3] + ref["offsets"]  # the node angles are columns 2 and 5


def deformations(x, ref, order=2):
    """Deformations e (n, 3) m, first (n, 3, 6) and second (n, 3, 6, 6) derivatives.

    order = 0, 1 or 2 returns (e,), (e, De) or (e, De, D2e). The deformations depend on x only
    through z = [l, phi^p, phi^q] (4), with dz/dx = _Z_OF_X constant: the derivatives are
    written in z, column by column, and mapped to x by one product (every x column is one z
    column, with its sign: exact). These functions run at every evaluation of the equations of
    motion on a handful of elements, where the number of numpy calls sets the time.
    """
    n = x.shape[0]
    l_vec = x[:, 3:5] - x[:, 0:2]
    lx, ly = l_vec[:, 0:1], l_vec[:, 1:2]
    length = np.sqrt(lx * lx + ly * ly)  # (n, 1)
    angle = _angles(x, ref)
    normal = angle + 0.5 * np.pi
    ny_x, ny_y = np.cos(normal), np.sin(normal)  # n_y at [p, q]
    c = ref["c"]
    e = np.empty((n, 3))
    bend = e[:, 1:]  # [e2, e3] = sign * (n_y . l)
    np.multiply(ny_x * lx + ny_y * ly, _SIGN, out=bend)
    e2, e3 = bend[:, 0], bend[:, 1]
    e[:, 0] = length[:, 0] - ref["l0"] + c * (2 * e2**2 + e2 * e3 + 2 * e3**2)
    if order == 0:
        return (e,)
    # bending: d e / d l = sign n_y, d e / d phi = sign (d n_y / d phi . l), d n_y / d phi = -t
    cos, sin = np.cos(angle), np.sin(angle)
    Dz = np.zeros((n, 3, 4))
    np.multiply(ny_x, _SIGN, out=Dz[:, 1:, 0])
    np.multiply(ny_y, _SIGN, out=Dz[:, 1:, 1])
    bend_by_angle = (-cos * lx - sin * ly) * _SIGN  # (n, 2): d e2 / d phi^p, d e3 / d phi^q
    Dz[:, 1, 2] = bend_by_angle[:, 0]
    Dz[:, 2, 3] = bend_by_angle[:, 1]
    # elongation: d|l|/dl = u, plus d e1 / d[e2, e3] = c W [e2, e3] times De2, De3
    unit = l_vec / length
    slopes = c[:, None] * (4 * bend + bend[:, ::-1])  # c [4 e2 + e3, e2 + 4 e3]
    terms = slopes[:, :, None] * Dz[:, 1:]
    Dz[:, 0, 0:2] = unit
    Dz[:, 0] += terms[:, 0]
    Dz[:, 0] += terms[:, 1]
    De = Dz @ _Z_OF_X
    if order == 1:
        return e, De
    # bending: d2 e / dl dphi = -sign t, d2 e / dphi2 = -e (every other entry zero)
    Hz = np.zeros((n, 3, 4, 4))
    minus_sign_t = np.empty((n, 2, 2))  # -sign t at [p, q], t = (cos, sin)
    np.multiply(cos, -_SIGN, out=minus_sign_t[:, :, 0])
    np.multiply(sin, -_SIGN, out=minus_sign_t[:, :, 1])
    Hz[:, 1, 2, 0:2] = Hz[:, 1, 0:2, 2] = minus_sign_t[:, 0]
    Hz[:, 2, 3, 0:2] = Hz[:, 2, 0:2, 3] = minus_sign_t[:, 1]
    Hz[:, 1, 2, 2] = -e2
    Hz[:, 2, 3, 3] = -e3
    # elongation: d2|l|/dl2 = (I - u u^T) / |l|, plus the bending terms of e1
    bend_Dz = Dz[:, 1:]
    Hz1 = np.swapaxes(bend_Dz, 1, 2) @ (c[:, None, None] * (_BEND_MIX @ bend_Dz))
    Hz1 += (slopes[:, None, :] @ Hz[:, 1:].reshape(n, 2, 16)).reshape(n, 4, 4)
    Hz1[:, 0:2, 0:2] += (_EYE2 - unit[:, :, None] * unit[:, None, :]) / length[:, :, None]
    Hz[:, 0] = Hz1
    D2e = (Hz.reshape(3 * n, 16) @ _HESSIAN_Z_TO_X).reshape(n, 3, 6, 6)
    return e, De, D2e


def stiffness(ref, props):
    """Deformation stiffness (n, 3, 3) in N/m: EA / l0 and EI / (l0^3 (1 + Phi)) [[4 + Phi,
    Phi - 2], [Phi - 2, 4 + Phi]], Phi = 12 EI / (GAs l0^2) (0 without GAs)."""
    return _constitutive(ref["l0"], props["EA"], props["EI"], _phi(ref, props))


def damping(ref, props):
    """Deformation damping (n, 3, 3) in N s/m from EdA and EdI, as the stiffness (the same
    Phi)."""
    return _constitutive(ref["l0"], props["EdA"], props["EdI"], _phi(ref, props))


def _phi(ref, props):
    return shear_ratio(props["EI"], props["GAs"], ref["l0"])


def _constitutive(l0, axial, flexural, phi):
    matrix = np.zeros((l0.size, 3, 3))
    matrix[:, 0, 0] = axial / l0
    matrix[:, 1:, 1:] = bending_block(flexural, l0, phi)
    return matrix


def inertia_points(x, ref, order=2):
    """The Hermite interpolation points [r^p, l0 t^p, r^q, l0 t^q] (n, 8) and derivatives."""
    n = x.shape[0]
    angle = _angles(x, ref)
    cos, sin = np.cos(angle), np.sin(angle)
    l0 = ref["l0"][:, None]
    l_cos, l_sin = l0 * cos, l0 * sin  # (n, 2): the tangent points at [p, q]
    p = np.empty((n, 8))  # [r^p, l0 t^p, r^q, l0 t^q]
    p[:, 0:2] = x[:, 0:2]
    p[:, 4:6] = x[:, 3:5]
    p[:, 2::4] = l_cos
    p[:, 3::4] = l_sin
    if order == 0:
        return (p,)
    Dp = np.empty((n, 8, 6))
    Dp[:] = _DP_TRANSLATION
    Dp[:, 2, _PHI_P] = -l_sin[:, 0]  # d (l0 t) / d phi = l0 (-sin, cos)
    Dp[:, 3, _PHI_P] = l_cos[:, 0]
    Dp[:, 6, _PHI_Q] = -l_sin[:, 1]
    Dp[:, 7, _PHI_Q] = l_cos[:, 1]
    if order == 1:
        return p, Dp
    D2p = np.zeros((n, 8, 6, 6))  # d2 (l0 t) / d phi2 = -l0 t
    D2p[:, 2, _PHI_P, _PHI_P] = -l_cos[:, 0]
    D2p[:, 3, _PHI_P, _PHI_P] = -l_sin[:, 0]
    D2p[:, 6, _PHI_Q, _PHI_Q] = -l_cos[:, 1]
    D2p[:, 7, _PHI_Q, _PHI_Q] = -l_sin[:, 1]
    return p, Dp, D2p


def inertia_matrix(ref, props):
    """Consistent mass (n, 8, 8) in kg on the inertia points of `inertia_points`."""
    mass = props["rho_A"] * ref["l0"]
    return mass[:, None, None] * np.kron(HERMITE_MASS, np.eye(2))[None]


def section_forces(e, sigma, ref):
    """Normal force and end bending moments from deformations and stress resultants.

    e, sigma (n, 3). Returns a dict of (n,) arrays: N (N), Mz_p, Mz_q (N m, bending in the
    plane). M = l0 (sigma_k + sigma1 d e1 / d e_k): the work conjugate of the end rotation,
    as the spatial BEAM's (whose e5, e6 are -e2, -e3: the same moments with the opposite sign,
    so that the moment along the beam is linear between Mz_p and Mz_q either way).
    """
    l0, c, s1 = ref["l0"], ref["c"], sigma[:, 0]
    e2, e3 = e[:, 1], e[:, 2]
    return {"N": s1, "Mz_p": l0 * (sigma[:, 1] + s1 * c * (4 * e2 + e3)),
            "Mz_q": l0 * (sigma[:, 2] + s1 * c * (e2 + 4 * e3))}


# -- compiled kernel: one element, the formulas above in scalars ----------------------------

REFERENCE_WIDTH = 4  # [l0, offset_p, offset_q, c]


def pack_reference(ref):
    """(n, 4) float64: l0 (m), offset_p, offset_q (rad), c (1/m) per element."""
    return np.ascontiguousarray(np.column_stack(
        [ref["l0"], ref["offset_p"], ref["offset_q"], ref["c"]]), dtype=float)


# x column of each z = [l_x, l_y, phi^p, phi^q] entry, twice where l = r^q - r^p, with sign
_KX = np.array([0, 1, 2, 3, 4, 5])
_KZ = np.array([0, 1, 2, 0, 1, 3])
_KS = np.array([-1.0, -1.0, 1.0, 1.0, 1.0, 1.0])


@kernel(inline="always")
def _bending_hessian(k, a, b, cp, sp, cq, sq, e2, e3):
    """d2 e_k / dz_a dz_b of the bending deformations (k = 1: e2, k = 2: e3) in z."""
    if k == 1:  # d2 e2 / dl dphi^p = t^p = (cos, sin), d2 e2 / dphi^p2 = -e2
        if (a == 0 and b == 2) or (a == 2 and b == 0):
            return cp
        if (a == 1 and b == 2) or (a == 2 and b == 1):
            return sp
        return -e2 if a == 2 and b == 2 else 0.0
    if (a == 0 and b == 3) or (a == 3 and b == 0):  # e3: -t^q and -e3
        return -cq
    if (a == 1 and b == 3) or (a == 3 and b == 1):
        return -sq
    return -e3 if a == 3 and b == 3 else 0.0


@kernel
def deformations_kernel(x, ref, order, e, De, D2e):
    """One element: e (3,) and, by order, De (3, 6) and D2e (3, 6, 6), every entry written.

    x (6,) local coordinates, ref (4,) from `pack_reference`; the formulas of the module
    docstring, with the derivatives written in z = [l_x, l_y, phi^p, phi^q] and mapped to x
    (x column i is z column _KZ[i] with sign _KS[i]). No allocation."""
    lx = x[3] - x[0]
    ly = x[4] - x[1]
    length = np.sqrt(lx * lx + ly * ly)
    ap = x[2] + ref[1]
    aq = x[5] + ref[2]
    cp, sp = np.cos(ap), np.sin(ap)
    cq, sq = np.cos(aq), np.sin(aq)
    c = ref[3]
    e2 = sp * lx - cp * ly  # -(n_y^p . l) with n_y = (-sin, cos)
    e3 = -sq * lx + cq * ly  # +(n_y^q . l)
    e[1] = e2
    e[2] = e3
    e[0] = length - ref[0] + c * (2.0 * e2 * e2 + e2 * e3 + 2.0 * e3 * e3)
    if order == 0:
        return
    s2 = c * (4.0 * e2 + e3)  # d e1 / d e2
    s3 = c * (e2 + 4.0 * e3)  # d e1 / d e3
    ux, uy = lx / length, ly / length
    # the bending rows in z: e2 on (l, phi^p), e3 on (l, phi^q)
    d2 = (sp, -cp, cp * lx + sp * ly, 0.0)
    d3 = (-sq, cq, 0.0, -(cq * lx + sq * ly))
    d1 = (ux + s2 * d2[0] + s3 * d3[0], uy + s2 * d2[1] + s3 * d3[1], s2 * d2[2], s3 * d3[3])
    for i in range(6):
        z, sign = _KZ[i], _KS[i]
        De[0, i] = sign * d1[z]
        De[1, i] = sign * d2[z]
        De[2, i] = sign * d3[z]
    if order == 1:
        return
    for i in range(6):
        a, si = _KZ[i], _KS[i]
        for j in range(6):
            b, sign = _KZ[j], si * _KS[j]
            h2 = _bending_hessian(1, a, b, cp, sp, cq, sq, e2, e3)
            h3 = _bending_hessian(2, a, b, cp, sp, cq, sq, e2, e3)
            # elongation: c Db^T [[4, 1], [1, 4]] Db + s2 H2 + s3 H3 + (I - u u^T) / |l|
            h1 = (c * (4.0 * d2[a] * d2[b] + d2[a] * d3[b] + d3[a] * d2[b]
                       + 4.0 * d3[a] * d3[b]) + s2 * h2 + s3 * h3)
            if a < 2 and b < 2:
                ua = ux if a == 0 else uy
                ub = ux if b == 0 else uy
                h1 += ((1.0 if a == b else 0.0) - ua * ub) / length
            D2e[0, i, j] = sign * h1
            D2e[1, i, j] = sign * h2
            D2e[2, i, j] = sign * h3


@kernel
def inertia_kernel(x, v, ref, order, p, Dp, acc):
    """One element: the points p (8,) of `inertia_points` and, by order, Dp (8, 6) and
    acc = (D2p v) v (8,) for the local velocity v (6,)."""
    l0 = ref[0]
    ap = x[2] + ref[1]
    aq = x[5] + ref[2]
    lcp, lsp = l0 * np.cos(ap), l0 * np.sin(ap)
    lcq, lsq = l0 * np.cos(aq), l0 * np.sin(aq)
    p[0], p[1], p[2], p[3] = x[0], x[1], lcp, lsp
    p[4], p[5], p[6], p[7] = x[3], x[4], lcq, lsq
    if order == 0:
        return
    Dp[:, :] = 0.0
    Dp[0, 0] = Dp[1, 1] = Dp[4, 3] = Dp[5, 4] = 1.0
    Dp[2, 2], Dp[3, 2] = -lsp, lcp
    Dp[6, 5], Dp[7, 5] = -lsq, lcq
    if order == 1:
        return
    wp, wq = v[2] * v[2], v[5] * v[5]
    acc[0] = acc[1] = acc[4] = acc[5] = 0.0
    acc[2], acc[3] = -lcp * wp, -lsp * wp
    acc[6], acc[7] = -lcq * wq, -lsq * wq


deformations_entry = entries.deformations_entry(deformations_kernel)
inertia_entry = entries.inertia_entry(inertia_kernel)
