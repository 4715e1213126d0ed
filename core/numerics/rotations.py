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
matrix, linear in lambda, G(lambda) lambda = 0).
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
