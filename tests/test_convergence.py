"""Convergence under mesh refinement, the elastica, and the frequency under preload."""

import numpy as np
import pytest

from examples import convergence_study as study
from flexure.core import buckling_load_factors, load_scene, natural_frequencies


def test_refined_springs_converge_to_the_continuous_buckling_load():
    exact, rows = study.buckling_convergence((1, 2, 4, 8, 16))
    assert exact == pytest.approx(77.72, abs=5e-3)
    assert rows[0][1] == pytest.approx(78.75, rel=1e-9)  # one element: 2 x 10 EI / l0^2
    errors = [abs(r[2]) for r in rows]
    assert errors == sorted(errors, reverse=True)
    orders = study.observed_order(errors)
    # Hermite cubics: the eigenvalue error falls as h^4 once the mesh resolves the mode.
    np.testing.assert_allclose(orders[-3:], 4.0, atol=0.15)
    assert errors[-1] < 3e-6


@pytest.mark.parametrize("alpha", sorted(study.MATTIASSON_1981))
def test_shooting_reproduces_the_published_elastica(alpha):
    """Our independent elastica against Mattiasson (1981), published to 5 digits."""
    u, w = study.elastica_tip(alpha)
    u_pub, w_pub = study.MATTIASSON_1981[alpha]
    assert u == pytest.approx(u_pub, abs=6e-6)
    assert w == pytest.approx(w_pub, abs=6e-6)


def test_cantilever_converges_at_second_order_to_the_elastica():
    rows = study.elastica_convergence(10.0, (4, 8, 16, 32))
    orders = study.observed_order([r[3] for r in rows])
    np.testing.assert_allclose(orders, 2.0, atol=0.1)


@pytest.mark.parametrize("alpha", [1.0, 2.0, 5.0, 10.0])
def test_refined_cantilever_matches_the_published_elastica_within_0_1_percent(alpha):
    u, w = study.cantilever_tip(64, alpha)
    u_pub, w_pub = study.MATTIASSON_1981[alpha]
    assert u == pytest.approx(u_pub, rel=1e-3)
    assert w == pytest.approx(w_pub, rel=1e-3)


@pytest.mark.parametrize("fraction", [0.0, 0.25, 0.5, 0.9])
def test_first_frequency_under_vertical_preload(fraction):
    """f(P)^2 = f(0)^2 (1 - P / P_cr) for the 1-DOF stage, P_cr of its own model."""
    model = load_scene("stage_planar_1dof")
    critical = buckling_load_factors(model, 1)[0]  # N, for the 1 N reference load on node 3
    f0 = natural_frequencies(model).frequencies_hz[0]
    model.loads[:] = 0.0
    model.loads[model.coordinate_index("3.y")] = -fraction * critical
    f = natural_frequencies(model).frequencies_hz[0]
    assert f**2 == pytest.approx(f0**2 * (1.0 - fraction), rel=1e-9)
