"""Rotational inertia of 3-D rotational nodes (Euler parameters) as inertia points.

A rigid body attached to a rotational node, with inertia tensor J (kg m^2) constant in the
node's body frame, has the kinetic energy T = 1/2 omega'^T J omega'. It is carried here by
three points fixed to the node, p_k = R(lambda) b_k (unit vectors b_k in the body frame), with
"masses" s_k: since |d/dt (R b)|^2 = |omega' x b|^2,

    1/2 sum_k s_k |p_k_dot|^2 = 1/2 omega'^T (tr(S) I - S) omega',   S = sum_k s_k b_k b_k^T,

which is T for S = tr(J) / 2 I - J: b_k and s_k are the eigenvectors and eigenvalues of S
(s_k >= 0 for a physical J, by the triangle inequality of its principal moments; an idealised
J, e.g. an inertia about one axis only, gives a negative s_k, which the algebra does not mind).
This is the form 1/2 pdot^T Mp pdot with a constant Mp that `assembly.Inertia` uses for the
element masses (and that the planar PLBEAM uses for its end tangents), so the mass matrix,
the convective force (D2p v) v, and every consumer of `Inertia.groups` treat it like an
element mass; the points are "tangent" points, so gravity does not act on them.

Off the normalisation constraint R(lambda) scales with |lambda|^2, so this kinetic energy
differs from 1/2 omega'^T J omega' with omega' = 2 G(lambda) lambda_dot there; the
constrained motion depends only on the kinetic energy on the constraint (Hamilton's principle
over constrained paths), where both agree (tested against Euler's equations).

The source of J: the lumped node inertias of a scene (`Model.node_inertias`). The spatial
BEAM carries its section's rotational inertia in the same way, with its own inertia points
(the section axes, see flexure.core.elements.beam).

`inertia_kernel` evaluates the same points for one node, from its row of `pack_reference`, for
the compiled evaluation engine.
"""

import numpy as np

from ..model import ElementGroup
from ..numerics.jit import kernel
from ..numerics.rotation_kernels import rotated_half_jacobian, rotated_vector
from ..numerics.rotations import rotate
from . import entries

type_name = "NODE_INERTIA"
inertia_point_kinds = ("tangent", "tangent", "tangent")


def inertia_points(x, ref, order=2):
    """The points [R b_1, R b_2, R b_3] (n, 9) of the nodes' Euler parameters x (n, 4)."""
    parts = [rotate(x, ref["axes"][:, :, k], order) for k in range(3)]
    p = np.concatenate([part[0] for part in parts], axis=1)
    if order == 0:
        return (p,)
    Dp = np.concatenate([part[1] for part in parts], axis=1)
    if order == 1:
        return p, Dp
    return p, Dp, np.concatenate([part[2] for part in parts], axis=1)


def point_masses(J):
    """(s (n, 3) kg m^2, b (n, 3, 3) columns in the body frame) for inertia tensors J (n, 3, 3)."""
    J = 0.5 * (J + np.swapaxes(J, 1, 2))
    trace = np.trace(J, axis1=1, axis2=2)
    S = 0.5 * trace[:, None, None] * np.eye(3)[None] - J
    return np.linalg.eigh(S)


def node_inertia_groups(model):
    """[(ElementGroup, Mp (n, 9, 9))]: every rigid-body inertia on a 3-D rotational node."""
    indices, tensors = [], []
    for index, J in getattr(model, "node_inertias", ()):
        indices.append(np.asarray(index, int)[None])
        tensors.append(np.asarray(J, float)[None])
    if not indices:
        return []
    index, J = np.concatenate(indices), np.concatenate(tensors)
    keep = np.any(J != 0.0, axis=(1, 2))
    if not np.any(keep):
        return []
    index, J = index[keep], J[keep]
    masses, axes = point_masses(J)
    Mp = np.einsum("nk,kl,ab->nkalb", masses, np.eye(3), np.eye(3)).reshape(-1, 9, 9)
    group = ElementGroup(kind=_self(), names=tuple(f"inertia{i}" for i in range(len(index))),
                         coordinate_index=index, deformation_index=np.zeros((len(index), 0), int),
                         reference={"axes": axes}, properties={})
    return [(group, Mp)]


def _self():
    import sys

    return sys.modules[__name__]


# -- compiled kernel (one node per call) -------------------------------------------------------
# `inertia_points` for one node, for the compiled evaluation engine, with scalar loops and no
# allocation. The packed reference row holds the three body vectors b_k (b_k at ref[3 k:3 k +
# 3]); the kernel rotates them by the closed forms of `rotation_kernels`, which give what
# `rotations.rotate` gives through the tensors of `rotations.vector_tensor` to round-off.

REFERENCE_WIDTH = 9  # floats


def pack_reference(ref):
    """(n, REFERENCE_WIDTH) float64, C-contiguous, of the reference {"axes": (n, 3, 3)} (the
    body vectors b_k as columns): b_k at columns 3 k ... 3 k + 2."""
    axes = np.asarray(ref["axes"], float)
    return np.ascontiguousarray(np.swapaxes(axes, 1, 2).reshape(axes.shape[0], REFERENCE_WIDTH))


@kernel
def inertia_kernel(x, v, ref, order, p, Dp, acc):
    """p (9,), Dp (9, 4) if order >= 1, acc = (D2p v) v (9,) if order >= 2 of one node: its
    Euler parameters x (4,) and their rates v (4,), ref its packed reference row. Overwrites
    every entry it fills; no allocation. Point k: p_k = R(lambda) b_k, Dp_k = 2 C_k lambda,
    (D2p_k v) v = 2 C_k v v = 2 R(v) b_k (R's quadratic form at v)."""
    m0, m1, m2, m3 = x[0], x[1], x[2], x[3]  # as scalars: indexing x in the loop is slower
    for k in range(3):
        b0, b1, b2 = ref[3 * k], ref[3 * k + 1], ref[3 * k + 2]
        u = rotated_vector(b0, b1, b2, m0, m1, m2, m3)
        for c in range(3):
            p[3 * k + c] = u[c]
        if order >= 1:
            h = rotated_half_jacobian(b0, b1, b2, m0, m1, m2, m3)
            for i in range(4):
                for c in range(3):
                    Dp[3 * k + c, i] = 2.0 * h[i][c]
        if order >= 2:
            w = rotated_vector(b0, b1, b2, v[0], v[1], v[2], v[3])
            for c in range(3):
                acc[3 * k + c] = 2.0 * w[c]


inertia_entry = entries.inertia_entry(inertia_kernel)
