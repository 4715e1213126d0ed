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
from ..numerics.rotations import rotate, vector_tensor
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
# allocation. The packed reference row holds the tensors C_k (3 x 4 x 4) of the three body
# vectors b_k (`rotations.vector_tensor`, R(lambda) b_k = C_k lambda lambda), C_k at
# ref[48 k + 16 m + 4 i + j] = (C_k)_mij.

REFERENCE_WIDTH = 3 * 48  # 144 floats


def pack_reference(ref):
    """(n, REFERENCE_WIDTH) float64, C-contiguous, of the reference {"axes": (n, 3, 3)} (the
    body vectors b_k as columns)."""
    axes = np.asarray(ref["axes"], float)
    tensors = vector_tensor(np.swapaxes(axes, 1, 2))  # (n, 3 vectors, 3, 4, 4)
    return np.ascontiguousarray(tensors.reshape(axes.shape[0], REFERENCE_WIDTH))


@kernel
def inertia_kernel(x, v, ref, order, p, Dp, acc):
    """p (9,), Dp (9, 4) if order >= 1, acc = (D2p v) v (9,) if order >= 2 of one node: its
    Euler parameters x (4,) and their rates v (4,), ref its packed reference row. Overwrites
    every entry it fills; no allocation. With C the tensor of a point's component: p = (C
    lambda) . lambda, Dp = 2 C lambda, D2p = 2 C."""
    m0, m1, m2, m3 = x[0], x[1], x[2], x[3]  # as scalars: indexing x in the loop is slower
    for row in range(9):
        base = 16 * row  # 48 k + 16 m for component m of point k, row 3 k + m
        h0 = ref[base] * m0 + ref[base + 1] * m1 + ref[base + 2] * m2 + ref[base + 3] * m3
        h1 = ref[base + 4] * m0 + ref[base + 5] * m1 + ref[base + 6] * m2 + ref[base + 7] * m3
        h2 = ref[base + 8] * m0 + ref[base + 9] * m1 + ref[base + 10] * m2 + ref[base + 11] * m3
        h3 = (ref[base + 12] * m0 + ref[base + 13] * m1 + ref[base + 14] * m2
              + ref[base + 15] * m3)
        p[row] = h0 * m0 + h1 * m1 + h2 * m2 + h3 * m3
        if order >= 1:
            Dp[row, 0] = 2.0 * h0
            Dp[row, 1] = 2.0 * h1
            Dp[row, 2] = 2.0 * h2
            Dp[row, 3] = 2.0 * h3
        if order >= 2:
            rate = 0.0
            for i in range(4):
                half = 0.0
                for j in range(4):
                    half += ref[base + 4 * i + j] * v[j]
                rate += half * v[i]
            acc[row] = 2.0 * rate


inertia_entry = entries.inertia_entry(inertia_kernel)
