"""BEAM's compiled twin: its deformations and inertia points for one element per call.

The formulas of `flexure.core.elements.beam` (its module docstring) for one element, for the
compiled evaluation engine (`flexure.core.engine`), with scalar loops and no allocation; they
compute what `beam.deformations` and `beam.inertia_points` compute, in the same order of
operations where it costs nothing, and tests/test_kernels_spatial.py checks them against those
to round-off. The element registry reads `pack_reference`, `REFERENCE_WIDTH`,
`deformations_entry` and `inertia_entry` from `beam`, which takes them from here.
"""

import numpy as np

from ..numerics.jit import kernel
from . import entries

# The packed reference row is
# [l0, c, c_t, bend_tensors (4 x 3 x 4 x 4), inertia_tensors (6 x 3 x 4 x 4)]; inertia_scale is
# l0 on the vectors ax_p, ax_q and 1 on the others. A tensor C (3 x 4 x 4) sits at
# ref[base + 16 k + 4 i + j] = C_kij.

_REF_BEND = 3
_REF_INERTIA = _REF_BEND + 4 * 48
REFERENCE_WIDTH = _REF_INERTIA + 6 * 48  # 483 floats, 3.9 kB per element
# x columns of the translations and Euler parameters of p and q
_XP, _XLP, _XQ, _XLQ = 0, 3, 7, 10
_TRANSLATIONS = (0, 1, 2, 7, 8, 9)  # the x columns of r^p and r^q


def pack_reference(ref):
    """(n, REFERENCE_WIDTH) float64, C-contiguous: the rows the kernels read of `reference()`."""
    n = ref["l0"].size
    packed = np.empty((n, REFERENCE_WIDTH))
    packed[:, 0] = ref["l0"]
    packed[:, 1] = ref["c"]
    packed[:, 2] = ref["c_t"]
    packed[:, _REF_BEND:_REF_INERTIA] = ref["bend_tensors"].reshape(n, 4 * 48)
    packed[:, _REF_INERTIA:] = ref["inertia_tensors"].reshape(n, 6 * 48)
    return packed


# The Euler parameters are read once into scalars m0 ... m3 and passed as such: indexing x
# inside the helpers made the kernels two to three times slower. The helpers are inlined by
# numba, except `_row`, the innermost and most used: LLVM inlines that one as well, and
# numba's inlining of its many uses doubled the kernels' first compilation (6.3 s against
# 3.8 s) for the same speed (974-1055 ns against 979-1019 ns per pair of calls).
@kernel
def _row(ref, start, m0, m1, m2, m3):
    """(C lambda)_i of the row C_i. = ref[start:start + 4], lambda = [m0, m1, m2, m3]."""
    return ref[start] * m0 + ref[start + 1] * m1 + ref[start + 2] * m2 + ref[start + 3] * m3


@kernel(inline="always")
def _quadratic(ref, start, m0, m1, m2, m3):
    """(C lambda) . lambda of the 4 x 4 block C = ref[start:start + 16]."""
    return (_row(ref, start, m0, m1, m2, m3) * m0 + _row(ref, start + 4, m0, m1, m2, m3) * m1
            + _row(ref, start + 8, m0, m1, m2, m3) * m2
            + _row(ref, start + 12, m0, m1, m2, m3) * m3)


@kernel(inline="always")
def _rotated_vector(ref, base, m0, m1, m2, m3):
    """u = C lambda lambda (three components) of the tensor C at ref[base:base + 48]."""
    return (_quadratic(ref, base, m0, m1, m2, m3), _quadratic(ref, base + 16, m0, m1, m2, m3),
            _quadratic(ref, base + 32, m0, m1, m2, m3))


@kernel(inline="always")
def _derivative_column(ref, base, i, m0, m1, m2, m3):
    """Column i of Du = 2 C lambda (three components) of the tensor C at ref[base:base + 48]."""
    start = base + 4 * i
    return (2.0 * _row(ref, start, m0, m1, m2, m3), 2.0 * _row(ref, start + 16, m0, m1, m2, m3),
            2.0 * _row(ref, start + 32, m0, m1, m2, m3))


@kernel(inline="always")
def _contracted(ref, base, w0, w1, w2, i, j):
    """(w . C)_ij = sum_k w_k C_kij of the tensor C at ref[base:base + 48]."""
    offset = base + 4 * i + j
    return w0 * ref[offset] + w1 * ref[offset + 16] + w2 * ref[offset + 32]


@kernel(inline="always")
def _store_mixed(D2e, row, col, v0, v1, v2):
    """D2e[row] between x column col and the translations: v (the l part) at r^q, -v at r^p."""
    D2e[row, _XQ, col] = D2e[row, col, _XQ] = v0
    D2e[row, _XQ + 1, col] = D2e[row, col, _XQ + 1] = v1
    D2e[row, _XQ + 2, col] = D2e[row, col, _XQ + 2] = v2
    D2e[row, _XP, col] = D2e[row, col, _XP] = -v0
    D2e[row, _XP + 1, col] = D2e[row, col, _XP + 1] = -v1
    D2e[row, _XP + 2, col] = D2e[row, col, _XP + 2] = -v2


@kernel
def deformations_kernel(x, ref, order, e, De, D2e):
    """e (6,), De (6, 14) if order >= 1, D2e (6, 14, 14) if order >= 2 of one element: x (14,),
    ref its packed reference row. Overwrites every entry of the arrays it fills; no allocation.
    """
    l0 = ref[0]
    c = ref[1]
    c_t = ref[2]
    half = 0.5 * l0
    lx = x[_XQ] - x[_XP]
    ly = x[_XQ + 1] - x[_XP + 1]
    lz = x[_XQ + 2] - x[_XP + 2]
    # the node vectors [n_z'^p, n_z'^q, n_y'^p, n_y'^q] (see _BEND_AXES) and their tensors
    t0 = _REF_BEND
    t1 = _REF_BEND + 48
    t2 = _REF_BEND + 96
    t3 = _REF_BEND + 144
    m0, m1, m2, m3 = x[_XLP], x[_XLP + 1], x[_XLP + 2], x[_XLP + 3]  # lambda^p
    k0, k1, k2, k3 = x[_XLQ], x[_XLQ + 1], x[_XLQ + 2], x[_XLQ + 3]  # lambda^q
    a0, a1, a2 = _rotated_vector(ref, t0, m0, m1, m2, m3)
    b0, b1, b2 = _rotated_vector(ref, t1, k0, k1, k2, k3)
    c0, c1, c2 = _rotated_vector(ref, t2, m0, m1, m2, m3)
    d0, d1, d2 = _rotated_vector(ref, t3, k0, k1, k2, k3)
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
    if order >= 2:  # zero what is not written below (row 0 is written whole)
        for r in range(1, 6):
            for i in range(14):
                for j in range(14):
                    D2e[r, i, j] = 0.0
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
        De[0, _XQ + k] = g1
        De[1, _XQ + k] = 0.0
        De[2, _XQ + k] = g3
        De[3, _XQ + k] = g4
        De[4, _XQ + k] = g5
        De[5, _XQ + k] = g6
        De[0, _XP + k] = -g1
        De[1, _XP + k] = 0.0
        De[2, _XP + k] = -g3
        De[3, _XP + k] = -g4
        De[4, _XP + k] = -g5
        De[5, _XP + k] = -g6
    # Euler parameters: column i of Dn for each vector; bending l^T Dn, torsion n_(3-i)^T Dn
    for i in range(4):
        p0, p1, p2 = _derivative_column(ref, t0, i, m0, m1, m2, m3)  # D n_z'^p
        q0, q1, q2 = _derivative_column(ref, t1, i, k0, k1, k2, k3)  # D n_z'^q
        r0, r1, r2 = _derivative_column(ref, t2, i, m0, m1, m2, m3)  # D n_y'^p
        w0, w1, w2 = _derivative_column(ref, t3, i, k0, k1, k2, k3)  # D n_y'^q
        g3 = -(lx * p0 + ly * p1 + lz * p2)
        g5 = lx * r0 + ly * r1 + lz * r2
        g4 = lx * q0 + ly * q1 + lz * q2
        g6 = -(lx * w0 + ly * w1 + lz * w2)
        g2p = half * ((d0 * p0 + d1 * p1 + d2 * p2) - (b0 * r0 + b1 * r1 + b2 * r2))
        g2q = half * ((a0 * w0 + a1 * w1 + a2 * w2) - (c0 * q0 + c1 * q1 + c2 * q2))
        De[0, _XLP + i] = s3 * g3 + s5 * g5 + s2 * g2p
        De[0, _XLQ + i] = s4 * g4 + s6 * g6 + s2 * g2q
        De[1, _XLP + i] = g2p
        De[1, _XLQ + i] = g2q
        De[2, _XLP + i] = g3
        De[2, _XLQ + i] = 0.0
        De[3, _XLP + i] = 0.0
        De[3, _XLQ + i] = g4
        De[4, _XLP + i] = g5
        De[4, _XLQ + i] = 0.0
        De[5, _XLP + i] = 0.0
        De[5, _XLQ + i] = g6
        if order >= 2:
            # bending: d2 e / dl dlambda = sign Dn (kept there for the torsion below)
            _store_mixed(D2e, 2, _XLP + i, -p0, -p1, -p2)
            _store_mixed(D2e, 3, _XLQ + i, q0, q1, q2)
            _store_mixed(D2e, 4, _XLP + i, r0, r1, r2)
            _store_mixed(D2e, 5, _XLQ + i, -w0, -w1, -w2)
    if order < 2:
        return
    for i in range(4):
        for j in range(4):
            # bending: d2 e / dlambda2 = 2 sign l . C
            D2e[2, _XLP + i, _XLP + j] = -2.0 * _contracted(ref, t0, lx, ly, lz, i, j)
            D2e[3, _XLQ + i, _XLQ + j] = 2.0 * _contracted(ref, t1, lx, ly, lz, i, j)
            D2e[4, _XLP + i, _XLP + j] = 2.0 * _contracted(ref, t2, lx, ly, lz, i, j)
            D2e[5, _XLQ + i, _XLQ + j] = -2.0 * _contracted(ref, t3, lx, ly, lz, i, j)
            # torsion: l0 sign n_(3-i) . C_i, and l0 / 2 (Dn_0^T Dn_3 - Dn_2^T Dn_1) between
            # the nodes (the Dn read back from the bending rows, where they are stored exactly)
            D2e[1, _XLP + i, _XLP + j] = (l0 * _contracted(ref, t0, d0, d1, d2, i, j)
                                          + -l0 * _contracted(ref, t2, b0, b1, b2, i, j))
            D2e[1, _XLQ + i, _XLQ + j] = (-l0 * _contracted(ref, t1, c0, c1, c2, i, j)
                                          + l0 * _contracted(ref, t3, a0, a1, a2, i, j))
            cross_03 = 0.0  # (-Dn_0) (-Dn_3) in the rows of e3 and e6
            cross_21 = 0.0
            for k in range(3):
                cross_03 += D2e[2, _XQ + k, _XLP + i] * D2e[5, _XQ + k, _XLQ + j]
                cross_21 += D2e[4, _XQ + k, _XLP + i] * D2e[3, _XQ + k, _XLQ + j]
            mixed = half * (cross_03 - cross_21)
            D2e[1, _XLP + i, _XLQ + j] = mixed
            D2e[1, _XLQ + j, _XLP + i] = mixed
    # elongation: c Db^T W Db + sum_k slope_k D2e_k + (I - u u^T) / |l| on the translations
    # and 2 c_t De2^T De2 + s2 D2e2 on the Euler parameters, column by column, leaving out
    # the terms that are zero by structure (the rows of e3, e5 in De and D2e do not involve
    # lambda^q, those of e4, e6 not lambda^p, e2 does not involve the translations, and the
    # D2e of e2 ... e6 are zero between translations): each entry the sum of the same
    # non-zero terms in the same order as over all of them
    for j in range(14):
        w2 = 2.0 * c_t * De[1, j]
        w3 = c * (4.0 * De[2, j] + De[3, j])
        w4 = c * (De[2, j] + 4.0 * De[3, j])
        w5 = c * (4.0 * De[4, j] + De[5, j])
        w6 = c * (De[4, j] + 4.0 * De[5, j])
        on_p = _XLP <= j < _XQ  # j a lambda^p column
        on_q = j >= _XLQ
        for i in _TRANSLATIONS:
            value = ((De[2, i] * w3 + De[3, i] * w4) + De[4, i] * w5) + De[5, i] * w6
            if on_p:
                value += s3 * D2e[2, i, j] + s5 * D2e[4, i, j]
            elif on_q:
                value += s4 * D2e[3, i, j] + s6 * D2e[5, i, j]
            D2e[0, i, j] = value
        for i in range(_XLP, _XLP + 4):
            value = De[2, i] * w3 + De[4, i] * w5
            if not on_q:
                value += s3 * D2e[2, i, j] + s5 * D2e[4, i, j]
            D2e[0, i, j] = value + (De[1, i] * w2 + s2 * D2e[1, i, j])
        for i in range(_XLQ, _XLQ + 4):
            value = De[3, i] * w4 + De[5, i] * w6
            if not on_p:
                value += s4 * D2e[3, i, j] + s6 * D2e[5, i, j]
            D2e[0, i, j] = value + (De[1, i] * w2 + s2 * D2e[1, i, j])
    for k in range(3):
        uk = (ux, uy, uz)[k]
        for m in range(3):
            value = ((1.0 if k == m else 0.0) - uk * (ux, uy, uz)[m]) / length
            D2e[0, _XQ + k, _XQ + m] += value
            D2e[0, _XP + k, _XP + m] += value
            D2e[0, _XQ + k, _XP + m] -= value
            D2e[0, _XP + k, _XQ + m] -= value


@kernel
def inertia_kernel(x, v, ref, order, p, Dp, acc):
    """p (24,), Dp (24, 14) if order >= 1, acc = (D2p v) v (24,) if order >= 2 of one element:
    x, v (14,), ref its packed reference row. Overwrites every entry it fills; no allocation."""
    l0 = ref[0]
    for k in range(3):
        p[k] = x[_XP + k]
        p[6 + k] = x[_XQ + k]
    if order >= 1:
        for r in range(24):
            for i in range(14):
                Dp[r, i] = 0.0
        for k in range(3):
            Dp[k, _XP + k] = 1.0
            Dp[6 + k, _XQ + k] = 1.0
    if order >= 2:
        for k in range(3):
            acc[k] = 0.0
            acc[6 + k] = 0.0
    # the vectors [ax_p, ay_p, az_p, ax_q, ay_q, az_q] (see _INERTIA_AXES)
    base = _REF_INERTIA
    m0, m1, m2, m3 = x[_XLP], x[_XLP + 1], x[_XLP + 2], x[_XLP + 3]
    _inertia_vector(v, ref, order, p, Dp, acc, 3, _XLP, l0, base, m0, m1, m2, m3)
    _inertia_vector(v, ref, order, p, Dp, acc, 12, _XLP, 1.0, base + 48, m0, m1, m2, m3)
    _inertia_vector(v, ref, order, p, Dp, acc, 15, _XLP, 1.0, base + 96, m0, m1, m2, m3)
    m0, m1, m2, m3 = x[_XLQ], x[_XLQ + 1], x[_XLQ + 2], x[_XLQ + 3]
    _inertia_vector(v, ref, order, p, Dp, acc, 9, _XLQ, l0, base + 144, m0, m1, m2, m3)
    _inertia_vector(v, ref, order, p, Dp, acc, 18, _XLQ, 1.0, base + 192, m0, m1, m2, m3)
    _inertia_vector(v, ref, order, p, Dp, acc, 21, _XLQ, 1.0, base + 240, m0, m1, m2, m3)


@kernel(inline="always")
def _inertia_vector(v, ref, order, p, Dp, acc, row, col, scale, base, m0, m1, m2, m3):
    """The rows row ... row + 2 of p, Dp, acc of the inertia point scale C lambda lambda, C the
    tensor at ref[base:base + 48], lambda = [m0, m1, m2, m3] = x[col:col + 4]: scale 2 C lambda,
    scale (2 C v) v."""
    for k in range(3):
        start = base + 16 * k
        h0 = _row(ref, start, m0, m1, m2, m3)
        h1 = _row(ref, start + 4, m0, m1, m2, m3)
        h2 = _row(ref, start + 8, m0, m1, m2, m3)
        h3 = _row(ref, start + 12, m0, m1, m2, m3)
        p[row + k] = scale * (h0 * m0 + h1 * m1 + h2 * m2 + h3 * m3)
        if order >= 1:
            Dp[row + k, col] = scale * (2.0 * h0)
            Dp[row + k, col + 1] = scale * (2.0 * h1)
            Dp[row + k, col + 2] = scale * (2.0 * h2)
            Dp[row + k, col + 3] = scale * (2.0 * h3)
        if order >= 2:
            acc[row + k] = scale * (2.0 * _quadratic(ref, start, v[col], v[col + 1], v[col + 2],
                                                     v[col + 3]))


deformations_entry = entries.deformations_entry(deformations_kernel)
inertia_entry = entries.inertia_entry(inertia_kernel)
