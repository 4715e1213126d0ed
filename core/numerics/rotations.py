"""Rotations in 3-D: Euler parameters, as SPACAR uses them for its rotational nodes.

The orientation of a spatial rotational node is described by four Euler parameters
lambda = [lambda0, lambda1, lambda2, lambda3] (a unit quaternion) with the normalisation
constraint lambda . lambda = 1. The rotation matrix is the homogeneous quadratic form

    R(lambda) = (lambda0^2 - lv . lv) I + 2 lv lv^T + 2 lambda0 [lv x],   lv = [l1, l2, l3],

which maps a vector fixed to the node (body frame) into the global frame.

Why Euler parameters (and not rotation vectors updating a stored rotation matrix):

- no singularity anywhere: R(lambda) is a polynomial in lambda, regular for every unit
  lambda, so a node may turn any number of full turns about any axis without loss of accuracy
  (three-parameter sets, Euler angles or rotation vectors, are singular somewhere);
- the coordinates stay plain numbers: the kinematics' Newton update x[free] -= dx, the
  integrators' state vectors and finite differences all work unchanged, where incremental
  rotation vectors would need a multiplicative update in every one of them;
- all derivatives are exact and cheap: R(lambda) a is quadratic in lambda, so its first
  derivative is linear and its second derivative constant.

The price is one coordinate more per node and the normalisation constraint, carried as an
always-zero deformation of the pseudo-element in `flexure.core.elements.euler` (the scene
builder adds one per free rotational node). `Model.dof_count` reports NX, NXO and NEO in the
course notes' convention of three coordinates per rotational node (see there).

Angular velocity in the body frame: omega' = 2 G(lambda) lambda_dot, with G below (a 3 x 4
matrix, linear in lambda, G(lambda) lambda = 0); in the global frame omega = R omega' =
2 E(lambda) lambda_dot (`global_rates_matrix`, also linear, E lambda = 0, R = E G^T).

Rotations about the global axes (the ports of a 3-D rotational node, `mechanics.ports`):

- a moment M (N m, global frame) does the virtual work M . delta theta = M . 2 E delta lambda,
  so its generalised force on the Euler parameters is f = 2 E(lambda)^T M; f . lambda = 0: it
  does no work along the normalisation, and f . lambda_dot = M . omega, the power of M;
- the angle about global axis k is the component phi_k of the rotation vector phi (axis
  times angle, rad; `rotation_vector_derivatives` gives it with its first and second
  derivatives): exact for a rotation about that axis, the same numbers as a scene's
  `rotation = [rx, ry, rz]`, and a vector (rotating the global frame rotates it), which no
  three-angle (Cardan) set is. At the unrotated orientation d phi / d lambda = 2 E, so a
  small angle is the small rotation a moment does work on; away from it they differ by the
  factor d phi / d theta = I + [phi x] / 2 + O(phi^2).
"""

import numpy as np


def _quadratic_rotation(lam):
    """R(lambda) (3, 3) as the homogeneous quadratic form above, for one lambda (4,)."""
    l0, lv = lam[0], lam[1:]
    skew = np.array([[0.0, -lv[2], lv[1]], [lv[2], 0.0, -lv[0]], [-lv[1], lv[0], 0.0]])
    return (l0 * l0 - lv @ lv) * np.eye(3) + 2.0 * np.outer(lv, lv) + 2.0 * l0 * skew


def _rotation_tensor():
    """T (3, 3, 4, 4), symmetric in its last two indices: R_km = T_kmij lambda_i lambda_j."""
    basis = np.eye(4)
    tensor = np.zeros((3, 3, 4, 4))
    for i in range(4):
        tensor[:, :, i, i] = _quadratic_rotation(basis[i])
    for i in range(4):
        for j in range(i + 1, 4):
            mixed = _quadratic_rotation(basis[i] + basis[j])
            tensor[:, :, i, j] = tensor[:, :, j, i] = 0.5 * (
                mixed - tensor[:, :, i, i] - tensor[:, :, j, j])
    return tensor


ROTATION_TENSOR = _rotation_tensor()


def rotation_matrix(lam):
    """R(lambda) (..., 3, 3) for Euler parameters lambda (..., 4)."""
    return np.einsum("kmij,...i,...j->...km", ROTATION_TENSOR, lam, lam)


def vector_tensor(body_vector):
    """C (..., 3, 4, 4) of body vectors a (..., 3): R(lambda) a = C lambda lambda.

    C_kij = T_kmij a_m, symmetric in i, j: the first derivative of R(lambda) a is 2 C lambda,
    the second 2 C. For a body vector fixed to its node C is a constant the element functions
    compute once, in their reference data.
    """
    return np.einsum("kmij,...m->...kij", ROTATION_TENSOR, body_vector)


def rotate(lam, body_vector, order=2):
    """u = R(lambda) a and its derivatives with respect to lambda.

    Parameters
    ----------
    lam : (n, 4) Euler parameters.
    body_vector : (n, 3) the vectors a in the node's body frame.
    order : 0, 1 or 2.

    Returns (u,), (u, Du) or (u, Du, D2u) shaped (n, 3), (n, 3, 4), (n, 3, 4, 4); D2u does not
    depend on lambda.
    """
    C = vector_tensor(body_vector)
    Cl = np.einsum("nkij,nj->nki", C, lam)
    u = np.einsum("nki,ni->nk", Cl, lam)
    if order == 0:
        return (u,)
    if order == 1:
        return u, 2.0 * Cl
    return u, 2.0 * Cl, 2.0 * C


def body_rates_matrix(lam):
    """G(lambda) (..., 3, 4): omega' = 2 G(lambda) lambda_dot (body-frame angular velocity)."""
    l0, l1, l2, l3 = np.moveaxis(np.asarray(lam, float), -1, 0)
    rows = [[-l1, l0, l3, -l2], [-l2, -l3, l0, l1], [-l3, l2, -l1, l0]]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def global_rates_matrix(lam):
    """E(lambda) (..., 3, 4): omega = 2 E(lambda) lambda_dot (global-frame angular velocity).

    E = [-lv, lambda0 I + [lv x]] (G's [lv x] with the other sign), linear in lambda: row k is
    RATES_TENSOR[k] @ lambda. The moment M about the global axes has the generalised force
    2 E^T M on the Euler parameters.
    """
    return np.einsum("kab,...b->...ka", RATES_TENSOR, np.asarray(lam, float))


def _rates_tensor():
    """P (3, 4, 4): E(lambda)[k, a] = P[k, a, b] lambda_b (the rows of E, linear in lambda)."""
    P = np.zeros((3, 4, 4))
    for k in range(3):
        P[k, 0, k + 1] = -1.0  # -lv
        P[k, k + 1, 0] = 1.0  # lambda0 I
    # [lv x]: row k, column m + 1: eps_kjm lv_j, i.e. (x: -l3 at y, l2 at z) and so on
    for k, j, m, sign in ((0, 2, 1, -1.0), (0, 1, 2, 1.0), (1, 2, 0, 1.0), (1, 0, 2, -1.0),
                          (2, 1, 0, -1.0), (2, 0, 1, 1.0)):
        P[k, m + 1, j + 1] = sign
    return P


RATES_TENSOR = _rates_tensor()

# terms of the series below, and the ratio s / lambda0 under which they are used: the series
# of (atan t) / t and its derivatives converge as t^2, so 16 terms reach round-off at t = 0.2;
# above it the closed forms lose at most eps / t^4 = 1e-13 relatively to cancellation
SERIES_TERMS = 16
SERIES_BELOW = 0.2


def rotation_vector_derivatives(lam, order=2):
    """The rotation vector phi(lambda) (n, 3), rad, and its first (n, 3, 4) and second
    (n, 3, 4, 4) derivatives with respect to the Euler parameters lambda (n, 4).

    With c = lambda0 >= 0 (lambda and -lambda are the same orientation: the sign is chosen so,
    which keeps the angle in [0, pi]), v = [lambda1, lambda2, lambda3], s = |v|,
    n^2 = c^2 + s^2 and alpha = atan2(s, c) (half the angle):

        phi = g v,   g = 2 alpha / s
        d phi_i / d c     = g_c v_i,                      g_c = -2 / n^2
        d phi_i / d v_j   = g delta_ij + h v_i v_j,       h = (2 / s^2) (c / n^2 - alpha / s)
        d2 phi_i / d c2   = (4 c / n^4) v_i
        d2 phi_i / d c d v_j = g_c delta_ij + (4 / n^4) v_i v_j
        d2 phi_i / d v_j d v_k = h (v_k delta_ij + v_j delta_ik + v_i delta_jk) + m v_i v_j v_k,
                          m = (1 / s) dh / ds = 6 alpha / s^5 - 2 c / (n^2 s^4)
                                                - 4 c (s^2 + n^2) / (n^4 s^4)

    phi is homogeneous of degree 0 in lambda, so it needs no normalised lambda and
    (d phi / d lambda) lambda = 0. For small t = s / c the closed forms of g, h and m cancel;
    there their series in t are used, from atan(t) / t = sum (-1)^k t^2k / (2k + 1):

        g = (2 / c) sum_k>=0 (-1)^k t^2k / (2k + 1)
        h = (2 / c^3) sum_k>=1 (-1)^k 2k / (2k + 1) t^(2k - 2)
        m = (2 / c^5) sum_k>=2 (-1)^k 2k (2k - 2) / (2k + 1) t^(2k - 4)

    At the unrotated orientation (v = 0): d phi / d lambda = [0, 2 I / c], which is 2 E.
    The compiled twin is `flexure.core.numerics.rotation_kernels.rotation_vector_component`.
    """
    lam = np.atleast_2d(np.asarray(lam, float))
    sign = np.where(lam[:, 0] < 0.0, -1.0, 1.0)
    lam = lam * sign[:, None]
    c, v = lam[:, 0], lam[:, 1:]
    s = np.linalg.norm(v, axis=1)
    n2 = c * c + s * s
    alpha = np.arctan2(s, c)
    small = s < SERIES_BELOW * c
    g, h, m = _series(c, s) if np.all(small) else _closed(c, s, n2, alpha)
    if np.any(small) and not np.all(small):
        gs, hs, ms = _series(np.where(small, c, 1.0), np.where(small, s, 0.0))
        g, h, m = (np.where(small, a, b) for a, b in ((gs, g), (hs, h), (ms, m)))
    phi = g[:, None] * v
    if order == 0:
        return (phi,)
    eye = np.eye(3)
    D = np.zeros((lam.shape[0], 3, 4))
    D[:, :, 0] = (-2.0 / n2)[:, None] * v
    D[:, :, 1:] = g[:, None, None] * eye + h[:, None, None] * v[:, :, None] * v[:, None, :]
    D *= sign[:, None, None]  # phi(lambda) = phi(-lambda) for lambda0 < 0: chain rule
    if order == 1:
        return phi, D
    n4 = n2 * n2
    D2 = np.zeros((lam.shape[0], 3, 4, 4))
    D2[:, :, 0, 0] = (4.0 * c / n4)[:, None] * v
    cross = (-2.0 / n2)[:, None, None] * eye + (4.0 / n4)[:, None, None] * (
        v[:, :, None] * v[:, None, :])
    D2[:, :, 0, 1:] = cross
    D2[:, :, 1:, 0] = cross
    D2[:, :, 1:, 1:] = h[:, None, None, None] * (
        np.einsum("nk,ij->nijk", v, eye) + np.einsum("nj,ik->nijk", v, eye)
        + np.einsum("ni,jk->nijk", v, eye)) + m[:, None, None, None] * np.einsum(
        "ni,nj,nk->nijk", v, v, v)
    return phi, D, D2


def _series(c, s):
    """g, h, m of `rotation_vector_derivatives` by their series in t = s / c (t small)."""
    t2 = (s / c) ** 2
    g, h, m = np.zeros_like(c), np.zeros_like(c), np.zeros_like(c)
    for k in range(SERIES_TERMS, -1, -1):  # Horner, smallest terms first
        sign = -1.0 if k % 2 else 1.0
        g = g * t2 + sign / (2 * k + 1)
        h = h * t2 + sign * (2 * k + 2) / (2 * k + 3)  # the term k + 1 of h's sum
        m = m * t2 + sign * (2 * k + 4) * (2 * k + 2) / (2 * k + 5)  # the term k + 2 of m's
    return 2.0 * g / c, -2.0 * h / c**3, 2.0 * m / c**5


def _closed(c, s, n2, alpha):
    """g, h, m of `rotation_vector_derivatives` by their closed forms (s not small)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        g = 2.0 * alpha / s
        h = 2.0 / s**2 * (c / n2 - alpha / s)
        m = 6.0 * alpha / s**5 - 2.0 * c / (n2 * s**4) - 4.0 * c * (s * s + n2) / (n2 * n2 * s**4)
    return g, h, m


def from_rotation_vector(phi):
    """Euler parameters (..., 4) of the rotation vector phi (..., 3) (axis times angle, rad)."""
    phi = np.asarray(phi, float)
    angle = np.linalg.norm(phi, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(half) / angle, with its limit 1/2 at zero angle
    factor = np.where(angle > 1e-8, np.sin(half) / np.where(angle > 1e-8, angle, 1.0),
                      0.5 - angle**2 / 48.0)
    return np.concatenate([np.cos(half), factor * phi], axis=-1)


def to_rotation_vector(lam):
    """The rotation vector (..., 3) (angle in [0, pi]) of unit Euler parameters (..., 4)."""
    lam = np.asarray(lam, float)
    lam = np.where(lam[..., :1] < 0.0, -lam, lam)
    sin_half = np.linalg.norm(lam[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(sin_half, lam[..., :1])
    factor = np.where(sin_half > 1e-12, angle / np.where(sin_half > 1e-12, sin_half, 1.0), 2.0)
    return factor * lam[..., 1:]


def compose(first, second):
    """Euler parameters of R(first) R(second) (quaternion product first * second)."""
    a0, av = first[..., :1], first[..., 1:]
    b0, bv = second[..., :1], second[..., 1:]
    scalar = a0 * b0 - np.sum(av * bv, axis=-1, keepdims=True)
    vector = a0 * bv + b0 * av + np.cross(av, bv)
    return np.concatenate([scalar, vector], axis=-1)


def normalized(lam):
    """lambda / |lambda|: the nearest unit Euler parameters."""
    lam = np.asarray(lam, float)
    return lam / np.linalg.norm(lam, axis=-1, keepdims=True)
