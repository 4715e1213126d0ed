"""The bending stiffness of a shear-deformable (Timoshenko) beam on SPACAR's bending deformations.

Shared by PLBEAM (one bending plane) and BEAM (two). The deformations do not change with shear:
a bending pair [e_p, e_q] stays l0 times the end rotations of the section relative to the chord,
to first order (PLBEAM: e2 = l0 theta^p, e3 = -l0 theta^q). Only the constitutive matrix on the
pair changes, as SPACAR does with the shear terms of its ESTIFF.

Derivation. A beam element without distributed load carries a constant shear force V and a
moment linear between the end moments M^p, M^q (the work conjugates of theta^p, theta^q);
equilibrium gives V = (M^p + M^q) / l0. Its complementary energy,

    integral M^2 / (2 EI) dx + integral V^2 / (2 G As) dx,

gives the flexibility on [M^p, M^q]: l0 / (6 EI) [[2, -1], [-1, 2]] from bending plus
1 / (G As l0) [[1, 1], [1, 1]] from shear, that is l0 / (6 EI) ([[2, -1], [-1, 2]]
+ Phi / 2 [[1, 1], [1, 1]]) with

    Phi = 12 EI / (G As l0^2)                      (dimensionless)

Its inverse, whose determinant is 3 (1 + Phi) times (l0 / (6 EI))^2, is the stiffness on the
end rotations EI / (l0 (1 + Phi)) [[4 + Phi, 2 - Phi], [2 - Phi, 4 + Phi]]; on the pair
[e_p, e_q] = l0 [theta^p, -theta^q]:

    EI / (l0^3 (1 + Phi)) [[4 + Phi, Phi - 2], [Phi - 2, 4 + Phi]]
      = EI / l0^3 ([[4, -2], [-2, 4]] - 3 Phi / (1 + Phi) [[1, -1], [-1, 1]])

Uniform bending (e_p = e_q, no shear force) keeps its stiffness 2 EI / l0^3; the antisymmetric
pair (e_p = -e_q, the S-shape that a shear force bends) falls from 6 EI / l0^3 to
6 EI / (l0^3 (1 + Phi)). G As is the shear stiffness (N): the shear modulus times the shear
area, kappa A with the shear-correction factor kappa. SPACAR's ESTIFF gives the shear terms as
EI / (G As) (m^2), so that Phi = 12 ESTIFF_shear / l0^2. Without a shear stiffness (G As
infinite, the default) Phi = 0 and the matrix is the Euler-Bernoulli one to the bit: every
operation that Phi enters is then an exact multiplication by 1 or an addition of 0.

Damping follows the same Phi: EdI / (l0^3 (1 + Phi)) [[4 + Phi, Phi - 2], ...], the damping of
a material whose shear damping stands to its shear stiffness as its bending damping to its
bending stiffness, so that stiffness-proportional damping (EdI = beta EI) stays beta times the
stiffness.
"""

import numpy as np

_EULER_BERNOULLI = np.array([[4.0, -2.0], [-2.0, 4.0]])
_SHEAR = np.ones((2, 2))


def shear_ratio(flexural, shear, l0):
    """Phi = 12 EI / (G As l0^2) (n,), dimensionless: EI (N m^2), G As (N; infinite: 0), l0 (m)."""
    return 12.0 * flexural / (shear * l0**2)


def bending_block(coefficient, l0, phi):
    """The (n, 2, 2) matrix coefficient / (l0^3 (1 + Phi)) [[4 + Phi, Phi - 2], [Phi - 2,
    4 + Phi]] on a bending pair: coefficient EI (N m^2) gives the stiffness in N/m, EdI
    (N m^2 s) the damping in N s/m; l0 (m), phi (n,) from `shear_ratio`."""
    scale = coefficient / (l0**3 * (1.0 + phi))
    return scale[:, None, None] * (_EULER_BERNOULLI + phi[:, None, None] * _SHEAR)
