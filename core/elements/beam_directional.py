"""BEAM's directional second derivative: h_b = v^T D2e_b v of one element without D2e.

The equations of motion need the deformations' second derivatives only contracted twice with
the coordinate velocities v = xdot (the constraint rows' h = xdot^T D2e xdot, 1/s^2 times the
deformation's unit). Along the line x + s v, h_b is d^2 e_b(x + s v) / ds^2 at s = 0, and this
kernel forms it as a second-order forward jet of `beam_kernels.deformations_kernel`'s formulas
(value, first and second derivative in s of every intermediate), about three times the cost
of e alone, where D2e (6 x 14 x 14) and its contraction cost some ten times e.

The jet of each intermediate, with l = r^q - r^p (m) and the Euler parameters lambda moving at
mu = dlambda/ds:

    l(s)     = l + s l1                         l1 = v_r^q - v_r^p, no second derivative
    n(s)     = R(lambda(s)) a = C lambda lambda  (a node vector, quadratic in lambda)
      n1     = 2 C lambda mu                     (the polar form B(lambda, mu) twice)
      n2     = 2 C mu mu = 2 R(mu) a
    e3 ... e6 = +- n . l:        e'' = +- (n2 . l + 2 n1 . l1)
    e2 = l0 / 2 (a . d - c . b): e'' = l0 / 2 (a2 . d + 2 a1 . d1 + a . d2 - (c2 . b + ...))
    |l|'' = (|l1|^2 - (u . l1)^2) / |l|,  u = l / |l|
    e1 = |l| - l0 + c Q(e3 ... e6) + c_t e2^2:
      e1'' = |l|'' + c (grad Q . e'' + e'^T (d2Q) e') + 2 c_t (e2'^2 + e2 e2'')

with Q = 2 e3^2 + e3 e4 + 2 e4^2 + 2 e5^2 + e5 e6 + 2 e6^2. Exact in exact arithmetic (no
truncation: every intermediate is a polynomial in s but |l|); tests/test_beam_directional.py
holds it against v^T D2e v of the kernel's and of `beam.deformations` at 1e-12 of the
products' magnitude.

The same jets give the section axes' (D2p v) v of `beam_kernels.inertia_kernel` (n2 of n_y'
and n_z' at both nodes), so `points_kernel` forms h and the inertia points' Dp and (D2p v) v
in one call, for the engine to keep through an evaluation's element passes (slot
beam_points); `kept_points_kernel` does the same from the node vectors and the section axes'
Dp blocks that `beam_kernels.kept_deformations_kernel` kept with e and De at the solution.
Each float as the separate kernels compute it: the same bits (tests/test_beam_kept_points.py).
"""

import numpy as np

from ..numerics.jit import kernel
from ..numerics.rotation_kernels import rotated_half_jacobian, rotated_vector
from . import entries
from .beam_kernels import (
    AX_P,
    AX_Q,
    AY_P,
    AY_Q,
    AZ_P,
    AZ_Q,
    VECTORS_AT,
    XLP,
    XLQ,
    XP,
    XQ,
    deformations_kernel,
    kept_deformations_kernel,
)


@kernel(inline="always")
def _polar(ref, start, m0, m1, m2, m3, n0, n1, n2, n3):
    """C lambda mu (three components) of the body vector a = ref[start:start + 3]: the
    symmetric bilinear form whose diagonal is R(lambda) a (`rotation_kernels.rotated_vector`),
    (lambda0 mu0 - v . w) a + (v . a) w + (w . a) v + lambda0 (w x a) + mu0 (v x a) with
    v, w the vector parts of lambda, mu."""
    a0, a1, a2 = ref[start], ref[start + 1], ref[start + 2]
    d = m0 * n0 - (m1 * n1 + m2 * n2 + m3 * n3)
    sv = m1 * a0 + m2 * a1 + m3 * a2
    sw = n1 * a0 + n2 * a1 + n3 * a2
    return (d * a0 + sv * n1 + sw * m1 + m0 * (n2 * a2 - n3 * a1) + n0 * (m2 * a2 - m3 * a1),
            d * a1 + sv * n2 + sw * m2 + m0 * (n3 * a0 - n1 * a2) + n0 * (m3 * a0 - m1 * a2),
            d * a2 + sv * n3 + sw * m3 + m0 * (n1 * a1 - n2 * a0) + n0 * (m1 * a1 - m2 * a0))


@kernel(inline="always")
def _jet(ref, start, u0, u1, u2, m0, m1, m2, m3, n0, n1, n2, n3):
    """The node vector u = R(lambda) a (given) and its first and second derivatives along
    mu: nine floats (n, n1 = 2 C lambda mu, n2 = 2 R(mu) a)."""
    a0, a1, a2 = ref[start], ref[start + 1], ref[start + 2]
    p0, p1, p2 = _polar(ref, start, m0, m1, m2, m3, n0, n1, n2, n3)
    q0, q1, q2 = rotated_vector(a0, a1, a2, n0, n1, n2, n3)
    return u0, u1, u2, 2.0 * p0, 2.0 * p1, 2.0 * p2, 2.0 * q0, 2.0 * q1, 2.0 * q2


@kernel
def directional_kernel(x, v, ref, h):
    """h (6,) = v^T D2e_b v (b = 1 ... 6, the units of e_b per s^2 for v in m/s and 1/s) of one
    element: x, v (14,), ref its packed reference row (`beam_kernels.pack_reference`).
    Overwrites h; no allocation."""
    _directional(x, v, ref, h)


@kernel(inline="always")
def _directional(x, v, ref, h):
    """`directional_kernel`'s h, returning the second derivatives n2 = 2 R(mu) a of the node
    vectors n_z'^p, n_z'^q, n_y'^p, n_y'^q (three floats each, in that order): the section
    axes' (D2p v) v of `beam_kernels.inertia_kernel`."""
    m0, m1, m2, m3 = x[XLP], x[XLP + 1], x[XLP + 2], x[XLP + 3]  # lambda^p
    k0, k1, k2, k3 = x[XLQ], x[XLQ + 1], x[XLQ + 2], x[XLQ + 3]  # lambda^q
    a0, a1, a2 = rotated_vector(ref[AZ_P], ref[AZ_P + 1], ref[AZ_P + 2], m0, m1, m2, m3)
    b0, b1, b2 = rotated_vector(ref[AZ_Q], ref[AZ_Q + 1], ref[AZ_Q + 2], k0, k1, k2, k3)
    c0, c1, c2 = rotated_vector(ref[AY_P], ref[AY_P + 1], ref[AY_P + 2], m0, m1, m2, m3)
    d0, d1, d2 = rotated_vector(ref[AY_Q], ref[AY_Q + 1], ref[AY_Q + 2], k0, k1, k2, k3)
    return _directional_from(x, v, ref, h, a0, a1, a2, b0, b1, b2, c0, c1, c2, d0, d1, d2)


@kernel(inline="always")
def _directional_from(x, v, ref, h, a0, a1, a2, b0, b1, b2, c0, c1, c2, d0, d1, d2):
    """`_directional` from the node vectors n_z'^p (a), n_z'^q (b), n_y'^p (c), n_y'^q (d)
    (`beam_kernels.deformations_kernel`'s, as it rotates them)."""
    l0, c, c_t = ref[0], ref[1], ref[2]
    half = 0.5 * l0
    lx, ly, lz = x[XQ] - x[XP], x[XQ + 1] - x[XP + 1], x[XQ + 2] - x[XP + 2]
    wx, wy, wz = v[XQ] - v[XP], v[XQ + 1] - v[XP + 1], v[XQ + 2] - v[XP + 2]  # l1
    m0, m1, m2, m3 = x[XLP], x[XLP + 1], x[XLP + 2], x[XLP + 3]  # lambda^p
    k0, k1, k2, k3 = x[XLQ], x[XLQ + 1], x[XLQ + 2], x[XLQ + 3]  # lambda^q
    n0, n1, n2, n3 = v[XLP], v[XLP + 1], v[XLP + 2], v[XLP + 3]  # mu^p
    j0, j1, j2, j3 = v[XLQ], v[XLQ + 1], v[XLQ + 2], v[XLQ + 3]  # mu^q
    # the node vectors n_z'^p (a), n_z'^q (b), n_y'^p (c), n_y'^q (d) with their jets
    a0, a1, a2, ap0, ap1, ap2, aq0, aq1, aq2 = _jet(ref, AZ_P, a0, a1, a2, m0, m1, m2, m3,
                                                    n0, n1, n2, n3)
    b0, b1, b2, bp0, bp1, bp2, bq0, bq1, bq2 = _jet(ref, AZ_Q, b0, b1, b2, k0, k1, k2, k3,
                                                    j0, j1, j2, j3)
    c0, c1, c2, cp0, cp1, cp2, cq0, cq1, cq2 = _jet(ref, AY_P, c0, c1, c2, m0, m1, m2, m3,
                                                    n0, n1, n2, n3)
    d0, d1, d2, dp0, dp1, dp2, dq0, dq1, dq2 = _jet(ref, AY_Q, d0, d1, d2, k0, k1, k2, k3,
                                                    j0, j1, j2, j3)
    # bending: e = sign n . l, e' = sign (n1 . l + n . l1), e'' = sign (n2 . l + 2 n1 . l1)
    e3 = -(a0 * lx + a1 * ly + a2 * lz)
    e4 = b0 * lx + b1 * ly + b2 * lz
    e5 = c0 * lx + c1 * ly + c2 * lz
    e6 = -(d0 * lx + d1 * ly + d2 * lz)
    f3 = -((ap0 * lx + ap1 * ly + ap2 * lz) + (a0 * wx + a1 * wy + a2 * wz))
    f4 = (bp0 * lx + bp1 * ly + bp2 * lz) + (b0 * wx + b1 * wy + b2 * wz)
    f5 = (cp0 * lx + cp1 * ly + cp2 * lz) + (c0 * wx + c1 * wy + c2 * wz)
    f6 = -((dp0 * lx + dp1 * ly + dp2 * lz) + (d0 * wx + d1 * wy + d2 * wz))
    g3 = -((aq0 * lx + aq1 * ly + aq2 * lz) + 2.0 * (ap0 * wx + ap1 * wy + ap2 * wz))
    g4 = (bq0 * lx + bq1 * ly + bq2 * lz) + 2.0 * (bp0 * wx + bp1 * wy + bp2 * wz)
    g5 = (cq0 * lx + cq1 * ly + cq2 * lz) + 2.0 * (cp0 * wx + cp1 * wy + cp2 * wz)
    g6 = -((dq0 * lx + dq1 * ly + dq2 * lz) + 2.0 * (dp0 * wx + dp1 * wy + dp2 * wz))
    # torsion: e2 = l0 / 2 (a . d - c . b)
    e2 = half * ((a0 * d0 + a1 * d1 + a2 * d2) - (c0 * b0 + c1 * b1 + c2 * b2))
    f2 = half * (((ap0 * d0 + ap1 * d1 + ap2 * d2) + (a0 * dp0 + a1 * dp1 + a2 * dp2))
                 - ((cp0 * b0 + cp1 * b1 + cp2 * b2) + (c0 * bp0 + c1 * bp1 + c2 * bp2)))
    g2 = half * (((aq0 * d0 + aq1 * d1 + aq2 * d2) + (a0 * dq0 + a1 * dq1 + a2 * dq2)
                  + 2.0 * (ap0 * dp0 + ap1 * dp1 + ap2 * dp2))
                 - ((cq0 * b0 + cq1 * b1 + cq2 * b2) + (c0 * bq0 + c1 * bq1 + c2 * bq2)
                    + 2.0 * (cp0 * bp0 + cp1 * bp1 + cp2 * bp2)))
    # elongation: |l|'' + c Q'' + c_t (e2^2)''
    length = np.sqrt(lx * lx + ly * ly + lz * lz)
    along = (lx * wx + ly * wy + lz * wz) / length
    stretch = ((wx * wx + wy * wy + wz * wz) - along * along) / length
    quadratic = (((4.0 * e3 + e4) * g3 + (4.0 * e4 + e3) * g4)
                 + ((4.0 * e5 + e6) * g5 + (4.0 * e6 + e5) * g6)
                 + 4.0 * ((f3 * f3 + f4 * f4) + (f5 * f5 + f6 * f6))
                 + 2.0 * (f3 * f4 + f5 * f6))
    h[0] = stretch + c * quadratic + c_t * (2.0 * (f2 * f2 + e2 * g2))
    h[1] = g2
    h[2] = g3
    h[3] = g4
    h[4] = g5
    h[5] = g6
    return aq0, aq1, aq2, bq0, bq1, bq2, cq0, cq1, cq2, dq0, dq1, dq2


# The inertia points that `points_kernel` keeps of one element, POINTS_WIDTH floats: Dp's
# blocks of the six rotated vectors (rows 3 l0 n_x'^p, 9 l0 n_x'^q, 12 n_y'^p, 15 n_z'^p,
# 18 n_y'^q, 21 n_z'^q of Dp, each three rows over its node's four Euler parameters, four
# columns of three components), then acc = (D2p v) v (24,), then the node vectors n_z'^p,
# n_z'^q, n_y'^p, n_y'^q (`beam_kernels.VECTORS_AT`); Dp's other entries are constants: 1 on
# the translations' rows 0 ... 2 and 6 ... 8 at their coordinates, else 0. Blocks 2 ... 5
# and the node vectors are the deformations' rotations: `beam_kernels.
# kept_deformations_kernel` keeps them with e and De, and `kept_points_kernel` adds the rest.
ACC_AT = 72
POINTS_WIDTH = VECTORS_AT + 12


@kernel
def points_kernel(x, v, ref, h, points):
    """`directional_kernel`'s h (6,) and `beam_kernels.inertia_kernel`'s Dp and acc at
    order 2 in one call, sharing the section axes' rotations (n and R(mu) a of n_y', n_z'
    at both nodes): points (POINTS_WIDTH,) the non-constant blocks of Dp and acc in the
    layout above (`beam_mass.kept_point_products` reads them; the node vectors are left
    as they were). Each float is computed as those two kernels compute it, so the same
    bits. x, v (14,), ref the packed reference row; no allocation."""
    _points_acc(points, ref, v, _directional(x, v, ref, h))
    _block(x, ref, points, 0, XLP, ref[0], AX_P)
    _block(x, ref, points, 1, XLQ, ref[0], AX_Q)
    _block(x, ref, points, 2, XLP, 1.0, AY_P)
    _block(x, ref, points, 3, XLP, 1.0, AZ_P)
    _block(x, ref, points, 4, XLQ, 1.0, AY_Q)
    _block(x, ref, points, 5, XLQ, 1.0, AZ_Q)


@kernel
def kept_points_kernel(x, v, ref, h, points):
    """`points_kernel` for points that `beam_kernels.kept_deformations_kernel` filled at x
    (the node vectors, Dp's blocks 2 ... 5): h from those vectors, acc and the tangents'
    blocks 0 and 1 into points. The same bits as `points_kernel`."""
    o = VECTORS_AT
    _points_acc(points, ref, v, _directional_from(
        x, v, ref, h, points[o], points[o + 1], points[o + 2], points[o + 3], points[o + 4],
        points[o + 5], points[o + 6], points[o + 7], points[o + 8], points[o + 9],
        points[o + 10], points[o + 11]))
    _block(x, ref, points, 0, XLP, ref[0], AX_P)
    _block(x, ref, points, 1, XLQ, ref[0], AX_Q)


@kernel(inline="always")
def _points_acc(points, ref, v, n2):
    """acc (24,) into points: zero on the translations, the section axes' 2 R(mu) a from the
    jets' n2 (n2: `_directional`'s return), the tangents' l0 (2 R(mu) a)."""
    aq0, aq1, aq2, bq0, bq1, bq2, cq0, cq1, cq2, dq0, dq1, dq2 = n2
    l0 = ref[0]
    for k in range(3):
        points[ACC_AT + k] = 0.0
        points[ACC_AT + 6 + k] = 0.0
    # the section axes' acc, 1.0 (2 R(mu) a) in inertia_kernel: the jet's n2 (scale 1 exact)
    points[ACC_AT + 12], points[ACC_AT + 13], points[ACC_AT + 14] = cq0, cq1, cq2
    points[ACC_AT + 15], points[ACC_AT + 16], points[ACC_AT + 17] = aq0, aq1, aq2
    points[ACC_AT + 18], points[ACC_AT + 19], points[ACC_AT + 20] = dq0, dq1, dq2
    points[ACC_AT + 21], points[ACC_AT + 22], points[ACC_AT + 23] = bq0, bq1, bq2
    # the tangents l0 n_x' at both nodes: acc l0 (2 R(mu) a), as inertia_kernel's
    _tangent_acc(v, ref, points, 3, XLP, l0, AX_P)
    _tangent_acc(v, ref, points, 9, XLQ, l0, AX_Q)


@kernel(inline="always")
def _tangent_acc(v, ref, points, row, col, scale, start):
    """acc's rows row ... row + 2 of the inertia point scale R(lambda) a (a = ref[start:
    start + 3], lambda at x[col:col + 4]): scale (2 R(mu) a), mu = v[col:col + 4]."""
    w = rotated_vector(ref[start], ref[start + 1], ref[start + 2], v[col], v[col + 1],
                       v[col + 2], v[col + 3])
    for k in range(3):
        points[ACC_AT + row + k] = scale * (2.0 * w[k])


@kernel(inline="always")
def _block(x, ref, points, j, col, scale, start):
    """Dp's block j (the layout above) of the inertia point scale R(lambda) a: scale 2 h, h = C
    lambda (lambda = x[col:col + 4], a = ref[start:start + 3]), its four columns."""
    half = rotated_half_jacobian(ref[start], ref[start + 1], ref[start + 2], x[col],
                                 x[col + 1], x[col + 2], x[col + 3])
    for i in range(4):
        for k in range(3):
            points[12 * j + 3 * i + k] = scale * (2.0 * half[i][k])


deformations_entry = entries.deformations_entry(deformations_kernel, directional_kernel,
                                                kept_deformations_kernel, POINTS_WIDTH)
