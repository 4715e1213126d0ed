"""BEAM's compiled twin: its deformations and inertia points for one element per call.

The formulas of `flexure.core.elements.beam` (its module docstring) for one element, for the
compiled evaluation engine (`flexure.core.engine`), with scalar loops and no allocation; they
compute what `beam.deformations` and `beam.inertia_points` compute, and
tests/test_kernels_spatial.py checks them against those to round-off. The element registry
reads `pack_reference`, `REFERENCE_WIDTH`, `deformations_entry` and `inertia_entry` from
`beam`, which takes them from here (`deformations_entry` from `beam_directional`, whose
kernel gives the equations of motion v^T D2e v without D2e).

Where numpy contracts the constant tensors C of `rotations.vector_tensor` (48 floats per
node vector, R(lambda) a = C lambda lambda), these kernels use the closed forms of
`rotation_kernels` (`rotated_vector`, `rotated_half_jacobian`, `rotated_contraction`) on the
body vector a itself: the same numbers to round-off for a few flops each. So the packed
reference row holds the element frame's vectors (21 floats per element where the tensors
took 483), and e1's Hessian, symmetric, is formed once per pair of columns and mirrored.
"""

import numpy as np

from ..numerics.jit import kernel
from ..numerics.rotation_kernels import rotated_contraction, rotated_half_jacobian, rotated_vector
from . import entries

# The packed reference row is [l0, c, c_t, az_p, az_q, ay_p, ay_q, ax_p, ax_q] (each vector
# three floats, in its node's body frame): the bending vectors in `beam._BEND_AXES`' order.
AZ_P, AZ_Q, AY_P, AY_Q, AX_P, AX_Q = 3, 6, 9, 12, 15, 18
REFERENCE_WIDTH = 21  # floats, 168 B per element
# x columns of the translations and Euler parameters of p and q
XP, XLP, XQ, XLQ = 0, 3, 7, 10


def pack_reference(ref):
    """(n, REFERENCE_WIDTH) float64, C-contiguous: the rows the kernels read of `reference()`."""
    n = ref["l0"].size
    packed = np.empty((n, REFERENCE_WIDTH))
    packed[:, 0] = ref["l0"]
    packed[:, 1] = ref["c"]
    packed[:, 2] = ref["c_t"]
    for start, key in ((AZ_P, "az_p"), (AZ_Q, "az_q"), (AY_P, "ay_p"), (AY_Q, "ay_q"),
                       (AX_P, "ax_p"), (AX_Q, "ax_q")):
        packed[:, start:start + 3] = ref[key]
    return packed


# The Euler parameters are read once into scalars m0 ... m3 and passed as such: indexing x
# inside the helpers made the kernels two to three times slower. The arithmetic helpers are
# inlined by numba; the ones that store into D2e are called, and LLVM inlines what pays.
# Inlined by numba, their 37 call sites (26 of them `_zero`'s loops in `_zero_structural`)
# made the deformations kernel's first compilation 9.5 s of CPU instead of 3.3, for the same
# speed.
@kernel(inline="always")
def _rotated(ref, start, m0, m1, m2, m3):
    """u = R(lambda) a (three components), a = ref[start:start + 3], lambda = [m0 ... m3]."""
    return rotated_vector(ref[start], ref[start + 1], ref[start + 2], m0, m1, m2, m3)


@kernel(inline="always")
def _half_jacobian(ref, start, m0, m1, m2, m3):
    """h = C lambda (Du = 2 h) as its four columns, of the body vector a = ref[start:start + 3]."""
    return rotated_half_jacobian(ref[start], ref[start + 1], ref[start + 2], m0, m1, m2, m3)


@kernel(inline="always")
def _contraction(ref, start, w0, w1, w2):
    """The ten entries of the symmetric w . C of the body vector a = ref[start:start + 3]."""
    return rotated_contraction(ref[start], ref[start + 1], ref[start + 2], w0, w1, w2)


@kernel
def _store_symmetric(D2e, row, col, f, K, g, L):
    """D2e[row] on the 4 x 4 block at (col, col) = f K + g L, both symmetric, as their ten
    entries (`_contraction`'s order)."""
    n = 0
    for i in range(4):
        for j in range(i, 4):
            value = f * K[n] + g * L[n]
            D2e[row, col + i, col + j] = value
            D2e[row, col + j, col + i] = value
            n += 1


@kernel
def _store_mixed(D2e, row, col, v0, v1, v2):
    """D2e[row] between x column col and the translations: v (the l part) at r^q, -v at r^p."""
    D2e[row, XQ, col] = D2e[row, col, XQ] = v0
    D2e[row, XQ + 1, col] = D2e[row, col, XQ + 1] = v1
    D2e[row, XQ + 2, col] = D2e[row, col, XQ + 2] = v2
    D2e[row, XP, col] = D2e[row, col, XP] = -v0
    D2e[row, XP + 1, col] = D2e[row, col, XP + 1] = -v1
    D2e[row, XP + 2, col] = D2e[row, col, XP + 2] = -v2


@kernel
def _zero(D2e, row, i0, i1, j0, j1):
    """D2e[row, i0:i1, j0:j1] = 0."""
    for i in range(i0, i1):
        for j in range(j0, j1):
            D2e[row, i, j] = 0.0


@kernel
def _zero_structural(D2e):
    """The entries of D2e's rows 1 ... 5 that are zero by structure, which the kernel does not
    write otherwise: e2 is free of the translations (r^p 0:3, r^q 7:10); e3, e5 (rows 2, 4)
    involve lambda^p (3:7) alone and its products with the translations, e4, e6 (rows 3, 5)
    likewise lambda^q (10:14)."""
    _zero(D2e, 1, 0, 3, 0, 14)
    _zero(D2e, 1, 7, 10, 0, 14)
    for first in (3, 10):
        _zero(D2e, 1, first, first + 4, 0, 3)
        _zero(D2e, 1, first, first + 4, 7, 10)
    for row in (2, 4):
        _zero(D2e, row, 0, 3, 0, 3)
        _zero(D2e, row, 0, 3, 7, 14)
        _zero(D2e, row, 7, 10, 0, 3)
        _zero(D2e, row, 7, 10, 7, 14)
        _zero(D2e, row, 10, 14, 0, 14)
        _zero(D2e, row, 3, 7, 10, 14)
    for row in (3, 5):
        _zero(D2e, row, 0, 3, 0, 10)
        _zero(D2e, row, 7, 10, 0, 10)
        _zero(D2e, row, 3, 7, 0, 14)
        _zero(D2e, row, 10, 14, 3, 7)


@kernel
def deformations_kernel(x, ref, order, e, De, D2e):
    """e (6,), De (6, 14) if order >= 1, D2e (6, 14, 14) if order >= 2 of one element: x (14,),
    ref its packed reference row. Overwrites every entry of the arrays it fills; no allocation.
    """
    _deformations(x, ref, order, e, De, D2e, e, False)


@kernel
def kept_deformations_kernel(x, ref, e, De, points):
    """`deformations_kernel` at order 1, and the rotations its rates share
    (`beam_directional.points_kernel` and `kept_points_kernel`) into one element's kept
    points (`beam_directional.POINTS_WIDTH`,): the section axes' Dp blocks (2 h of
    n_y'^p, n_z'^p, n_y'^q, n_z'^q: blocks 2 ... 5 of that layout) and the node vectors
    n_z'^p, n_z'^q, n_y'^p, n_y'^q (at VECTORS_AT), each as the two kernels compute it.
    e, De as `deformations_kernel`'s; no allocation."""
    _deformations(x, ref, 1, e, De, points[:1].reshape((1, 1, 1)), points, True)


VECTORS_AT = 96  # the node vectors' place in the kept points (after Dp's blocks and acc)


@kernel(inline="always")
def _deformations(x, ref, order, e, De, D2e, kept, keeping):
    """`deformations_kernel`, with keeping also `kept_deformations_kernel`'s rotations into
    kept (read only then)."""
    l0 = ref[0]
    c = ref[1]
    c_t = ref[2]
    half = 0.5 * l0
    lx = x[XQ] - x[XP]
    ly = x[XQ + 1] - x[XP + 1]
    lz = x[XQ + 2] - x[XP + 2]
    m0, m1, m2, m3 = x[XLP], x[XLP + 1], x[XLP + 2], x[XLP + 3]  # lambda^p
    k0, k1, k2, k3 = x[XLQ], x[XLQ + 1], x[XLQ + 2], x[XLQ + 3]  # lambda^q
    # the node vectors [n_z'^p, n_z'^q, n_y'^p, n_y'^q] (see beam._BEND_AXES)
    a0, a1, a2 = _rotated(ref, AZ_P, m0, m1, m2, m3)
    b0, b1, b2 = _rotated(ref, AZ_Q, k0, k1, k2, k3)
    c0, c1, c2 = _rotated(ref, AY_P, m0, m1, m2, m3)
    d0, d1, d2 = _rotated(ref, AY_Q, k0, k1, k2, k3)
    if keeping:
        kept[VECTORS_AT], kept[VECTORS_AT + 1], kept[VECTORS_AT + 2] = a0, a1, a2
        kept[VECTORS_AT + 3], kept[VECTORS_AT + 4], kept[VECTORS_AT + 5] = b0, b1, b2
        kept[VECTORS_AT + 6], kept[VECTORS_AT + 7], kept[VECTORS_AT + 8] = c0, c1, c2
        kept[VECTORS_AT + 9], kept[VECTORS_AT + 10], kept[VECTORS_AT + 11] = d0, d1, d2
    e3 = -(a0 * lx + a1 * ly + a2 * lz)
    e4 = b0 * lx + b1 * ly + b2 * lz
    e5 = c0 * lx + c1 * ly + c2 * lz
    e6 = -(d0 * lx + d1 * ly + d2 * lz)
    e[2] = e3
    e[3] = e4
    e[4] = e5
    e[5] = e6
    e2 = half * ((a0 * d0 + a1 * d1 + a2 * d2) - (c0 * b0 + c1 * b1 + c2 * b2))
    e[1] = e2
    length = np.sqrt(lx * lx + ly * ly + lz * lz)
    quadratic = (e3 * e3 * 2.0 + e3 * e4 * 1.0 + e4 * e4 * 2.0 + e5 * e5 * 2.0
                 + e5 * e6 * 1.0 + e6 * e6 * 2.0)
    e[0] = length - l0 + c * quadratic + c_t * (e2 * e2)
    if order < 1:
        return
    s2 = 2.0 * c_t * e2  # d e1 / d e2 ... e6
    s3 = c * (4.0 * e3 + e4)
    s4 = c * (4.0 * e4 + e3)
    s5 = c * (4.0 * e5 + e6)
    s6 = c * (4.0 * e6 + e5)
    # translations: d e / d r^q = Dz (l), d e / d r^p its negative
    ux = lx / length
    uy = ly / length
    uz = lz / length
    for k in range(3):
        na = (a0, a1, a2)[k]
        nb = (b0, b1, b2)[k]
        nc = (c0, c1, c2)[k]
        nd = (d0, d1, d2)[k]
        g3 = -na
        g4 = nb
        g5 = nc
        g6 = -nd
        g1 = (ux, uy, uz)[k] + (((s3 * g3 + s4 * g4) + s5 * g5) + s6 * g6)
        De[0, XQ + k] = g1
        De[1, XQ + k] = 0.0
        De[2, XQ + k] = g3
        De[3, XQ + k] = g4
        De[4, XQ + k] = g5
        De[5, XQ + k] = g6
        De[0, XP + k] = -g1
        De[1, XP + k] = 0.0
        De[2, XP + k] = -g3
        De[3, XP + k] = -g4
        De[4, XP + k] = -g5
        De[5, XP + k] = -g6
    if order >= 2:  # zero what is not written below (row 0 is written whole)
        _zero_structural(D2e)
    # Euler parameters: column i of Dn = 2 h_i for each vector; bending l^T Dn, torsion
    # n_(3-i)^T Dn
    ha = _half_jacobian(ref, AZ_P, m0, m1, m2, m3)  # D n_z'^p / 2
    hb = _half_jacobian(ref, AZ_Q, k0, k1, k2, k3)  # D n_z'^q / 2
    hc = _half_jacobian(ref, AY_P, m0, m1, m2, m3)  # D n_y'^p / 2
    hd = _half_jacobian(ref, AY_Q, k0, k1, k2, k3)  # D n_y'^q / 2
    for i in range(4):
        p0, p1, p2 = 2.0 * ha[i][0], 2.0 * ha[i][1], 2.0 * ha[i][2]  # D n_z'^p
        q0, q1, q2 = 2.0 * hb[i][0], 2.0 * hb[i][1], 2.0 * hb[i][2]  # D n_z'^q
        r0, r1, r2 = 2.0 * hc[i][0], 2.0 * hc[i][1], 2.0 * hc[i][2]  # D n_y'^p
        w0, w1, w2 = 2.0 * hd[i][0], 2.0 * hd[i][1], 2.0 * hd[i][2]  # D n_y'^q
        if keeping:  # Dp's blocks 2 ... 5: rows 12 n_y'^p, 15 n_z'^p, 18 n_y'^q, 21 n_z'^q
            kept[24 + 3 * i], kept[24 + 3 * i + 1], kept[24 + 3 * i + 2] = r0, r1, r2
            kept[36 + 3 * i], kept[36 + 3 * i + 1], kept[36 + 3 * i + 2] = p0, p1, p2
            kept[48 + 3 * i], kept[48 + 3 * i + 1], kept[48 + 3 * i + 2] = w0, w1, w2
            kept[60 + 3 * i], kept[60 + 3 * i + 1], kept[60 + 3 * i + 2] = q0, q1, q2
        g3 = -(lx * p0 + ly * p1 + lz * p2)
        g5 = lx * r0 + ly * r1 + lz * r2
        g4 = lx * q0 + ly * q1 + lz * q2
        g6 = -(lx * w0 + ly * w1 + lz * w2)
        g2p = half * ((d0 * p0 + d1 * p1 + d2 * p2) - (b0 * r0 + b1 * r1 + b2 * r2))
        g2q = half * ((a0 * w0 + a1 * w1 + a2 * w2) - (c0 * q0 + c1 * q1 + c2 * q2))
        De[0, XLP + i] = s3 * g3 + s5 * g5 + s2 * g2p
        De[0, XLQ + i] = s4 * g4 + s6 * g6 + s2 * g2q
        De[1, XLP + i] = g2p
        De[1, XLQ + i] = g2q
        De[2, XLP + i] = g3
        De[2, XLQ + i] = 0.0
        De[3, XLP + i] = 0.0
        De[3, XLQ + i] = g4
        De[4, XLP + i] = g5
        De[4, XLQ + i] = 0.0
        De[5, XLP + i] = 0.0
        De[5, XLQ + i] = g6
        if order >= 2:
            # bending: d2 e / dl dlambda = sign Dn
            _store_mixed(D2e, 2, XLP + i, -p0, -p1, -p2)
            _store_mixed(D2e, 3, XLQ + i, q0, q1, q2)
            _store_mixed(D2e, 4, XLP + i, r0, r1, r2)
            _store_mixed(D2e, 5, XLQ + i, -w0, -w1, -w2)
            # torsion between the nodes: l0 / 2 (Dn_0^T Dn_3 - Dn_2^T Dn_1)
            for j in range(4):
                mixed = half * ((p0 * (2.0 * hd[j][0]) + p1 * (2.0 * hd[j][1])
                                 + p2 * (2.0 * hd[j][2]))
                                - (r0 * (2.0 * hb[j][0]) + r1 * (2.0 * hb[j][1])
                                   + r2 * (2.0 * hb[j][2])))
                D2e[1, XLP + i, XLQ + j] = mixed
                D2e[1, XLQ + j, XLP + i] = mixed
    if order < 2:
        return
    # bending: d2 e / dlambda2 = 2 sign l . C; torsion within a node: l0 sign n_(3-i) . C_i
    kl_a = _contraction(ref, AZ_P, lx, ly, lz)
    kl_b = _contraction(ref, AZ_Q, lx, ly, lz)
    kl_c = _contraction(ref, AY_P, lx, ly, lz)
    kl_d = _contraction(ref, AY_Q, lx, ly, lz)
    _store_symmetric(D2e, 2, XLP, -2.0, kl_a, 0.0, kl_a)  # one tensor: its second term 0
    _store_symmetric(D2e, 3, XLQ, 2.0, kl_b, 0.0, kl_b)
    _store_symmetric(D2e, 4, XLP, 2.0, kl_c, 0.0, kl_c)
    _store_symmetric(D2e, 5, XLQ, -2.0, kl_d, 0.0, kl_d)
    _store_symmetric(D2e, 1, XLP, l0, _contraction(ref, AZ_P, d0, d1, d2),
                     -l0, _contraction(ref, AY_P, b0, b1, b2))
    _store_symmetric(D2e, 1, XLQ, -l0, _contraction(ref, AZ_Q, c0, c1, c2),
                     l0, _contraction(ref, AY_Q, a0, a1, a2))
    # elongation: c Db^T W Db + 2 c_t De2^T De2 + sum_k slope_k D2e_k (k = 2 ... 6), and
    # (I - u u^T) / |l| on the translations: block by block of z = [l, lambda^p, lambda^q],
    # leaving out the terms that are zero by structure (e2 does not involve l, e3 and e5 not
    # lambda^q, e4 and e6 not lambda^p), the upper triangle mirrored; an r^p column is minus
    # its r^q column
    ct2 = 2.0 * c_t
    for k in range(3):
        i = XQ + k
        g3i, g4i, g5i, g6i = De[2, i], De[3, i], De[4, i], De[5, i]
        uk = (ux, uy, uz)[k]
        for m in range(k, 3):
            j = XQ + m
            g3j, g4j, g5j, g6j = De[2, j], De[3, j], De[4, j], De[5, j]
            value = (c * (4.0 * ((g3i * g3j + g4i * g4j) + (g5i * g5j + g6i * g6j))
                          + ((g3i * g4j + g4i * g3j) + (g5i * g6j + g6i * g5j)))
                     + ((1.0 if k == m else 0.0) - uk * (ux, uy, uz)[m]) / length)
            D2e[0, i, j] = D2e[0, j, i] = value
            D2e[0, i - 7, j - 7] = D2e[0, j - 7, i - 7] = value
            D2e[0, i - 7, j] = D2e[0, j, i - 7] = -value
            D2e[0, i, j - 7] = D2e[0, j - 7, i] = -value
        for j in range(XLP, XLP + 4):
            g3j, g5j = De[2, j], De[4, j]
            value = (c * (4.0 * (g3i * g3j + g5i * g5j) + (g4i * g3j + g6i * g5j))
                     + (s3 * D2e[2, i, j] + s5 * D2e[4, i, j]))
            D2e[0, i, j] = D2e[0, j, i] = value
            D2e[0, i - 7, j] = D2e[0, j, i - 7] = -value
        for j in range(XLQ, XLQ + 4):
            g4j, g6j = De[3, j], De[5, j]
            value = (c * (4.0 * (g4i * g4j + g6i * g6j) + (g3i * g4j + g5i * g6j))
                     + (s4 * D2e[3, i, j] + s6 * D2e[5, i, j]))
            D2e[0, i, j] = D2e[0, j, i] = value
            D2e[0, i - 7, j] = D2e[0, j, i - 7] = -value
    for i in range(4):
        ip, iq = XLP + i, XLQ + i
        g2p, g3i, g5i = De[1, ip], De[2, ip], De[4, ip]
        g2q, g4i, g6i = De[1, iq], De[3, iq], De[5, iq]
        for j in range(i, 4):
            jp, jq = XLP + j, XLQ + j
            value = (c * (4.0 * (g3i * De[2, jp] + g5i * De[4, jp])) + ct2 * (g2p * De[1, jp])
                     + (s2 * D2e[1, ip, jp] + s3 * D2e[2, ip, jp] + s5 * D2e[4, ip, jp]))
            D2e[0, ip, jp] = D2e[0, jp, ip] = value
            value = (c * (4.0 * (g4i * De[3, jq] + g6i * De[5, jq])) + ct2 * (g2q * De[1, jq])
                     + (s2 * D2e[1, iq, jq] + s4 * D2e[3, iq, jq] + s6 * D2e[5, iq, jq]))
            D2e[0, iq, jq] = D2e[0, jq, iq] = value
        for j in range(4):
            jq = XLQ + j
            value = (c * (g3i * De[3, jq] + g5i * De[5, jq]) + ct2 * (g2p * De[1, jq])
                     + s2 * D2e[1, ip, jq])
            D2e[0, ip, jq] = D2e[0, jq, ip] = value


@kernel
def inertia_kernel(x, v, ref, order, p, Dp, acc):
    """p (24,), Dp (24, 14) if order >= 1, acc = (D2p v) v (24,) if order >= 2 of one element:
    x, v (14,), ref its packed reference row. Overwrites every entry it fills; no allocation."""
    l0 = ref[0]
    for k in range(3):
        p[k] = x[XP + k]
        p[6 + k] = x[XQ + k]
    if order >= 1:
        for r in range(24):
            for i in range(14):
                Dp[r, i] = 0.0
        for k in range(3):
            Dp[k, XP + k] = 1.0
            Dp[6 + k, XQ + k] = 1.0
    if order >= 2:
        for k in range(3):
            acc[k] = 0.0
            acc[6 + k] = 0.0
    # the vectors [ax_p, ay_p, az_p, ax_q, ay_q, az_q] (see beam._INERTIA_AXES) at their rows
    m0, m1, m2, m3 = x[XLP], x[XLP + 1], x[XLP + 2], x[XLP + 3]
    _inertia_vector(v, ref, order, p, Dp, acc, 3, XLP, l0, AX_P, m0, m1, m2, m3)
    _inertia_vector(v, ref, order, p, Dp, acc, 12, XLP, 1.0, AY_P, m0, m1, m2, m3)
    _inertia_vector(v, ref, order, p, Dp, acc, 15, XLP, 1.0, AZ_P, m0, m1, m2, m3)
    m0, m1, m2, m3 = x[XLQ], x[XLQ + 1], x[XLQ + 2], x[XLQ + 3]
    _inertia_vector(v, ref, order, p, Dp, acc, 9, XLQ, l0, AX_Q, m0, m1, m2, m3)
    _inertia_vector(v, ref, order, p, Dp, acc, 18, XLQ, 1.0, AY_Q, m0, m1, m2, m3)
    _inertia_vector(v, ref, order, p, Dp, acc, 21, XLQ, 1.0, AZ_Q, m0, m1, m2, m3)


@kernel(inline="always")
def _inertia_vector(v, ref, order, p, Dp, acc, row, col, scale, start, m0, m1, m2, m3):
    """The rows row ... row + 2 of p, Dp, acc of the inertia point scale R(lambda) a, a the
    body vector ref[start:start + 3], lambda = [m0, m1, m2, m3] = x[col:col + 4]: scale 2 h
    (h = C lambda) and scale (2 C v) v = 2 scale R(v) a (C v v is R's quadratic form at v)."""
    u = _rotated(ref, start, m0, m1, m2, m3)
    for k in range(3):
        p[row + k] = scale * u[k]
    if order >= 1:
        h = _half_jacobian(ref, start, m0, m1, m2, m3)
        for i in range(4):
            for k in range(3):
                Dp[row + k, col + i] = scale * (2.0 * h[i][k])
    if order >= 2:
        w = _rotated(ref, start, v[col], v[col + 1], v[col + 2], v[col + 3])
        for k in range(3):
            acc[row + k] = scale * (2.0 * w[k])


inertia_entry = entries.inertia_entry(inertia_kernel)
