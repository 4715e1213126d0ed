"""Rotations about the global axes (flexure.core.numerics.rotations, rotation_kernels): the
rotation vector's first and second derivatives against finite differences, the angular
velocity 2 E lambda_dot against R' R^T, the virtual work of a moment's generalised force
2 E^T M against M . omega, and the compiled kernels against the numpy reference to round-off.
"""

import numpy as np
import pytest

from flexure.core.numerics import rotation_kernels as kernels
from flexure.core.numerics.rotations import (
    RATES_TENSOR,
    body_rates_matrix,
    from_rotation_vector,
    global_rates_matrix,
    normalized,
    rotation_matrix,
    rotation_vector_derivatives,
    to_rotation_vector,
)


def random_lambdas(seed):
    """Euler parameters of rotations from 0 to near pi about random axes, some with
    lambda0 < 0 or |lambda| != 1 (the rotation vector does not depend on either)."""
    rng = np.random.default_rng(seed)
    angles = [0.0, 1e-9, 1e-3, 0.19, 0.21, 1.0, 2.5, 3.1]
    found = []
    for k, angle in enumerate(angles):
        axis = normalized(rng.standard_normal(3))
        found.append(from_rotation_vector(angle * axis) * [1.0, -1.0, 1.3, 0.8][k % 4])
    return np.array(found)


def test_rotation_vector_and_its_derivatives_against_finite_differences():
    lam = random_lambdas(1)
    phi, D, D2 = rotation_vector_derivatives(lam)
    np.testing.assert_allclose(phi, to_rotation_vector(normalized(lam)), atol=1e-15)
    h = 1e-6
    for a in range(4):
        step = h * np.eye(4)[a]
        plus, minus = (rotation_vector_derivatives(lam + s, order=1) for s in (step, -step))
        np.testing.assert_allclose(D[:, :, a], (plus[0] - minus[0]) / (2 * h), atol=1e-9)
        np.testing.assert_allclose(D2[:, :, :, a], (plus[1] - minus[1]) / (2 * h), atol=1e-8)
    # homogeneous of degree 0: no component along lambda; at the unrotated orientation 2 E
    np.testing.assert_allclose(np.einsum("nka,na->nk", D, lam), 0.0, atol=1e-14)
    identity = np.array([[1.0, 0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(rotation_vector_derivatives(identity)[1],
                                  2.0 * global_rates_matrix(identity))


def test_compiled_rotation_kernels_equal_the_numpy_reference():
    lam = random_lambdas(2)
    phi, D, D2 = rotation_vector_derivatives(lam)
    E = global_rates_matrix(lam)
    for n, row in enumerate(lam):
        for k in range(3):
            d, d2 = np.zeros(4), np.zeros((4, 4))
            value = kernels.rotation_vector_component(row, k, 2, d, d2)
            assert abs(value - phi[n, k]) <= 1e-15 * max(1.0, abs(phi[n, k]))
            assert kernels.rotation_vector_value(*row, k) == value
            np.testing.assert_allclose(d, D[n, k], rtol=1e-14, atol=1e-14)
            np.testing.assert_allclose(d2, D2[n, k], rtol=1e-13, atol=1e-13)
            assert kernels.rates_row(*row, k) == tuple(E[n, k])
            for a in range(4):
                for b in range(4):
                    assert kernels.rates_coefficient(k, a, b) == RATES_TENSOR[k, a, b]


def test_global_rates_give_the_angular_velocity_and_the_moment_its_power():
    """omega = 2 E lambda_dot is the vector of R' R^T; R = E G^T; E lambda = 0; and the
    generalised force 2 E^T M of a moment M does the power M . omega on any lambda_dot."""
    rng = np.random.default_rng(3)
    for lam in normalized(rng.standard_normal((5, 4))):
        rate = rng.standard_normal(4)
        rate -= lam * (lam @ rate)  # along the unit sphere
        h = 1e-6
        dR = (rotation_matrix(lam + h * rate) - rotation_matrix(lam - h * rate)) / (2 * h)
        W = dR @ rotation_matrix(lam).T
        omega = 2.0 * global_rates_matrix(lam) @ rate
        np.testing.assert_allclose(omega, [W[2, 1], W[0, 2], W[1, 0]], atol=1e-8)
        np.testing.assert_allclose(global_rates_matrix(lam) @ body_rates_matrix(lam).T,
                                   rotation_matrix(lam), atol=1e-15)
        np.testing.assert_allclose(global_rates_matrix(lam) @ lam, 0.0, atol=1e-16)
        moment = rng.standard_normal(3)
        force = 2.0 * global_rates_matrix(lam).T @ moment
        assert force @ rate == pytest.approx(moment @ omega, rel=1e-13)
