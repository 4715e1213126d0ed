"""The course-note figures of the four planar scenes (shared/reference/figures.md).

Each figure is asserted with the tolerance that figures.md gives, and where an analytic value
exists (k_eq, the consistent-mass frequencies) against that too, more tightly.
"""

import control
import numpy as np
import pytest

from flexure.core import (
    buckling_load_factors,
    linearize,
    load_scene,
    natural_frequencies,
    state_space,
    static_equilibrium,
)

K_EQ = 945.0  # N/m, both leaf springs
RHO_A_BOTH = 0.1413  # kg/m, both leaf springs
BAR_MASS = 0.206  # kg
L0 = 0.1  # m
EI = 0.039375  # N m^2 per spring
EA = 1.89e6  # N per spring


@pytest.fixture(params=["truss_1dof_x", "truss_1dof_e"])
def truss(request):
    return load_scene(request.param)


def test_truss_dof_count(truss):
    assert truss.dof_count() == {"nx": 4, "nxo": 3, "neo": 0, "ndof": 1}


def test_truss_static_deflection_and_normal_force(truss):
    solution = static_equilibrium(truss)
    assert solution.coordinates()["2.x"] == pytest.approx(0.1 + 1.0 / K_EQ, rel=1e-6)
    assert round(solution.coordinates()["2.x"], 4) == 0.1011
    assert solution.stresses()["spring.e1"] == pytest.approx(1.0, abs=1e-9)


def test_truss_mass_stiffness_and_frequency(truss):
    lin = linearize(truss)
    m0 = BAR_MASS + RHO_A_BOTH * L0 / 3
    assert lin.M0[0, 0] == pytest.approx(m0, rel=1e-12)
    assert lin.M0[0, 0] == pytest.approx(0.2107, rel=1e-4)
    assert lin.K[0, 0] == pytest.approx(945.0, rel=1e-9)
    frequency = natural_frequencies(truss, linear_model=lin).frequencies_hz[0]
    assert frequency == pytest.approx(10.6584, rel=1e-4)


def test_truss_transfer_function(truss):
    tf = control.ss2tf(state_space(truss))
    num, den = tf.num[0][0], tf.den[0][0]
    assert len(den) == 3 and np.all(np.abs(num[:-1]) < 1e-9 * abs(num[-1]))  # x/F = b0 / den
    assert num[-1] / den[0] == pytest.approx(4.746, rel=5e-4)  # 4 digits as published
    assert den[1] / den[0] == pytest.approx(0.1732, rel=5e-4)
    assert den[2] / den[0] == pytest.approx(4485.0, rel=5e-4)


def test_planar_1dof_stage():
    model = load_scene("stage_planar_1dof")
    assert model.dof_count() == {"nx": 12, "nxo": 6, "neo": 5, "ndof": 1}
    frequency = natural_frequencies(model).frequencies_hz[0]
    assert frequency == pytest.approx(10.6, rel=5e-3)
    # Consistent (Hermite) mass of a guided spring: 13/35 rho A l0 of each spring moves along.
    m0 = BAR_MASS + 2 * 13 / 35 * (RHO_A_BOTH / 2) * L0
    assert frequency == pytest.approx(np.sqrt(24 * EI / L0**3 / m0) / (2 * np.pi), rel=1e-9)


def test_planar_1dof_buckling_load_factor():
    factors = buckling_load_factors(load_scene("stage_planar_1dof"))
    assert factors[0] == pytest.approx(78.75, rel=1e-4)
    assert factors[0] == pytest.approx(2 * 10 * EI / L0**2, rel=1e-9)


def test_planar_3dof_stage_frequencies():
    model = load_scene("stage_planar_3dof")
    assert model.dof_count() == {"nx": 12, "nxo": 6, "neo": 3, "ndof": 3}
    frequencies = natural_frequencies(model).frequencies_hz
    np.testing.assert_allclose(frequencies, [10.6, 2129.0, 3585.0], rtol=5e-3)
    # The vertical mode: both springs in tension-compression, 13/35 of their mass moving.
    m_vertical = BAR_MASS + 2 * 13 / 35 * (RHO_A_BOTH / 2) * L0
    vertical = np.sqrt(2 * EA / L0 / m_vertical) / (2 * np.pi)
    assert frequencies[1] == pytest.approx(vertical, rel=1e-4)


def test_planar_3dof_first_mode_matches_1dof_model():
    """Releasing the stiff elongations barely changes the first mode (the 1-DOF model holds)."""
    f1 = natural_frequencies(load_scene("stage_planar_1dof")).frequencies_hz[0]
    f3 = natural_frequencies(load_scene("stage_planar_3dof")).frequencies_hz[0]
    assert f3 == pytest.approx(f1, rel=1e-4)
