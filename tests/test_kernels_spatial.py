"""The compiled one-element kernels of the spatial BEAM and of the rigid-body node inertia
against the numpy functions of the same modules (the reference implementation): equal to
round-off, every entry of the arrays they fill overwritten, nothing touched beyond the order.

The compiled BEAM kernels' tests are in the slow tier: called from Python they compile the
kernels once more (about 11 s of CPU on an empty cache), and the default tier checks the same
kernels through the engine (tests/test_engine.py: accelerations and tangent of the spatial
stages against the plain formulas).
"""

from types import SimpleNamespace

import numpy as np
import pytest
from numba import njit
from numpy.testing import assert_allclose

from flexure.core.elements import beam, rotary_inertia
from flexure.core.numerics.rotation_kernels import (
    rotated_contraction,
    rotated_half_jacobian,
    rotated_vector,
)
from flexure.core.numerics.rotations import from_rotation_vector, rotation_matrix, vector_tensor

COUNT = 12


def close(actual, desired):
    """Equal to round-off: rtol 1e-12, atol 1e-12 times the array's scale; and all filled."""
    assert np.all(np.isfinite(actual))
    scale = max(np.abs(desired).max(), 1e-300)
    assert_allclose(actual, desired, rtol=1e-12, atol=1e-12 * scale)


@pytest.fixture(scope="module", params=["default_axis", "given_axis"])
def beams(request):
    rng = np.random.default_rng(20240611)
    x0, x = beam.random_coordinates(rng, COUNT)
    y_axis = None if request.param == "default_axis" else rng.normal(size=(COUNT, 3))
    # Ip_A of the order of the elements' length squared: e1's torsion term as large as the rest
    ref = beam.reference(x0, y_axis, properties={"Ip_A": rng.uniform(0.01, 0.1, COUNT)})
    v = rng.normal(size=x.shape)
    return x, v, ref, beam.pack_reference(ref)


@pytest.fixture(scope="module")
def nodes():
    rng = np.random.default_rng(7)
    lam = from_rotation_vector(rng.uniform(-3.0, 3.0, (COUNT, 3)))
    A = rng.normal(size=(COUNT, 3, 3))
    J = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(3)  # symmetric positive definite
    model = SimpleNamespace(node_inertias=[(np.arange(4) + 4 * k, J[k]) for k in range(COUNT)])
    ((group, _),) = rotary_inertia.node_inertia_groups(model)
    v = rng.normal(size=lam.shape)
    return lam, v, group.reference, rotary_inertia.pack_reference(group.reference)


def nan(*shape):
    return np.full(shape, np.nan)


def filled_to_order(order, actual, desired):
    """Each `actual[i]` close to `desired[i]` for i <= order, and untouched (NaN) past it."""
    for i, array in enumerate(actual):
        if i <= order:
            close(array, desired[i])
        else:
            assert np.all(np.isnan(array))


def python(kernel):
    """The kernel as plain Python, where indexing is bounds-checked (already so without JIT)."""
    return getattr(kernel, "py_func", kernel)


def test_pack_reference_layout(beams, nodes):
    for module, packed, n in ((beam, beams[3], COUNT), (rotary_inertia, nodes[3], COUNT)):
        assert packed.shape == (n, module.REFERENCE_WIDTH)
        assert packed.dtype == np.float64 and packed.flags.c_contiguous


@pytest.mark.slow
@pytest.mark.parametrize("order", [0, 1, 2])
def test_beam_deformations_kernel(beams, order):
    x, _, ref, packed = beams
    expected = beam.deformations(x, ref, order)
    for n in range(COUNT):
        e, De, D2e = nan(6), nan(6, 14), nan(6, 14, 14)
        beam.deformations_kernel(x[n], packed[n], order, e, De, D2e)
        filled_to_order(order, (e, De, D2e), [part[n] for part in expected])


def check_inertia_kernel(module, case, order, points, coordinates):
    """One element's inertia points (points,), their Jacobian (points, coordinates) and
    convective accelerations v' D2p v (points,) by `module.inertia_kernel`, against
    `module.inertia_points` for every element of `case` (x, v, ref, packed)."""
    x, v, ref, packed = case
    expected = module.inertia_points(x, ref, 2)
    acc_expected = np.einsum("npij,ni,nj->np", expected[2], v, v)
    for n in range(COUNT):
        p, Dp, acc = nan(points), nan(points, coordinates), nan(points)
        module.inertia_kernel(x[n], v[n], packed[n], order, p, Dp, acc)
        filled_to_order(order, (p, Dp, acc), (expected[0][n], expected[1][n], acc_expected[n]))


@pytest.mark.slow
@pytest.mark.parametrize("order", [0, 1, 2])
def test_beam_inertia_kernel(beams, order):
    check_inertia_kernel(beam, beams, order, 24, 14)


@pytest.mark.parametrize("order", [0, 1, 2])
def test_node_inertia_kernel(nodes, order):
    check_inertia_kernel(rotary_inertia, nodes, order, 9, 4)


def test_lower_orders_do_not_index_the_higher_arrays(beams, nodes):
    """The plain-Python kernels (bounds-checked) with empty arrays for what the order skips."""
    x, v, ref, packed = beams
    e = nan(6)
    python(beam.deformations_kernel)(x[0], packed[0], 0, e, nan(0, 0), nan(0, 0, 0))
    close(e, beam.deformations(x, ref, 0)[0][0])
    De = nan(6, 14)
    python(beam.deformations_kernel)(x[0], packed[0], 1, e, De, nan(0, 0, 0))
    close(De, beam.deformations(x, ref, 1)[1][0])
    p = nan(24)
    python(beam.inertia_kernel)(x[0], v[0], packed[0], 0, p, nan(0, 0), nan(0))
    Dp = nan(24, 14)
    python(beam.inertia_kernel)(x[0], v[0], packed[0], 1, p, Dp, nan(0))
    close(Dp, beam.inertia_points(x, ref, 1)[1][0])
    lam, v, ref, packed = nodes
    p, Dp = nan(9), nan(9, 4)
    python(rotary_inertia.inertia_kernel)(lam[0], v[0], packed[0], 0, p, nan(0, 0), nan(0))
    python(rotary_inertia.inertia_kernel)(lam[0], v[0], packed[0], 1, p, Dp, nan(0))
    close(Dp, rotary_inertia.inertia_points(lam, ref, 1)[1][0])


@njit
def _all_beams(x, v, ref, order, e, De, D2e, p, Dp, acc):
    for n in range(x.shape[0]):
        beam.deformations_kernel(x[n], ref[n], order, e[n], De[n], D2e[n])
        beam.inertia_kernel(x[n], v[n], ref[n], order, p[n], Dp[n], acc[n])


@pytest.mark.slow
def test_kernels_called_from_compiled_code(beams):
    """As the engine calls them: from a compiled loop over the rows of stacked buffers."""
    x, v, ref, packed = beams
    e, De, D2e = nan(COUNT, 6), nan(COUNT, 6, 14), nan(COUNT, 6, 14, 14)
    p, Dp, acc = nan(COUNT, 24), nan(COUNT, 24, 14), nan(COUNT, 24)
    _all_beams(x, v, packed, 2, e, De, D2e, p, Dp, acc)
    for actual, desired in zip((e, De, D2e), beam.deformations(x, ref, 2), strict=True):
        close(actual, desired)
    expected = beam.inertia_points(x, ref, 2)
    close(p, expected[0])
    close(Dp, expected[1])
    close(acc, np.einsum("npij,ni,nj->np", expected[2], v, v))


def test_closed_forms_of_the_rotation_against_its_tensors():
    """rotation_kernels' u = R(lambda) a, h = C lambda and K = w . C on a body vector a against
    the contractions of `rotations.vector_tensor` (C lambda lambda = R(lambda) a), for lambda
    off the unit sphere too (the forms are the quadratic form, not only the rotation)."""
    rng = np.random.default_rng(31)
    for _ in range(50):
        a, w = rng.normal(size=3), rng.normal(size=3)
        lam = rng.normal(size=4) * rng.uniform(0.5, 2.0)
        C = vector_tensor(a)
        u = np.array(rotated_vector(*a, *lam))
        assert_allclose(u, C @ lam @ lam, rtol=0, atol=1e-14 * np.abs(C).max() * (lam @ lam))
        assert_allclose(u, rotation_matrix(lam) @ a, rtol=0, atol=1e-14 * (lam @ lam) * 4)
        h = np.array(rotated_half_jacobian(*a, *lam)).T  # (3, 4): columns h_i
        assert_allclose(h, C @ lam, rtol=0, atol=1e-14 * np.abs(C @ lam).max())
        K = np.empty((4, 4))
        K[np.triu_indices(4)] = rotated_contraction(*a, *w)
        K[np.tril_indices(4)] = K.T[np.tril_indices(4)]
        assert_allclose(K, np.einsum("k,kij->ij", w, C), rtol=0, atol=1e-14 * np.abs(w).max())


@pytest.mark.slow
def test_beam_hessian_exactly_symmetric(beams):
    """D2e_k is formed on one triangle and mirrored: symmetric to the bit."""
    x, _, _, packed = beams
    for n in range(COUNT):
        e, De, D2e = nan(6), nan(6, 14), nan(6, 14, 14)
        beam.deformations_kernel(x[n], packed[n], 2, e, De, D2e)
        assert np.array_equal(D2e, np.swapaxes(D2e, 1, 2))
