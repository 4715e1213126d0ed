"""Shear-deformable beams against Timoshenko's beam theory.

PLBEAM's `GAs` and BEAM's `GAs_y`, `GAs_z` (shear stiffness G kappa A, N) turn the bending
stiffness on each pair of bending deformations into the Timoshenko beam element's,
EI / (l0^3 (1 + Phi)) [[4 + Phi, Phi - 2], [Phi - 2, 4 + Phi]], Phi = 12 EI / (G kappa A l0^2)
(core/elements/timoshenko.py). Checked here:

- a short cantilever's tip compliance against delta / F = L^3 / (3 EI) + L / (kappa G A),
  with one element and with several (the element is exact under end loads: 1e-12);
- the clamped-free bending frequencies of a thick beam (L / h = 5) against the roots of the
  Timoshenko beam's frequency equation (Huang 1961), found here with brentq and checked against
  a transfer matrix of Timoshenko's differential equations, within 1e-3;
- SPACAR's ESTIFF shear terms EI / (kappa G A) (m^2) read as those shear stiffnesses;
- the default (no shear stiffness) is the Euler-Bernoulli matrix to the bit, and a shear
  stiffness of zero or below is refused naming the file, the section and the key.

Steel in SI units: E = 210 GPa, nu = 0.3, rho = 7850 kg/m^3; a rectangle's shear coefficient
kappa = 10 (1 + nu) / (12 + 11 nu) (Cowper 1966, the one SPACAR Light's calc_stiffness uses).
"""

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

from flexure.core import SceneError, build_model, load_scene, natural_frequencies, scene_toml
from flexure.core.analysis.compliance import compliance
from flexure.core.elements import beam, plbeam
from flexure.core.scene.spacar_input import read_spacar

E, NU, RHO = 2.1e11, 0.3, 7850.0  # Pa, 1, kg/m^3
G = E / (2.0 * (1.0 + NU))  # Pa
KAPPA = 10.0 * (1.0 + NU) / (12.0 + 11.0 * NU)  # rectangle (Cowper)


def planar_cantilever(length, height, width, segments, *, shear=True, mass=False):
    """A PLBEAM cantilever along x clamped at node 1, free at node 3 (m): its scene dict."""
    area, inertia = width * height, width * height**3 / 12.0
    section = {"EA": E * area, "EI": E * inertia}
    if shear:
        section["GAs"] = KAPPA * G * area
    if mass:
        section["rho_A"] = RHO * area
    return {"scene": {"name": "shear_cantilever", "dimension": 2}, "sections": {"s": section},
            "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                      "2": {"angle": 0.0, "fixed": ["phi"]},
                      "3": {"position": [length, 0.0]}, "4": {"angle": 0.0}},
            "elements": {"b": {"type": "PLBEAM", "nodes": ["1", "2", "3", "4"], "section": "s",
                               "released": ["e1", "e2", "e3"], "segments": segments}}}


def spatial_cantilever(length, height, width, segments, *, mass=False):
    """A BEAM cantilever along x, y' = y (height along y', width along z'), clamped at node 1:
    its scene dict, with the shear stiffness kappa G A in both planes."""
    area = width * height
    iz, iy = width * height**3 / 12.0, height * width**3 / 12.0
    section = {"EA": E * area, "GIt": G * 0.1 * area * min(width, height)**2, "EIy": E * iy,
               "EIz": E * iz, "GAs_y": KAPPA * G * area, "GAs_z": KAPPA * G * area}
    if mass:
        section.update(rho_A=RHO * area, rho_Iy=RHO * iy, rho_Iz=RHO * iz)
    return {"scene": {"name": "shear_cantilever_3d", "dimension": 3}, "sections": {"s": section},
            "nodes": {"1": {"position": [0.0, 0.0, 0.0], "fixed": ["x", "y", "z"]},
                      "2": {"rotation": [0.0, 0.0, 0.0], "fixed": True},
                      "3": {"position": [length, 0.0, 0.0]},
                      "4": {"rotation": [0.0, 0.0, 0.0]}},
            "elements": {"b": {"type": "BEAM", "nodes": ["1", "2", "3", "4"], "section": "s",
                               "y_axis": [0.0, 1.0, 0.0],
                               "released": ["e1", "e2", "e3", "e4", "e5", "e6"],
                               "segments": segments}}}


def timoshenko_tip_compliance(length, bending, shear):
    """delta / F = L^3 / (3 EI) + L / (kappa G A) of a cantilever under a tip force (m/N)."""
    return length**3 / (3.0 * bending) + length / shear


@pytest.mark.parametrize("segments", [1, 3, 8])
def test_planar_cantilever_tip_compliance_is_timoshenkos(segments):
    length, height, width = 0.02, 0.01, 0.01  # L / h = 2: shear adds 19 % to bending
    result = compliance(build_model(planar_cantilever(length, height, width, segments)), "3")
    area, inertia = width * height, width * height**3 / 12.0
    expected = timoshenko_tip_compliance(length, E * inertia, KAPPA * G * area)
    y = result.coordinates.index("3.y")
    assert result.matrix[y, y] == pytest.approx(expected, rel=1e-12)
    # the shear part is not negligible: Euler-Bernoulli alone is 16 % off
    assert abs(length**3 / (3 * E * inertia) / expected - 1) > 0.1


@pytest.mark.parametrize("segments", [1, 4])
def test_spatial_cantilever_tip_compliance_is_timoshenkos_in_both_planes(segments):
    """The force along y' bends with EIz and GAs_y, the one along z' with EIy and GAs_z: the
    section's two bending stiffnesses differ (height 10 mm along y', width 6 mm along z'), so a
    key paired with the wrong plane would miss."""
    length, height, width = 0.03, 0.01, 0.006
    area = width * height
    data = spatial_cantilever(length, height, width, segments)
    data["sections"]["s"]["GAs_z"] *= 0.5  # two different shear stiffnesses as well
    result = compliance(build_model(data), "3")
    iz, iy = width * height**3 / 12.0, height * width**3 / 12.0
    y, z = result.coordinates.index("3.y"), result.coordinates.index("3.z")
    assert result.matrix[y, y] == pytest.approx(
        timoshenko_tip_compliance(length, E * iz, KAPPA * G * area), rel=1e-12)
    assert result.matrix[z, z] == pytest.approx(
        timoshenko_tip_compliance(length, E * iy, 0.5 * KAPPA * G * area), rel=1e-12)


# -- the frequencies of a thick clamped-free beam ----------------------------------------------

def huang_equation(b, r2, s2):
    """Timoshenko's clamped-free frequency equation (Huang, J. Appl. Mech. 28, 1961), below the
    cut-off b^2 r2 s2 < 1: zero at b = omega L^2 sqrt(rho A / (EI)), with r2 = I / (A L^2) (the
    rotary inertia; 0 leaves it out) and s2 = EI / (kappa G A L^2) (the shear flexibility)."""
    root = np.sqrt((r2 - s2) ** 2 + 4.0 / b**2)
    alpha = np.sqrt((root - (r2 + s2)) / 2.0)
    beta = np.sqrt((root + (r2 + s2)) / 2.0)
    return (2.0 + (b**2 * (r2 - s2) ** 2 + 2.0) * np.cosh(b * alpha) * np.cos(b * beta)
            - b * (r2 + s2) / np.sqrt(1.0 - b**2 * r2 * s2) * np.sinh(b * alpha)
            * np.sin(b * beta))


def transfer_determinant(omega, length, bending, shear, mass, rotary):
    """The frequency equation as a transfer matrix: Timoshenko's beam in the state
    [w, psi, M, V] (w' = psi + V / (kappa G A), psi' = M / EI, M' = -V - rho I omega^2 psi,
    V' = -rho A omega^2 w); clamped (w = psi = 0) at 0, free (M = V = 0) at L: the 2 x 2 block
    of expm(A L) from [M, V] at 0 to [M, V] at L is singular at a natural frequency."""
    a = np.array([[0.0, 1.0, 0.0, 1.0 / shear], [0.0, 0.0, 1.0 / bending, 0.0],
                  [0.0, -rotary * omega**2, 0.0, -1.0], [-mass * omega**2, 0.0, 0.0, 0.0]])
    return np.linalg.det(expm(a * length)[2:, 2:])


def timoshenko_frequencies(length, area, inertia, *, rotary, count=3):
    """The first `count` clamped-free bending frequencies (Hz) of Timoshenko's beam, from the
    roots of `huang_equation` by brentq, each checked to be a root of `transfer_determinant`
    too (a sign change within 1e-9 relative)."""
    r2 = inertia / (area * length**2) if rotary else 0.0
    s2 = E * inertia / (KAPPA * G * area * length**2)
    grid = np.linspace(0.5, 60.0, 1200)
    values = huang_equation(grid, r2, s2)
    roots = [brentq(huang_equation, lo, hi, args=(r2, s2), xtol=1e-14, rtol=1e-15)
             for lo, hi, f_lo, f_hi in zip(grid[:-1], grid[1:], values[:-1], values[1:],
                                           strict=True) if np.sign(f_lo) != np.sign(f_hi)]
    assert len(roots) >= count and all(b**2 * r2 * s2 < 1.0 for b in roots[:count])
    omegas = np.array(roots[:count]) / length**2 * np.sqrt(E * inertia / (RHO * area))
    for omega in omegas:
        ends = [transfer_determinant(omega * f, length, E * inertia, KAPPA * G * area,
                                     RHO * area, RHO * inertia * rotary)
                for f in (1 - 1e-9, 1 + 1e-9)]
        assert ends[0] * ends[1] < 0.0
    return omegas / (2.0 * np.pi)


def nearest(frequencies, targets):
    return np.array([frequencies[np.argmin(np.abs(frequencies - t))] for t in targets])


def test_the_reference_equation_gives_euler_bernoulli_without_shear_and_rotary_inertia():
    """With r2 = s2 = 0 Huang's equation is 2 + 2 cosh(sqrt(b)) cos(sqrt(b)): sqrt(b) = 1.8751,
    4.6941, 7.8548, the roots of the Euler-Bernoulli cantilever."""
    roots = [brentq(huang_equation, lo, hi, args=(0.0, 0.0), xtol=1e-14)
             for lo, hi in ((3.0, 4.0), (21.0, 23.0), (61.0, 62.5))]
    assert np.sqrt(roots) == pytest.approx([1.8751040687, 4.6940911330, 7.8547574382],
                                           rel=1e-9)


def test_planar_thick_cantilever_frequencies_are_timoshenkos_without_rotary_inertia():
    """PLBEAM has no rotary inertia of the section (its mass is the Hermite consistent mass of
    the position), so a refined mesh converges to Timoshenko's beam with shear flexibility and
    translational inertia only: the first three bending frequencies of a 50 x 10 x 10 mm steel
    beam (Phi = 0.12 over the whole length) with 64 segments are within 1.3e-4 of those roots
    (errors falling as 1 / segments^2: 32 segments give 5e-4 on the third). Against the full
    Timoshenko beam (with rotary inertia rho I) the same model is 0.7 % off on the first mode,
    and Euler-Bernoulli is 2.3 % off: the comparison tells them apart."""
    length, height, width = 0.05, 0.01, 0.01
    area, inertia = width * height, width * height**3 / 12.0
    expected = timoshenko_frequencies(length, area, inertia, rotary=False)
    model = build_model(planar_cantilever(length, height, width, 64, mass=True))
    found = nearest(np.sort(natural_frequencies(model).frequencies_hz), expected)
    np.testing.assert_allclose(found, expected, rtol=1e-3)
    with_rotary = timoshenko_frequencies(length, area, inertia, rotary=True)
    assert abs(found[0] / with_rotary[0] - 1) > 5e-3
    euler_bernoulli = 1.8751040687**2 / (2 * np.pi * length**2) * np.sqrt(
        E * inertia / (RHO * area))
    assert abs(found[0] / euler_bernoulli - 1) > 2e-2


def test_spatial_thick_cantilever_frequencies_are_timoshenkos_with_rotary_inertia():
    """BEAM carries the section's rotary inertia (rho_Iy, rho_Iz on its section axes,
    interpolated linearly), the full Timoshenko beam: with 64 segments the first three bending
    frequencies in each plane of a 50 x 10 x 6 mm steel beam are within 2e-4 of the roots of
    Timoshenko's equation with shear and rotary inertia (errors falling as 1 / segments^2)."""
    length, height, width = 0.05, 0.01, 0.006
    area = width * height
    model = build_model(spatial_cantilever(length, height, width, 64, mass=True))
    frequencies = np.sort(natural_frequencies(model).frequencies_hz)
    for inertia in (width * height**3 / 12.0, height * width**3 / 12.0):  # along y', z'
        expected = timoshenko_frequencies(length, area, inertia, rotary=True)
        np.testing.assert_allclose(nearest(frequencies, expected), expected, rtol=1e-3)


# -- the default, SPACAR's ESTIFF, and what is refused ---------------------------------------

def test_without_shear_stiffness_the_bending_matrices_are_euler_bernoullis_to_the_bit():
    rng = np.random.default_rng(7)
    l0 = rng.uniform(0.01, 0.3, 5)
    flexural = rng.uniform(0.1, 100.0, 5)
    euler_bernoulli = (flexural / l0**3)[:, None, None] * np.array([[4.0, -2.0], [-2.0, 4.0]])
    planar = plbeam.stiffness({"l0": l0}, {"EA": flexural, "EI": flexural, "GAs": np.inf})
    np.testing.assert_array_equal(planar[:, 1:, 1:], euler_bernoulli)
    spatial = beam.damping({"l0": l0}, {"EdA": flexural, "GdIt": flexural, "EdIy": flexural,
                                        "EdIz": flexural, "EIy": flexural, "EIz": flexural,
                                        "GAs_y": np.inf, "GAs_z": np.inf})
    np.testing.assert_array_equal(spatial[:, 2:4, 2:4], euler_bernoulli)
    np.testing.assert_array_equal(spatial[:, 4:6, 4:6], euler_bernoulli)
    defaults = {key.name: key.default for kind in (plbeam, beam) for key in kind.section_schema}
    assert defaults["GAs"] == defaults["GAs_y"] == defaults["GAs_z"] == np.inf


def test_uniform_bending_keeps_its_stiffness_and_the_s_shape_softens_by_one_plus_phi():
    l0, flexural, shear = np.array([0.02]), np.array([3.0]), np.array([2.0e4])
    phi = 12.0 * flexural / (shear * l0**2)
    block = plbeam.stiffness({"l0": l0}, {"EA": flexural, "EI": flexural, "GAs": shear})[0, 1:, 1:]
    uniform, s_shape = np.array([1.0, 1.0]), np.array([1.0, -1.0])
    assert uniform @ block @ uniform == pytest.approx(4.0 * flexural[0] / l0[0]**3, rel=1e-14)
    assert s_shape @ block @ s_shape == pytest.approx(
        12.0 * flexural[0] / (l0[0]**3 * (1.0 + phi[0])), rel=1e-14)


BEAM_DAT = """\
BEAM 1 1 2 3 4 0 1 0
X 1 0 0 0
X 3 {length} 0 0
FIX 1
FIX 2
RLSE 1 1 2 3 4 5 6
END
ESTIFF 1 {EA} {GIt} {EIy} {EIz} {sy} {sz}
END
END
"""


def test_spacar_shear_terms_are_ei_over_kappa_g_a(tmp_path):
    """SPACAR Light's calc_stiffness writes the BEAM's ESTIFF as EA, GIt, EIy, EIz,
    EIy / (k G A), EIz / (k G A): read, they give the tip compliance of Timoshenko's
    cantilever in both planes, and the section keys GAs_z = EIy / sy, GAs_y = EIz / sz."""
    length, height, width = 0.03, 0.01, 0.006
    area = width * height
    iz, iy = width * height**3 / 12.0, height * width**3 / 12.0
    shear = KAPPA * G * area
    path = tmp_path / "thick.dat"
    path.write_text(BEAM_DAT.format(length=length, EA=E * area, GIt=G * 1e-9, EIy=E * iy,
                                    EIz=E * iz, sy=E * iy / shear, sz=E * iz / shear))
    section = read_spacar(path)["sections"]["1"]
    assert section["GAs_z"] == pytest.approx(shear, rel=1e-14)
    assert section["GAs_y"] == pytest.approx(shear, rel=1e-14)
    result = compliance(load_scene(path), "3")
    y, z = result.coordinates.index("3.y"), result.coordinates.index("3.z")
    assert result.matrix[y, y] == pytest.approx(
        timoshenko_tip_compliance(length, E * iz, shear), rel=1e-12)
    assert result.matrix[z, z] == pytest.approx(
        timoshenko_tip_compliance(length, E * iy, shear), rel=1e-12)


def test_a_planar_spacar_shear_term_is_read_as_gas(tmp_path):
    length, height, width = 0.02, 0.01, 0.01
    inertia, shear = width * height**3 / 12.0, KAPPA * G * width * height
    path = tmp_path / "thick.dat"
    path.write_text(f"PLBEAM 1 1 2 3 4\nX 1 0 0\nX 3 {length} 0\nFIX 1\nFIX 2\nRLSE 1 1 2 3\n"
                    f"END\nESTIFF 1 {E * width * height} {E * inertia} {E * inertia / shear}\n"
                    "END\nEND\n")
    assert read_spacar(path)["sections"]["1"]["GAs"] == pytest.approx(shear, rel=1e-14)
    result = compliance(load_scene(path), "3")
    y = result.coordinates.index("3.y")
    assert result.matrix[y, y] == pytest.approx(
        timoshenko_tip_compliance(length, E * inertia, shear), rel=1e-12)


@pytest.mark.parametrize("dimension, key", [(2, "GAs"), (3, "GAs_y"), (3, "GAs_z")])
@pytest.mark.parametrize("value", [0.0, -1.0e6])
def test_a_shear_stiffness_not_above_zero_is_refused_naming_file_section_and_key(
        dimension, key, value, tmp_path):
    data = (planar_cantilever if dimension == 2 else spatial_cantilever)(0.02, 0.01, 0.01, 1)
    data["sections"]["s"][key] = value
    path = tmp_path / "thick.toml"
    path.write_text(scene_toml(data))
    with pytest.raises(SceneError) as raised:
        load_scene(path)
    message = str(raised.value)
    assert str(path) in message and f"sections.s.{key}" in message, message
    assert f"expected a value > 0, got {value!r}" in message, message
