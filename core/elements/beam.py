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
                  + rp^2 e2^2 / (2 l0^3),      rp^2 = (Iy' + Iz') / A

e2 ... e6 as in the course notes; e1 with the second-order terms of the planar PLBEAM for both
bending planes (the consistent geometric stiffness, 10 EI / l0^2 per clamped-guided spring) and
the term quadratic in the torsion that SPACAR's elongation carries, the shortening of a twisted
beam (its published coefficient was not at hand; it is derived here). Derivation: twisted by
the angle theta between its ends, at the rate theta / l0, a fibre at distance r from the axis
is a helix whose length per unit of axis length is sqrt(1 + r^2 theta^2 / l0^2) = 1 + r^2
theta^2 / (2 l0^2) + O(theta^4). The normal force, the resultant of the fibres' stresses E
(eps_axis + r^2 theta^2 / (2 l0^2)), is EA (eps_axis + rp^2 theta^2 / (2 l0^2)), with rp^2 =
integral r^2 dA / A = (Iy' + Iz') / A about the centroid: the elongation that it does work on
is l0 times that strain, and e2 = l0 sin(theta) = l0 theta to first order gives the term above.
Its Hessian times the normal force, sigma1 rp^2 / l0^3 on e2, adds to the torsional stiffness
GIt / l0^3: a torque stiffness (GIt + N rp^2) / l, Biot's G It + T Ip / A of a bar under axial
force T (Timoshenko and Gere, Theory of Elastic Stability, art. 5.3), which vanishes at the
torsional buckling load N = -A G It / Ip. The term is exact to second order for a doubly
symmetric section (shear centre on the centroid); the fourth-order stiffening of large twist
(Wagner's, of order E integral r^4 dA (theta / l0)^4) and warping are not modelled. rp^2 is the
section key `Ip_A` (m^2), derived from the section's shape (`flexure.core.scene.sections`);
reference() takes it (default 0: no torsion term). In a planar motion e2 = 0, where the term,
its first derivative and the Hessian's part that multiplies e2 all vanish: the motion equals
the planar PLBEAM model's, and only the stiffness against leaving the plane feels the normal
force through the term.

Stress resultants (all in N, as the deformations are lengths):

    sigma1 = EA / l0 e1                               normal force
    sigma2 = GIt / l0^3 e2                            torque / l0 (pure torsion: GIt / l)

(sigma2 is Saint-Venant's torque, that of the shear stresses; the fibres' normal stresses,
inclined on their helices, add N rp^2 theta / l0 to the moment about the axis, through e1.)
    [sigma3, sigma4] = EIy' / l0^3 [[4, -2], [-2, 4]] [e3, e4]
    [sigma5, sigma6] = EIz' / l0^3 [[4, -2], [-2, 4]] [e5, e6]

plus the same with EdA, GdIt, EdIy', EdIz' for damping. EIy' belongs to bending about y'
(deflection along z', e3 and e4), EIz' to bending about z' (deflection along y', e5, e6); a
planar motion in the x'y' plane is the planar PLBEAM with EI = EIz'. With shear stiffnesses
(N) GAs_z (the shear force along z', which bends about y': e3, e4) and GAs_y (along y': e5,
e6) each bending block is the Timoshenko beam's, EI / (l0^3 (1 + Phi)) [[4 + Phi, Phi - 2],
[Phi - 2, 4 + Phi]] with Phi_y' = 12 EIy' / (GAs_z l0^2) and Phi_z' = 12 EIz' / (GAs_y l0^2)
(`timoshenko`, derived there), the damping blocks with the same Phi; the deformations and the
mass do not change. Without them (infinite, the default) Phi = 0: the matrices above, to the
bit.

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
The compiled kernels, which evaluate the same formulas for one element from its row of
`pack_reference` for the compiled evaluation engine, are in `beam_kernels` (`deformations_kernel`,
`inertia_kernel`) and `beam_directional` (`directional_kernel`: v^T D2e v without D2e, and
the deformations' entry with it); this module hands on what the element registry reads of
them.
"""

import numpy as np

from ..numerics.rotations import from_rotation_vector, rotation_matrix, vector_tensor
from .beam_directional import (  # noqa: F401 (the element's compiled interface, read here)
    deformations_entry,
    directional_kernel,
)
from .beam_kernels import (  # noqa: F401 (the element's compiled interface, read from here)
    REFERENCE_WIDTH,
    deformations_kernel,
    inertia_entry,
    inertia_kernel,
    pack_reference,
)
from .plbeam import HERMITE_MASS
from .protocol import YIELD_STRESS, SchemaKey, property_names, zero_length_problems
from .timoshenko import bending_block, shear_ratio

type_name = "BEAM"
dimension = 3
node_kinds = ("translational", "rotational", "translational", "rotational")
node_roles = ("p", "p", "q", "q")
deformation_names = ("e1", "e2", "e3", "e4", "e5", "e6")
deformation_stiffness = {"e1": "EA", "e2": "GIt", "e3": "EIy", "e4": "EIy", "e5": "EIz",
                         "e6": "EIz"}  # the section key that makes each one elastic
coordinates_per_element = 14
inertia_point_kinds = ("position", "tangent", "position", "tangent",  # Hermite
                       "tangent", "tangent", "tangent", "tangent")  # n_y'^p n_z'^p n_y'^q n_z'^q
section_schema = (
    SchemaKey("EA", "N", "axial stiffness E A"),
    SchemaKey("GIt", "N.m2", "torsional stiffness G It"),
    SchemaKey("EIy", "N.m2", "bending stiffness about y' (deflection along z': e3, e4)"),
    SchemaKey("EIz", "N.m2", "bending stiffness about z' (deflection along y': e5, e6)"),
    SchemaKey("GAs_y", "N", "shear stiffness G kappa A for the shear force along y' (bending "
              "with EIz: e5, e6; default none, rigid in shear)", default=np.inf, positive=True),
    SchemaKey("GAs_z", "N", "shear stiffness G kappa A for the shear force along z' (bending "
              "with EIy: e3, e4; default none, rigid in shear)", default=np.inf, positive=True),
    SchemaKey("EdA", "N.s", "axial damping, the counterpart of EA", damping=True),
    SchemaKey("GdIt", "N.m2.s", "torsional damping, the counterpart of GIt", damping=True),
    SchemaKey("EdIy", "N.m2.s", "bending damping, the counterpart of EIy", damping=True),
    SchemaKey("EdIz", "N.m2.s", "bending damping, the counterpart of EIz", damping=True),
    SchemaKey("rho_A", "kg/m", "mass per length"),
    SchemaKey("rho_Iy", "kg.m", "rotational inertia of the section about y' per length"),
    SchemaKey("rho_Iz", "kg.m", "rotational inertia of the section about z' per length"),
    YIELD_STRESS,
    SchemaKey("A", "m2", "cross-section area, for the stresses"),
    SchemaKey("Ip_A", "m2", "(Iy' + Iz') / A, the polar radius of gyration squared: e1's "
              "torsion term (the shortening of a twisted beam)"),
    SchemaKey("Wy", "m3", "section modulus about y', for the bending stress"),
    SchemaKey("Wz", "m3", "section modulus about z', for the bending stress"),
    SchemaKey("Wt", "m3", "torsion modulus: the largest shear stress is T / Wt"),
    SchemaKey("circular", "1", "1 for a circular section (its stresses; from diameter)",
              given=False),
)
properties = property_names(section_schema)
needs_orientation = True  # the scene gives the principal y' axis of every beam
reference_properties = ("Ip_A",)  # section keys the deformations depend on (e1's torsion term)

_P, _LP, _Q, _LQ = slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 14)
_DL = np.zeros((3, 14))
_DL[:, _P] = -np.eye(3)
_DL[:, _Q] = np.eye(3)

# The deformations depend on x only through z = [l (3), lambda^p (4), lambda^q (4)]; every x
# column is one z column with a sign (l = r^q - r^p), so De = Dz[..., _Z_OF_X] * _Z_SIGN and
# the Hessian likewise, exactly (a product with +-1).
_Z_OF_X = np.array([0, 1, 2, 3, 4, 5, 6, 0, 1, 2, 7, 8, 9, 10])
_Z_SIGN = np.array([-1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
_HESSIAN_TAKE = (11 * _Z_OF_X[:, None] + _Z_OF_X[None, :]).ravel()  # into a flat 11 x 11
_HESSIAN_SIGN = np.outer(_Z_SIGN, _Z_SIGN).ravel()
_ZL, _ZP, _ZQ = slice(0, 3), slice(3, 7), slice(7, 11)

# The node vectors of the deformations, in the order [n_z'^p, n_z'^q, n_y'^p, n_y'^q]: then
# [e3, e4, e5, e6] = _BEND_SIGN (n_i . l), and the torsion pairs each vector with the one in
# the reversed order, e2 = l0 / 2 (n_0 . n_3 - n_2 . n_1), whose derivative with respect to
# the rotation of n_i is l0 / 2 _TWIST_SIGN_i n_(3-i)^T Dn_i. Even i: node p, odd i: node q.
_BEND_AXES = ("az_p", "az_q", "ay_p", "ay_q")
_BEND_SIGN = np.array([-1.0, 1.0, 1.0, -1.0])
_TWIST_SIGN = np.array([1.0, -1.0, -1.0, 1.0])
_BEND_LAMBDA = np.array([[3, 4, 5, 6], [10, 11, 12, 13]] * 2)  # x columns of each one's node
# c (2 e3^2 + e3 e4 + 2 e4^2 + 2 e5^2 + e5 e6 + 2 e6^2) = c / 2 b^T _BEND_MIX b, b = e3 ... e6
_BEND_MIX = np.kron(np.eye(2), np.array([[4.0, 1.0], [1.0, 4.0]]))
# e1 sums the same terms one by one (b_first b_second weight), in the order written above, and
# its slopes d e1 / d b = c _BEND_MIX b as c (4 b + b[_BEND_PARTNER]): e and De then round as
# the module docstring's formulas evaluated term by term do, so the kinematic iterates (which
# stop at a round-off tolerance) do not depend on how the products are batched here
_QUAD_FIRST = np.array([0, 0, 1, 2, 2, 3])
_QUAD_SECOND = np.array([0, 1, 1, 2, 3, 3])
_QUAD_WEIGHT = np.array([2.0, 1.0, 2.0, 2.0, 1.0, 2.0])
_BEND_PARTNER = np.array([1, 0, 3, 2])
_EYE3 = np.eye(3)

# The inertia points: the rotated vectors [ax_p, ay_p, az_p, ax_q, ay_q, az_q] (the first of
# each node times l0), their rows in p (n, 24) and the x columns of their node's lambda.
_POINT_ROWS = {"ax_p": 3, "ax_q": 9, "ay_p": 12, "az_p": 15, "ay_q": 18, "az_q": 21}
_INERTIA_AXES = ("ax_p", "ay_p", "az_p", "ax_q", "ay_q", "az_q")
_INERTIA_ROWS = np.array([_POINT_ROWS[key] + k for key in _INERTIA_AXES for k in range(3)])
_INERTIA_LAMBDA = np.array([[3, 4, 5, 6]] * 3 + [[10, 11, 12, 13]] * 3)
_INERTIA_COLUMNS = np.repeat(_INERTIA_LAMBDA, 3, axis=0)  # (18, 4) per row of p
_DP_TRANSLATION = np.zeros((24, 14))  # d p / d x of r^p and r^q: constant
_DP_TRANSLATION[0:3, _P] = np.eye(3)
_DP_TRANSLATION[6:9, _Q] = np.eye(3)


def default_y_axis(l_vec):
    """A y' axis normal to l when the scene gives none: the global axis least along l."""
    axes = np.eye(3)[np.argmin(np.abs(l_vec), axis=1)]
    return axes


def reference(x0, y_axis=None, properties=None):
    """Reference data from the initial coordinates x0 (n, 14), the y' axes (n, 3) and the
    section keys of `reference_properties` ({"Ip_A": (n,) m^2}; without it, zero).

    l0 (m); c = 1 / (30 l0) (1/m), the factor of the bending terms in e1; c_t = Ip_A / (2 l0^3)
    (1/m), the factor of its torsion term; the element
    frame in the body frames of p and q: ax_p, ay_p, az_p, ax_q, ay_q, az_q (n, 3). Constant
    tensors of the rotated vectors (`rotations.vector_tensor`, R(lambda) a = C lambda lambda):
    bend_tensors (n, 4, 3, 4, 4) of [az_p, az_q, ay_p, ay_q]; inertia_tensors (n, 6, 3, 4, 4)
    of [ax_p, ay_p, az_p, ax_q, ay_q, az_q] with inertia_scale (n, 6, 1) = [l0, 1, 1, l0, 1, 1]
    (m, dimensionless); inertia_hessian (n, 24, 14, 14), the second derivative of the inertia
    points, which is constant (read-only; 37.6 kB per element, 94 % zeros, kept so that no
    evaluation allocates it). Raises ValueError when a y' axis is along the beam.
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
    radius2 = np.zeros_like(l0) if properties is None else np.broadcast_to(
        np.asarray(properties["Ip_A"], float), l0.shape)
    with np.errstate(divide="ignore"):  # a zero length is refused (`reference_problems`)
        ref = {"l0": l0, "c": 1.0 / (30.0 * l0), "c_t": radius2 / (2.0 * l0**3)}
    for node, cols in (("p", _LP), ("q", _LQ)):
        R = rotation_matrix(x0[:, cols])
        for axis, vector in (("x", n_x), ("y", n_y), ("z", n_z)):
            ref[f"a{axis}_{node}"] = np.einsum("nkm,nk->nm", R, vector)
    ref["bend_tensors"] = vector_tensor(np.stack([ref[key] for key in _BEND_AXES], axis=1))
    tensors = vector_tensor(np.stack([ref[key] for key in _INERTIA_AXES], axis=1))
    scale = np.ones((l0.size, 6, 1))
    scale[:, 0::3, 0] = l0[:, None]
    hessian = np.zeros((l0.size, 24, 14, 14))
    # point k's three rows of p against its node's lambda columns, twice: the constant 2 C_k
    for k, (rows, cols) in enumerate(zip(_INERTIA_ROWS.reshape(6, 3), _INERTIA_LAMBDA,
                                         strict=True)):
        hessian[:, rows[:, None, None], cols[:, None], cols] = scale[:, k, :, None, None] * (
            2.0 * tensors[:, k])
    hessian.flags.writeable = False
    ref.update(inertia_tensors=tensors, inertia_scale=scale, inertia_hessian=hessian)
    return ref


def reference_problems(x0, y_axis=None):
    """[(element index, scene key, message)] of the beams `reference` cannot take: end nodes
    that coincide ("nodes"), a principal axis along the beam or zero ("y_axis")."""
    l_vec = x0 @ _DL.T
    problems = zero_length_problems(np.linalg.norm(l_vec, axis=1))
    if y_axis is not None:  # the test of `reference`: the axis's part normal to the beam
        short = {i for i, _, _ in problems}
        for i, (axis, along) in enumerate(zip(np.asarray(y_axis, float), l_vec, strict=True)):
            if i in short:
                continue
            n_x = along / np.linalg.norm(along)
            if np.linalg.norm(axis - (axis @ n_x) * n_x) < 1e-9:
                problems.append((i, "y_axis", f"the principal axis {axis.tolist()} lies along "
                                              "the beam (or is zero)"))
    return sorted(problems)


def random_coordinates(rng, count):
    """Reference coordinates x0 (unit Euler parameters) and a perturbed x, for tests."""
    r_p = rng.uniform(-0.1, 0.1, (count, 3))
    r_q = r_p + 0.3 + rng.uniform(-0.1, 0.1, (count, 3))
    lam_p = from_rotation_vector(rng.uniform(-2.0, 2.0, (count, 3)))
    lam_q = from_rotation_vector(rng.uniform(-2.0, 2.0, (count, 3)))
    x0 = np.concatenate([r_p, lam_p, r_q, lam_q], axis=1)
    return x0, x0 + rng.normal(scale=0.02, size=x0.shape)


def _rotated(tensors, lam):
    """(u (n, k, 3), Du (n, k, 3, 4)) of u = C lambda lambda, C (n, k, 3, 4, 4), lambda (n, k, 4).

    Du = 2 C lambda; the second derivative is the constant 2 C."""
    n, k = lam.shape[:2]
    half_Du = (tensors.reshape(n, k, 12, 4) @ lam[..., None]).reshape(n, k, 3, 4)
    return (half_Du @ lam[..., None])[..., 0], 2.0 * half_Du


def deformations(x, ref, order=2):
    """Deformations e (n, 6) m, first (n, 6, 14) and second (n, 6, 14, 14) derivatives.

    order = 0, 1 or 2 returns (e,), (e, De) or (e, De, D2e). The derivatives are written in
    z = [l, lambda^p, lambda^q] (11), block by block, and mapped to x at the end (see _Z_OF_X).
    With u = C lambda lambda for each node vector: d(w . u) / d lambda = 2 w^T C lambda =
    w^T Du, d2(w . u) / d lambda2 = 2 w . C. e1 = |l| - l0 + c/2 b^T W b + c_t e2^2 (b = e3
    ... e6, W = _BEND_MIX) by the chain rule: De1 = u^T Dl + c b^T W Db + 2 c_t e2 De2 and
    D2e1 = (I - u u^T) / |l| + c Db^T W Db + sum_k (c W b)_k D2b_k + 2 c_t (De2^T De2
    + e2 D2e2), u = l / |l|. These functions run at every evaluation of the
    equations of motion on a handful of elements, where the number of numpy calls sets the time.
    """
    n = x.shape[0]
    l0, c, c_t = ref["l0"], ref["c"], ref["c_t"]
    half = 0.5 * l0
    l_vec = x[:, _Q] - x[:, _P]
    axes, D_axes = _rotated(ref["bend_tensors"], x[:, _BEND_LAMBDA])  # (n, 4, 3), (n, 4, 3, 4)
    # The dot products as einsums: they sum in the order of the formulas written out (a matmul
    # rounds differently), which keeps e and De those of the term-by-term formulas
    e = np.empty((n, 6))
    bend = e[:, 2:]  # [e3, e4, e5, e6]
    np.multiply(np.einsum("nvk,nk->nv", axes, l_vec), _BEND_SIGN, out=bend)
    pairs = np.einsum("nvk,nvk->nv", axes, axes[:, ::-1])  # [n_0 . n_3, n_1 . n_2, ...]
    e[:, 1] = half * (pairs[:, 0] - pairs[:, 2])
    length = np.sqrt((l_vec * l_vec).sum(axis=1))
    quadratic = (bend[:, _QUAD_FIRST] * bend[:, _QUAD_SECOND] * _QUAD_WEIGHT).sum(axis=1)
    e[:, 0] = length - l0 + c * quadratic + c_t * (e[:, 1] * e[:, 1])
    if order == 0:
        return (e,)
    # per node vector i the two vectors it is dotted with: l (bending), n_(3-i) (torsion)
    partners = np.empty((n, 4, 2, 3))
    partners[:, :, 0] = l_vec[:, None]
    partners[:, :, 1] = axes[:, ::-1]
    by_lambda = np.einsum("nvjk,nvki->nvji", partners, D_axes)  # [l^T Dn_i, n_(3-i)^T Dn_i]
    Dz = np.zeros((n, 6, 11))
    Dz[:, 2:, _ZL] = _BEND_SIGN[:, None] * axes
    bend_by_lambda = _BEND_SIGN[:, None] * by_lambda[:, :, 0]
    Dz[:, 2::2, _ZP] = bend_by_lambda[:, 0::2]  # e3, e5: the vectors of node p
    Dz[:, 3::2, _ZQ] = bend_by_lambda[:, 1::2]  # e4, e6: node q
    twist = by_lambda[:, :, 1]
    Dz[:, 1, _ZP] = half[:, None] * (twist[:, 0] - twist[:, 2])
    Dz[:, 1, _ZQ] = half[:, None] * (twist[:, 3] - twist[:, 1])
    Dz[:, 0, _ZL] = l_vec / length[:, None]
    slopes = c[:, None] * (4.0 * bend + bend[:, _BEND_PARTNER])  # d e1 / d[e3 ... e6]
    terms = slopes[:, :, None] * Dz[:, 2:]  # added left to right, as the formula is written
    Dz[:, 0] += ((terms[:, 0] + terms[:, 1]) + terms[:, 2]) + terms[:, 3]
    twist_slope = 2.0 * c_t * e[:, 1]  # d e1 / d e2
    Dz[:, 0] += twist_slope[:, None] * Dz[:, 1]
    De = Dz[:, :, _Z_OF_X] * _Z_SIGN
    if order == 1:
        return e, De
    Hz = np.zeros((n, 6, 11, 11))
    # bending: d2 / dl dlambda = sign Dn_i, d2 / dlambda2 = 2 sign l . C_i
    bend_D = _BEND_SIGN[:, None, None] * D_axes
    for rows, block, i in ((slice(2, None, 2), _ZP, slice(0, None, 2)),
                           (slice(3, None, 2), _ZQ, slice(1, None, 2))):
        Hz[:, rows, _ZL, block] = bend_D[:, i]
        Hz[:, rows, block, _ZL] = np.swapaxes(bend_D[:, i], 2, 3)
    partner_C = (partners @ ref["bend_tensors"].reshape(n, 4, 3, 16)).reshape(n, 4, 2, 4, 4)
    bend_C = (2.0 * _BEND_SIGN)[:, None, None] * partner_C[:, :, 0]
    Hz[:, 2::2, _ZP, _ZP] = bend_C[:, 0::2]
    Hz[:, 3::2, _ZQ, _ZQ] = bend_C[:, 1::2]
    # torsion: d2 / dlambda_i2 = l0 sign n_(3-i) . C_i, d2 / dlambda^p dlambda^q from Dn^T Dn
    twist_C = (l0[:, None] * _TWIST_SIGN)[:, :, None, None] * partner_C[:, :, 1]
    Hz[:, 1, _ZP, _ZP] = twist_C[:, 0] + twist_C[:, 2]
    Hz[:, 1, _ZQ, _ZQ] = twist_C[:, 1] + twist_C[:, 3]
    cross = np.swapaxes(D_axes[:, 0::2], 2, 3) @ D_axes[:, 3::-2]  # [Dn_0^T Dn_3, Dn_2^T Dn_1]
    mixed = half[:, None, None] * (cross[:, 0] - cross[:, 1])
    Hz[:, 1, _ZP, _ZQ] = mixed
    Hz[:, 1, _ZQ, _ZP] = np.swapaxes(mixed, 1, 2)
    # elongation: d2|l|/dl2 = (I - u u^T) / |l|, plus the second-order terms' c Db^T W Db and
    # sum_k slope_k D2e_k
    bend_Dz = Dz[:, 2:]
    H1 = np.swapaxes(bend_Dz, 1, 2) @ (c[:, None, None] * (_BEND_MIX @ bend_Dz))
    H1 += (slopes[:, None, :] @ Hz[:, 2:].reshape(n, 4, 121)).reshape(n, 11, 11)
    unit = l_vec / length[:, None]
    H1[:, _ZL, _ZL] += (_EYE3 - unit[:, :, None] * unit[:, None, :]) / length[:, None, None]
    H1 += (2.0 * c_t)[:, None, None] * (Dz[:, 1, :, None] * Dz[:, 1, None, :])
    H1 += twist_slope[:, None, None] * Hz[:, 1]
    Hz[:, 0] = H1
    D2e = (Hz.reshape(6 * n, 121).take(_HESSIAN_TAKE, axis=1) * _HESSIAN_SIGN)
    return e, De, D2e.reshape(n, 6, 14, 14)


def stiffness(ref, props):
    """Deformation stiffness (n, 6, 6) in N/m, see the module docstring."""
    return _constitutive(ref["l0"], props["EA"], props["GIt"], props["EIy"], props["EIz"],
                         _phis(ref, props))


def damping(ref, props):
    """Deformation damping (n, 6, 6) in N s/m from EdA, GdIt, EdIy, EdIz (the stiffness's
    Phi)."""
    return _constitutive(ref["l0"], props["EdA"], props["GdIt"], props["EdIy"], props["EdIz"],
                         _phis(ref, props))


def _phis(ref, props):
    """(Phi_y', Phi_z'): the shear ratios of the bending about y' (e3, e4) and about z'."""
    l0 = ref["l0"]
    return (shear_ratio(props["EIy"], props["GAs_z"], l0),
            shear_ratio(props["EIz"], props["GAs_y"], l0))


def _constitutive(l0, axial, torsional, flexural_y, flexural_z, phis):
    matrix = np.zeros((l0.size, 6, 6))
    matrix[:, 0, 0] = axial / l0
    matrix[:, 1, 1] = torsional / l0**3
    matrix[:, 2:4, 2:4] = bending_block(flexural_y, l0, phis[0])
    matrix[:, 4:6, 4:6] = bending_block(flexural_z, l0, phis[1])
    return matrix


def inertia_points(x, ref, order=2):
    """The inertia points (n, 24) and their derivatives (n, 24, 14), (n, 24, 14, 14):

    [r^p, l0 n_x'^p, r^q, l0 n_x'^q] (the Hermite points) and [n_y'^p, n_z'^p, n_y'^q, n_z'^q]
    (the section axes, for the rotational inertia). p is quadratic in x, so the second
    derivative is the constant ref["inertia_hessian"], returned as is (read-only).
    """
    n = x.shape[0]
    scale = ref["inertia_scale"]
    vectors, D_vectors = _rotated(ref["inertia_tensors"], x[:, _INERTIA_LAMBDA])
    p = np.empty((n, 24))
    p[:, 0:3], p[:, 6:9] = x[:, _P], x[:, _Q]
    p[:, _INERTIA_ROWS] = (scale * vectors).reshape(n, 18)
    if order == 0:
        return (p,)
    Dp = np.empty((n, 24, 14))
    Dp[:] = _DP_TRANSLATION
    Dp[:, _INERTIA_ROWS[:, None], _INERTIA_COLUMNS] = (
        scale[..., None] * D_vectors).reshape(n, 18, 4)
    if order == 1:
        return p, Dp
    return p, Dp, ref["inertia_hessian"]


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
    terms of e1: M = l0 (sigma_k + sigma1 d e1 / d e_k). T is Saint-Venant's torque l0 sigma2,
    the one the shear stresses carry (T / Wt); the normal force's share through e1's torsion
    term, l0 sigma1 2 c_t e2, is carried by the normal stresses on their helices.
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
