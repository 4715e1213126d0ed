"""Compiled twins of the rotations about the global axes in `flexure.core.numerics.rotations`.

For one node's Euler parameters lambda (4,) and a global axis k (0, 1, 2 for x, y, z):

- `rates_row`: row k of E(lambda), omega_k = 2 E_k . lambda_dot (rad/s), and the generalised
  force of a moment u about axis k is 2 u E_k (N m);
- `rotation_vector_component`: phi_k, the rotation-vector component about axis k (rad), with
  its first and second derivatives with respect to lambda.

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
