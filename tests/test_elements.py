"""Every element's analytic derivatives against central finite differences.

Parametrised over the element registry, so a new element is checked by registering it.
Central differences with step h have truncation error O(h^2); with h = 1e-6 on coordinates of
order 0.1 m the combined truncation and round-off error is below 1e-7 relative.
"""

import numpy as np
import pytest

from flexure.core.elements import ELEMENT_TYPES

H = 1e-6


def random_configuration(kind, rng, count=3):
    """Reference coordinates x0 and a deformed configuration x of `count` elements."""
    sample = getattr(kind, "random_coordinates", None)
    if sample is not None:
        return sample(rng, count)
    columns = []
    for node_kind in kind.node_kinds:
        if node_kind == "translational":
            columns.append(rng.uniform(-0.1, 0.1, (count, kind.dimension)))
        else:
            columns.append(rng.uniform(-np.pi, np.pi, (count, 1)))
    x0 = np.concatenate(columns, axis=1)
    # keep the two ends apart so that the element has a length
    translational = [i for i, k in enumerate(kind.node_kinds) if k == "translational"]
    q_columns = sum(kind.dimension if k == "translational" else 1
                    for k in kind.node_kinds[: translational[-1]])
    x0[:, q_columns:q_columns + kind.dimension] += 0.3
    x = x0 + rng.normal(scale=0.02, size=x0.shape)
    return x0, x


def reference_of(kind, x0, rng):
    """The element's reference data for the undeformed x0: with, for the section keys its
    deformations depend on (`reference_properties`, e.g. a BEAM's Ip_A in m^2), random values
    of 0.01 to 0.1 in SI units, so that the terms they weigh (e1's torsion term: Ip_A of the
    order of the test elements' 0.3 m length squared) are as large as the others."""
    keys = getattr(kind, "reference_properties", ())
    if not keys:
        return kind.reference(x0)
    count = x0.shape[0]
    return kind.reference(x0, properties={key: rng.uniform(0.01, 0.1, count) for key in keys})


def numerical_jacobian(function, x):
    """d function / d x by central differences, per element: (n, k, m)."""
    columns = []
    for j in range(x.shape[1]):
        step = np.zeros_like(x)
        step[:, j] = H
        columns.append((function(x + step) - function(x - step)) / (2 * H))
    return np.stack(columns, axis=-1)


def deformed(element, seed):
    """(x, ref): a random deformed configuration of 3 elements (`random_configuration` with
    the generator of `seed`) and the reference of their undeformed one."""
    rng = np.random.default_rng(seed)
    x0, x = random_configuration(element, rng)
    return x, reference_of(element, x0, rng)


def differences_of(function, x, ref, order):
    """Central differences, per element, of output `order` of function(x, ref, order=order)
    (an element's deformations or inertia points, order 0, or their first derivatives, 1)."""
    return numerical_jacobian(lambda y: function(y, ref, order=order)[order], x)


@pytest.fixture(params=sorted(ELEMENT_TYPES), ids=str)
def element(request):
    return ELEMENT_TYPES[request.param]


def test_deformations_are_zero_in_the_reference_configuration(element):
    rng = np.random.default_rng(1)
    x0, _ = random_configuration(element, rng)
    (e,) = element.deformations(x0, reference_of(element, x0, rng), order=0)
    assert np.max(np.abs(e)) < 1e-14


def test_first_derivatives_of_deformations(element):
    x, ref = deformed(element, seed=2)
    _, De = element.deformations(x, ref, order=1)
    numeric = differences_of(element.deformations, x, ref, 0)
    np.testing.assert_allclose(De, numeric, rtol=1e-6, atol=1e-8)


def test_second_derivatives_of_deformations(element):
    x, ref = deformed(element, seed=3)
    _, _, D2e = element.deformations(x, ref, order=2)
    numeric = differences_of(element.deformations, x, ref, 1)
    np.testing.assert_allclose(D2e, numeric, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(D2e, np.swapaxes(D2e, -1, -2), atol=1e-14)


def test_derivatives_of_inertia_points(element):
    x, ref = deformed(element, seed=4)
    _, Dp, D2p = element.inertia_points(x, ref, order=2)
    numeric = differences_of(element.inertia_points, x, ref, 0)
    np.testing.assert_allclose(Dp, numeric, rtol=1e-6, atol=1e-8)
    numeric2 = differences_of(element.inertia_points, x, ref, 1)
    np.testing.assert_allclose(D2p, numeric2, rtol=1e-6, atol=1e-7)


def test_deformations_are_invariant_under_rigid_translation(element):
    """A rigid translation leaves every deformation unchanged."""
    x, ref = deformed(element, seed=5)
    translational = sum(1 for k in element.node_kinds if k == "translational")
    rotation_width = (element.coordinates_per_element - translational * element.dimension) // max(
        1, len(element.node_kinds) - translational)
    shift, column = np.zeros(x.shape[1]), 0
    for node_kind in element.node_kinds:
        width = element.dimension if node_kind == "translational" else rotation_width
        if node_kind == "translational":
            shift[column:column + width] = 0.37
        column += width
    (e,) = element.deformations(x, ref, order=0)
    (moved,) = element.deformations(x + shift, ref, order=0)
    np.testing.assert_allclose(moved, e, atol=1e-14)


def test_mass_matrices_are_symmetric_positive_semidefinite(element):
    rng = np.random.default_rng(6)
    x0, _ = random_configuration(element, rng)
    ref = element.reference(x0)
    props = {name: np.full(x0.shape[0], 1.0) for name in element.properties}
    Mp = element.inertia_matrix(ref, props)
    np.testing.assert_allclose(Mp, np.swapaxes(Mp, 1, 2), atol=1e-15)
    assert np.all(np.linalg.eigvalsh(Mp) > -1e-14)


def test_plbeam_matches_its_textbook_formulas_element_by_element():
    """The column-wise PLBEAM against a plain loop over the docstring's formulas."""
    from flexure.core.elements import plbeam

    rng = np.random.default_rng(7)
    x0, x = random_configuration(plbeam, rng, count=4)
    ref = plbeam.reference(x0)
    (e,) = plbeam.deformations(x, ref, order=0)
    (p,) = plbeam.inertia_points(x, ref, order=0)
    for i in range(x.shape[0]):
        r_p, r_q = x[i, 0:2], x[i, 3:5]
        l_vec, l0 = r_q - r_p, ref["l0"][i]
        t_p = np.array([np.cos(x[i, 2] + ref["offset_p"][i]), np.sin(x[i, 2] + ref["offset_p"][i])])
        t_q = np.array([np.cos(x[i, 5] + ref["offset_q"][i]), np.sin(x[i, 5] + ref["offset_q"][i])])
        n_p, n_q = np.array([-t_p[1], t_p[0]]), np.array([-t_q[1], t_q[0]])
        e2, e3 = -(n_p @ l_vec), n_q @ l_vec
        e1 = np.linalg.norm(l_vec) - l0 + (2 * e2**2 + e2 * e3 + 2 * e3**2) / (30 * l0)
        np.testing.assert_allclose(e[i], [e1, e2, e3], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(p[i], np.concatenate([r_p, l0 * t_p, r_q, l0 * t_q]),
                                   rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("scene", ["stage_planar_3dof", "truss_1dof_x", "stage_spatial_19dof"])
def test_batched_hessian_forms_match_the_einsum_forms(scene):
    """assembly's batched quadratic forms v^T D2e_i v (the convective term) against its einsum
    over columns. (The compiled engine's mass and convective force are checked against
    assembly.Inertia in tests/test_engine.py.)"""
    from flexure.core import load_scene
    from flexure.core.mechanics import assembly

    model = load_scene(scene)
    rng = np.random.default_rng(8)
    x = model.initial_coordinates + rng.normal(scale=1e-3, size=model.nx)
    v = rng.normal(size=model.nx)
    hessians = assembly.deformation_hessians(model, x)
    forms = assembly.hessian_quadratic_forms(model, hessians, v)
    columns = assembly.hessian_quadratic_forms(model, hessians, v[:, None])[:, 0]
    np.testing.assert_allclose(forms, columns, rtol=1e-12, atol=1e-12 * np.abs(columns).max())
