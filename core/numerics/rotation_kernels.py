"""Compiled twins of the rotations about the global axes in `flexure.core.numerics.rotations`.

For one node's Euler parameters lambda (4,) and a global axis k (0, 1, 2 for x, y, z):

- `rates_row`: row k of E(lambda), omega_k = 2 E_k . lambda_dot (rad/s), and the generalised
  force of a moment u about axis k is 2 u E_k (N m);
- `rotation_vector_component`: phi_k, the rotation-vector component about axis k (rad), with
  its first and second derivatives with respect to lambda;
- `rotated_vector`, `rotated_half_jacobian`, `rotated_contraction`: a body vector a rotated,
  u = R(lambda) a, its first derivative and its constant second derivative contracted with a
  vector, in closed form (the BEAM's and the node inertias' kernels).

The formulas, and the reason for the series at small angles, are those of
`rotations.rotation_vector_derivatives` (the readable numpy reference, which the tests compare
with these to round-off). Nothing here allocates.
"""

import math

from .jit import kernel
from .rotations import SERIES_BELOW, SERIES_TERMS


@kernel
def rates_row(l0, l1, l2, l3, k):
    """Row k of E(lambda), a 4-tuple: E = [-lv, lambda0 I + [lv x]]."""
    if k == 0:
        return -l1, l0, -l3, l2
    if k == 1:
        return -l2, l3, l0, -l1
    return -l3, -l2, l1, l0


@kernel(inline="always")
def rates_coefficient(k, a, b):
    """d E[k, a] / d lambda_b (E is linear in lambda: -1, 0 or 1), the load stiffness of a
    moment about axis k."""
    if a == 0:
        return -1.0 if b == k + 1 else 0.0
    if b == 0:
        return 1.0 if a == k + 1 else 0.0
    # [lv x] of row k, column a: the permutation symbol eps_{k, b-1, a-1}
    i, j, m = k, b - 1, a - 1
    return (i - j) * (j - m) * (m - i) / 2.0


@kernel
def _ghm(c, s):
    """g, h, m of `rotations.rotation_vector_derivatives` for c >= 0."""
    if s < SERIES_BELOW * c:
        t2 = (s / c) * (s / c)
        g = h = m = 0.0
        for k in range(SERIES_TERMS, -1, -1):
            sign = -1.0 if k % 2 else 1.0
            g = g * t2 + sign / (2 * k + 1)
            h = h * t2 + sign * (2 * k + 2) / (2 * k + 3)
            m = m * t2 + sign * (2 * k + 4) * (2 * k + 2) / (2 * k + 5)
        return 2.0 * g / c, -2.0 * h / (c * c * c), 2.0 * m / (c * c * c * c * c)
    n2 = c * c + s * s
    alpha = math.atan2(s, c)
    s2 = s * s
    s4 = s2 * s2
    g = 2.0 * alpha / s
    h = 2.0 / s2 * (c / n2 - alpha / s)
    m = 6.0 * alpha / (s4 * s) - 2.0 * c / (n2 * s4) - 4.0 * c * (s2 + n2) / (n2 * n2 * s4)
    return g, h, m


@kernel
def rotation_vector_value(l0, l1, l2, l3, k):
    """phi_k(lambda) (rad) alone, from the four Euler parameters."""
    sign = -1.0 if l0 < 0.0 else 1.0
    s = math.sqrt(l1 * l1 + l2 * l2 + l3 * l3)
    g, _, _ = _ghm(sign * l0, s)
    return sign * g * (l1 if k == 0 else (l2 if k == 1 else l3))


@kernel
def rotation_vector_component(lam, k, order, D, D2):
    """phi_k(lambda) (rad); by order also D (4,) = d phi_k / d lambda and D2 (4, 4) its second
    derivative (written into the arrays given)."""
    sign = -1.0 if lam[0] < 0.0 else 1.0
    c = sign * lam[0]
    v0, v1, v2 = sign * lam[1], sign * lam[2], sign * lam[3]
    s = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    g, h, m = _ghm(c, s)
    vk = v0 if k == 0 else (v1 if k == 1 else v2)
    value = g * vk
    if order == 0:
        return value
    n2 = c * c + s * s
    v = (v0, v1, v2)
    D[0] = sign * (-2.0 / n2) * vk
    for j in range(3):
        D[j + 1] = sign * ((g if j == k else 0.0) + h * vk * v[j])
    if order == 1:
        return value
    n4 = n2 * n2
    D2[0, 0] = 4.0 * c / n4 * vk
    for j in range(3):
        cross = (-2.0 / n2 if j == k else 0.0) + 4.0 / n4 * vk * v[j]
        D2[0, j + 1] = cross
        D2[j + 1, 0] = cross
        for i in range(3):
            term = m * vk * v[j] * v[i]
            if j == k:
                term += h * v[i]
            if i == k:
                term += h * v[j]
            if i == j:
                term += h * vk
            D2[j + 1, i + 1] = term
    return value


# -- the quadratic rotation on a body vector, in closed form ---------------------------------
# R(lambda) = (lambda0^2 - v . v) I + 2 v v^T + 2 lambda0 [v x] (v = [lambda1, lambda2,
# lambda3]) maps a body vector a to u = R a = C lambda lambda, with C (3 x 4 x 4,
# `rotations.vector_tensor`) linear in a: C_00 = a, C_0i = e_i x a, C_ij = a_i e_j + a_j e_i
# - delta_ij a (i, j = 1, 2, 3). These forms give u, Du = 2 C lambda and D2(w . u) = 2 w . C
# in a few flops on a itself, where contracting C takes 48 multiply-adds and 48 floats read.

@kernel(inline="always")
def rotated_vector(a0, a1, a2, m0, m1, m2, m3):
    """u = R(lambda) a (three components) of the body vector a, lambda = [m0, m1, m2, m3]:
    (lambda0^2 - v . v) a + 2 (v . a) v + 2 lambda0 (v x a). Also (C mu) . mu for any mu
    (the quadratic form at mu: a BEAM's or a node's (D2u mu) mu = 2 R(mu) a)."""
    s = 2.0 * (m1 * a0 + m2 * a1 + m3 * a2)
    q = m0 * m0 - (m1 * m1 + m2 * m2 + m3 * m3)
    t = 2.0 * m0
    return (q * a0 + s * m1 + t * (m2 * a2 - m3 * a1),
            q * a1 + s * m2 + t * (m3 * a0 - m1 * a2),
            q * a2 + s * m3 + t * (m1 * a1 - m2 * a0))


@kernel(inline="always")
def rotated_half_jacobian(a0, a1, a2, m0, m1, m2, m3):
    """h = C lambda (3 x 4; d(R a) / d lambda = 2 h) of the body vector a as its four columns
    h_0 ... h_3, each a 3-tuple: h_0 = lambda0 a + v x a, h_i = (v . a) e_i + a_i v - v_i a
    + lambda0 (e_i x a) for i = 1, 2, 3."""
    s = m1 * a0 + m2 * a1 + m3 * a2
    pxy = a0 * m2 - m1 * a1  # the antisymmetric products a_i v_j - v_i a_j
    pxz = a0 * m3 - m1 * a2
    pyz = a1 * m3 - m2 * a2
    al = pxy - m0 * a2
    be = pxz + m0 * a1
    ga = pyz - m0 * a0
    return ((m0 * a0 - pyz, m0 * a1 + pxz, m0 * a2 - pxy), (s, al, be), (-al, s, ga),
            (-be, -ga, s))


@kernel(inline="always")
def rotated_contraction(a0, a1, a2, w0, w1, w2):
    """The ten entries K_00, K_01, K_02, K_03, K_11, K_12, K_13, K_22, K_23, K_33 of the
    symmetric K = w . C (4 x 4) of the body vector a: d2(w . R(lambda) a) / d lambda2 = 2 K,
    constant. K_00 = w . a, K_0i = (a x w)_i, K_ij = a_i w_j + a_j w_i - delta_ij (w . a)."""
    d = w0 * a0 + w1 * a1 + w2 * a2
    return (d, a1 * w2 - a2 * w1, a2 * w0 - a0 * w2, a0 * w1 - a1 * w0,
            2.0 * a0 * w0 - d, a0 * w1 + a1 * w0, a0 * w2 + a2 * w0,
            2.0 * a1 * w1 - d, a1 * w2 + a2 * w1, 2.0 * a2 * w2 - d)
