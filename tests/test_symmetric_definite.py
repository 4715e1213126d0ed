"""The symmetric-definite eigenproblem in numpy (core/numerics/symmetric_definite.py) against
scipy.linalg.eigh (LAPACK's sygvd), on random problems and a built-in scene's K and M0."""

import numpy as np
import pytest
import scipy.linalg

from flexure.core import load_scene
from flexure.core.analysis.linearization import linearize
from flexure.core.numerics.symmetric_definite import symmetric_definite_eigh


def _random_problem(n, seed, mass_condition=1e6):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    K = A + A.T
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    M = Q @ np.diag(np.logspace(0, np.log10(mass_condition), n)) @ Q.T
    return K, 0.5 * (M + M.T)


def _check(K, M):
    w, phi = symmetric_definite_eigh(K, M)
    expected = scipy.linalg.eigh(K, M, eigvals_only=True)
    scale = np.max(np.abs(expected))
    assert np.all(np.diff(w) >= 0)
    assert np.max(np.abs(w - expected)) <= 1e-10 * scale
    n = K.shape[0]
    # M-orthonormal, and each column an eigenvector: K phi = M phi diag(w)
    assert np.max(np.abs(phi.T @ M @ phi - np.eye(n))) <= 1e-9
    residual = K @ phi - M @ phi * w
    assert np.max(np.abs(residual)) <= 1e-9 * scale * np.max(np.abs(M))


@pytest.mark.parametrize("n, seed", [(1, 0), (5, 1), (40, 2), (120, 3)])
def test_random_problems_match_lapack_sygvd(n, seed):
    _check(*_random_problem(n, seed))


@pytest.mark.parametrize("scene", ["stage_planar_3dof", "stage_spatial_19dof"])
def test_a_scenes_stiffness_and_mass_match_lapack_sygvd(scene):
    lin = linearize(load_scene(scene))
    _check(lin.K, lin.M0)


def test_a_mass_that_is_not_positive_definite_is_refused():
    K, M = _random_problem(4, 5)
    M[0, 0] = -1.0
    with pytest.raises(np.linalg.LinAlgError):
        symmetric_definite_eigh(K, M)
