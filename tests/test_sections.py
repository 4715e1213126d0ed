"""Section properties from dimensions against tabulated values and limits.

Torsion of rectangles: Roark's Formulas for Stress and Strain (7th ed., table 10.7, case 4)
tabulates It = K1 a t^3 and tau_max = T / (K2 a t^2) by a / t: K1 = 0.141, 0.229, 0.263, 0.281,
0.312 and K2 = 0.208, 0.246, 0.267, 0.282, 0.312 at a / t = 1, 2, 3, 4, 10 (three digits).
For a thin strip (a / t -> infinity) both tend to 1/3. Circles: It = pi d^4 / 32 exactly.
"""

import numpy as np
import pytest

from flexure.core import SceneError, build_model
from flexure.core.scene.sections import beam_properties, circle, rectangle


@pytest.mark.parametrize("ratio, k1, k2", [(1, 0.1406, 0.208), (2, 0.229, 0.246),
                                           (3, 0.263, 0.267), (4, 0.281, 0.282),
                                           (10, 0.312, 0.312)])
def test_rectangle_torsion_series_matches_the_tabulated_constants(ratio, k1, k2):
    section = rectangle(width=float(ratio) * 0.01, height=0.01)
    a, t = ratio * 0.01, 0.01
    np.testing.assert_allclose(section["It"] / (a * t**3), k1, atol=1.5e-3)
    np.testing.assert_allclose(section["Wt"] / (a * t**2), k2, atol=1.5e-3)


def test_thin_strip_tends_to_one_third_and_the_orientation_does_not_matter():
    strip = rectangle(width=1.0, height=1e-3)
    np.testing.assert_allclose(strip["It"], 1.0 * 1e-9 / 3 * (1 - 0.630 * 1e-3), rtol=1e-4)
    turned = rectangle(width=1e-3, height=1.0)
    assert turned["It"] == strip["It"] and turned["Wt"] == strip["Wt"]
    assert turned["Iz"] == strip["Iy"] and turned["Wz"] == strip["Wy"]


def test_a_strip_of_any_thinness_sums_its_series_without_overflow():
    """Width / height up to 1e308 (a mutated scene's): the torsion series' arguments overflow
    no longer, and It, Wt stay finite; a strip past a / t = 446, where every argument has
    reached its cap of 700 already, keeps the uncapped series' value; a thin strip's Wt tends
    to a t^2 / 3."""
    with np.errstate(over="raise"):
        extreme = rectangle(width=1.0, height=1e-308)
    assert np.isfinite(extreme["It"]) and np.isfinite(extreme["Wt"])
    a, t = 10.0, 1e-3
    n = np.arange(1, 4002, 2, dtype=float)
    argument = np.minimum(n * np.pi * (a / t) / 2.0, 700.0)  # uncapped: finite at a / t = 1e4
    series = np.sum(np.tanh(argument) / n**5)
    it = a * t**3 / 3.0 * (1.0 - 192.0 / np.pi**5 / (a / t) * series)
    assert rectangle(width=a, height=t)["It"] == it
    np.testing.assert_allclose(rectangle(1.0, 1e-6)["Wt"], 1e-12 / 3, rtol=1e-5)


def test_leaf_spring_section_of_the_stage():
    """18 mm x 0.5 mm steel: EIz' = 0.039375 N m^2 (figures.md), EA = 1.89e6 N,
    rho A = 0.07065 kg/m, G = E / 2.6."""
    props = beam_properties({"E": 2.1e11, "rho": 7850.0, "width": 0.018, "height": 0.0005})
    np.testing.assert_allclose(props["EIz"], 0.039375, rtol=1e-12)
    np.testing.assert_allclose(props["EA"], 1.89e6, rtol=1e-12)
    np.testing.assert_allclose(props["rho_A"], 0.07065, rtol=1e-12)
    np.testing.assert_allclose(props["EIy"], 2.1e11 * 0.0005 * 0.018**3 / 12, rtol=1e-12)
    it = rectangle(0.018, 0.0005)["It"]
    np.testing.assert_allclose(props["GIt"], 2.1e11 / 2.6 * it, rtol=1e-12)
    np.testing.assert_allclose(props["Wz"], 0.018 * 0.0005**2 / 6, rtol=1e-12)


def test_circle():
    d = 0.02
    section = circle(d)
    np.testing.assert_allclose(section["It"], np.pi * d**4 / 32, rtol=1e-15)
    np.testing.assert_allclose(section["Iy"], section["It"] / 2, rtol=1e-15)
    np.testing.assert_allclose(section["Wt"], 2 * section["Wy"], rtol=1e-15)
    props = beam_properties({"E": 7e10, "G": 2.6e10, "diameter": d, "beta": 1e-4})
    np.testing.assert_allclose(props["GIt"], 2.6e10 * np.pi * d**4 / 32, rtol=1e-15)
    np.testing.assert_allclose(props["EdIy"], 1e-4 * props["EIy"], rtol=1e-15)
    assert props["circular"] == 1.0


def test_properties_given_directly_take_precedence():
    props = beam_properties({"E": 2e11, "width": 0.01, "height": 0.01, "GIt": 5.0})
    assert props["GIt"] == 5.0
    direct = beam_properties({"EA": 1.0, "GIt": 2.0, "EIy": 3.0, "EIz": 4.0})
    assert "A" not in direct  # no dimensions: no stresses


def test_section_errors_name_the_section():
    base = {"scene": {"dimension": 3}, "nodes": {"a": {"position": [0.0, 0.0, 0.0]}}}
    for section, expected in (({"E": 1.0, "width": 0.1}, "missing ['height']"),
                              ({"diameter": 0.1, "width": 0.1, "height": 0.1}, "not both"),
                              ({"width": 0.1, "height": 0.1}, "needs E"),
                              ({"EI": 1.0}, "unknown key")):
        data = dict(base, sections={"leaf": section})
        with pytest.raises(SceneError) as error:
            build_model(data, source="s.toml", check=False)
        assert "s.toml: sections.leaf" in str(error.value)
        assert expected in str(error.value)


def test_polar_radius_of_gyration_of_each_kind_of_section():
    """Ip_A = (Iy + Iz) / A (m^2): (b^2 + h^2) / 12 of a rectangle, d^2 / 8 of a circle, and of
    a section given by its properties (EIy + EIz) / EA, else (rho_Iy + rho_Iz) / rho_A; one
    given directly is kept; none without any of them."""
    strip = beam_properties({"E": 2.1e11, "width": 0.010, "height": 0.0003})
    np.testing.assert_allclose(strip["Ip_A"], (0.010**2 + 0.0003**2) / 12, rtol=1e-14)
    np.testing.assert_allclose(beam_properties({"E": 7e10, "diameter": 0.02})["Ip_A"],
                               0.02**2 / 8, rtol=1e-14)
    direct = beam_properties({"EA": 8.0, "GIt": 2.0, "EIy": 3.0, "EIz": 1.0})
    assert direct["Ip_A"] == 0.5
    inertias = beam_properties({"rho_A": 4.0, "rho_Iy": 1.0, "rho_Iz": 2.0})
    assert inertias["Ip_A"] == 0.75
    assert beam_properties({"EA": 8.0, "EIy": 3.0, "EIz": 1.0, "Ip_A": 0.1})["Ip_A"] == 0.1
    assert "Ip_A" not in beam_properties({"GIt": 2.0})
