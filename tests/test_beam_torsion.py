"""An axial force changes a beam's torsional stiffness: the BEAM's elongation term rp^2 e2^2 /
(2 l0^3) against the closed forms.

References:
- M. A. Biot, "Increase of torsional stiffness of a prismatical bar due to axial tension",
  J. Appl. Phys. 10 (1939) 860-864; S. P. Timoshenko and J. M. Gere, Theory of Elastic
  Stability, 2nd ed. (1961), art. 5.3: a bar under an axial force N (tension positive) has the
  torque stiffness per unit length G It + N Ip / A (Saint-Venant torsion, warping free), so
  that it buckles in pure torsion under the compression A G It / Ip.
- Its torsional vibration, clamped at both ends: f_n = n / (2 L) sqrt((G It + N Ip / A) /
  (rho Ip)).

The strip of the issue: steel, 100 x 10 x 0.3 mm, clamped at both ends, the end q free to slide
along the strip under a dead tension T. Its twist is piecewise linear along any mesh of BEAMs
(no warping: the torque is constant between the loads), which e2 = l0 sin(theta) and the torsion
term represent exactly to second order: the compliance and the buckling load have no
discretisation error, whatever the number of elements, and the frequencies' only error is that
of the linearly interpolated rotational inertia, (k h)^2 / 24 for the wave number k and element
length h, which the tension does not change. Tolerances: round-off of the solves on a stiffness
whose axial and torsional entries differ by 1e7 to 1e8 (1e-9 relative for the linear solves,
1e-8 for the generalised eigenproblems, each several times what is measured), and the closed
forms' 1e-4 where a discretisation error remains.
"""

import numpy as np
import pytest

from flexure.core import build_model, compliance, natural_frequencies
from flexure.core.analysis.modal import buckling_load_factors
from flexure.core.scene.sections import rectangle

LENGTH, WIDTH, THICKNESS = 0.100, 0.010, 0.0003  # m
E, NU, RHO = 2.1e11, 0.3, 7850.0  # Pa, 1, kg/m^3
G = E / (2.0 * (1.0 + NU))
STRIP = rectangle(WIDTH, THICKNESS)
GIT = G * STRIP["It"]  # N m^2, Saint-Venant with the series of Timoshenko and Goodier
IP = STRIP["Iy"] + STRIP["Iz"]  # m^4
IP_A = IP / STRIP["A"]  # m^2


def strip(elements, *, section=None, tension=0.0):
    """A scene dict: the strip along x in `elements` BEAMs, every deformation released, clamped
    at t0, its end t{elements} held in y and z, its rotation fixed, pulled by `tension` (N)."""
    section = section or {"E": E, "nu": NU, "rho": RHO, "width": WIDTH, "height": THICKNESS}
    nodes, beams = {}, {}
    for i in range(elements + 1):
        nodes[f"t{i}"] = {"position": [LENGTH * i / elements, 0.0, 0.0]}
        nodes[f"r{i}"] = {"rotation": [0.0, 0.0, 0.0]}
    nodes["t0"]["fixed"] = ["x", "y", "z"]
    nodes["r0"]["fixed"] = True
    nodes[f"t{elements}"]["fixed"] = ["y", "z"]
    nodes[f"t{elements}"]["force"] = [tension, 0.0, 0.0]
    nodes[f"r{elements}"]["fixed"] = True
    for i in range(elements):
        beams[f"b{i}"] = {"type": "BEAM", "nodes": [f"t{i}", f"r{i}", f"t{i + 1}", f"r{i + 1}"],
                          "section": "strip", "y_axis": [0.0, 1.0, 0.0],
                          "released": ["e1", "e2", "e3", "e4", "e5", "e6"]}
    return {"scene": {"name": "strip", "dimension": 3}, "sections": {"strip": section},
            "nodes": nodes, "elements": beams}


def torque_stiffness(tension):
    """Biot: G It + N Ip / A (N m^2)."""
    return GIT + tension * IP_A


def test_the_strip_section_is_the_issues():
    """A = 3 mm^2, Ip / A = (b^2 + h^2) / 12 = 8.341 mm^2, G It = 7.13e-3 N m^2: the torque
    stiffness rises by T Ip / (A G It) = 3.5 % at 30 N and 11.7 % at 100 N, so the compliance
    falls by 3.4 % and 10.5 %, the frequencies rise by 1.7 % and 5.7 %."""
    np.testing.assert_allclose(IP_A, (WIDTH**2 + THICKNESS**2) / 12, rtol=1e-14)
    np.testing.assert_allclose(GIT, 7.13e-3, rtol=2e-3)
    np.testing.assert_allclose([30 * IP_A / GIT, 100 * IP_A / GIT], [0.0351, 0.117], rtol=2e-3)
    np.testing.assert_allclose(np.sqrt(1 + np.array([30, 100]) * IP_A / GIT) - 1,
                               [0.0174, 0.0569], rtol=2e-3)


@pytest.mark.parametrize("elements", [2, 8])
def test_torsional_compliance_falls_with_tension_as_biot(elements):
    """The rotation about x of the middle node under a moment there: L / (4 (G It + T Ip / A))
    (two halves of L / 2 in parallel), at T = 0, 30 and 100 N (33 MPa), to round-off on any
    mesh."""
    middle = f"r{elements // 2}"
    measured = []
    for tension in (0.0, 30.0, 100.0):
        model = build_model(strip(elements, tension=tension))
        measured.append(compliance(model, middle).matrix[0, 0])  # rad/(N m)
        expected = LENGTH / (4.0 * torque_stiffness(tension))
        np.testing.assert_allclose(measured[-1], expected, rtol=1e-9)
    falls = 1.0 - np.array(measured[1:]) / measured[0]
    np.testing.assert_allclose(falls, [30 * IP_A / torque_stiffness(30.0),
                                       100 * IP_A / torque_stiffness(100.0)], rtol=1e-8)
    assert 0.033 < falls[0] < 0.035 and 0.104 < falls[1] < 0.106


def torsional_frequencies(model, count=2):
    """The lowest `count` frequencies (Hz) of the modes in which the nodes only turn about x:
    for the doubly symmetric strip, straight, torsion decouples from bending and stretching."""
    modes = natural_frequencies(model)
    twist = [model.coordinate_index(f"{node.name}.lambda1") for node in model.nodes
             if node.kind == "rotational"]
    found = []
    for k, frequency in enumerate(modes.frequencies_hz):
        shape = modes.coordinate_shapes[:, k]
        if np.linalg.norm(shape[twist]) > (1.0 - 1e-9) * np.linalg.norm(shape):
            found.append(frequency)
    return np.array(found[:count])


def test_torsional_frequencies_rise_with_tension_as_biot():
    """The first two torsional frequencies rise by sqrt(1 + T Ip / (A G It)) (1.7 % at 30 N,
    5.7 % at 100 N) on any mesh; on 8 and 16 elements they converge to n / (2 L)
    sqrt((G It + T Ip / A) / (rho Ip)) from above as h^2, and the extrapolation h -> 0 meets
    it within 1e-4."""
    results = {}
    for elements in (8, 16):
        for tension in (0.0, 30.0, 100.0):
            model = build_model(strip(elements, tension=tension))
            results[elements, tension] = torsional_frequencies(model)
    for elements in (8, 16):
        for tension in (30.0, 100.0):
            rise = results[elements, tension] / results[elements, 0.0]
            np.testing.assert_allclose(rise, np.sqrt(torque_stiffness(tension) / GIT),
                                       rtol=1e-9)
    for tension in (0.0, 30.0, 100.0):
        exact = np.array([1.0, 2.0]) / (2 * LENGTH) * np.sqrt(
            torque_stiffness(tension) / (RHO * IP))
        coarse, fine = results[8, tension] / exact - 1.0, results[16, tension] / exact - 1.0
        assert np.all(fine > 0) and np.all(fine < 0.02)
        np.testing.assert_allclose(coarse / fine, 4.0, rtol=0.02)  # error ~ h^2
        extrapolated = results[16, tension] + (results[16, tension] - results[8, tension]) / 3
        np.testing.assert_allclose(extrapolated, exact, rtol=1e-4)


def test_the_strip_buckles_in_torsion_at_a_g_it_over_ip_after_bending():
    """Under compression the strip buckles first sideways, at the Euler load of a clamped
    column 4 pi^2 E Iz / L^2 = 18.7 N; the torsional buckling load A G It / Ip = 855 N is among
    its load factors, once per interior node (every twist distribution loses its stiffness
    there at once, as G It + N Ip / A multiplies them all)."""
    elements = 6
    model = build_model(strip(elements, tension=-1.0))
    factors = buckling_load_factors(model)
    euler = 4 * np.pi**2 * E * STRIP["Iz"] / LENGTH**2
    np.testing.assert_allclose(factors[0], euler, rtol=2e-3)  # six Hermite elements
    torsional = GIT / IP_A
    close = np.abs(factors / torsional - 1.0) < 1e-8
    assert np.count_nonzero(close) == elements - 1
    assert 850.0 < torsional < 860.0


def test_a_cruciform_column_buckles_in_torsion_first():
    """Timoshenko and Gere's example of art. 5.3: a cruciform section, four flanges b = 10 mm
    from the centre, t = 1 mm thick (It = 4 b t^3 / 3, Ip = 4 t b^3 / 3, Iy = Iz = Ip / 2,
    warping negligible), 100 mm long, buckles in torsion at A G It / Ip = 4 G t^3 / b
    (32.3 kN) long before the Euler load (553 kN); given by its properties, its Ip_A follows
    from (EIy + EIz) / EA."""
    b, t = 0.010, 0.001
    area, it, ip = 4 * b * t, 4 * b * t**3 / 3, 4 * t * b**3 / 3
    section = {"EA": E * area, "GIt": G * it, "EIy": E * ip / 2, "EIz": E * ip / 2,
               "rho_A": RHO * area}
    model = build_model(strip(4, section=section, tension=-1.0))
    factors = buckling_load_factors(model)
    np.testing.assert_allclose(factors[:3], area * G * it / ip, rtol=1e-8)  # three twist DOFs
    np.testing.assert_allclose(area * G * it / ip, 4 * G * t**3 / b, rtol=1e-14)
    euler = 4 * np.pi**2 * E * (ip / 2) / LENGTH**2
    np.testing.assert_allclose(factors[3], euler, rtol=1e-2)  # then bending, on 4 elements
