"""Design sensitivities (core/analysis/sensitivity*.py) against closed forms and against
central differences of the full analysis.

Tolerances: an analytic derivative against the closed form to 1e-9 relative (both exact; the
analyses' round-off is about 1e-13); a difference-scheme derivative against the closed form
within FACTOR times its own error estimate, and that estimate below 1e-6 of the derivative;
analytic against the difference scheme within FACTOR times the scheme's error estimate.
"""

import json

import numpy as np
import pytest
from cli_runs import run

from flexure.core import (
    Sensitivities,
    buckling_load_factors,
    build_model,
    load_scene,
    natural_frequencies,
    sensitivities,
)
from flexure.core.analysis.sensitivity import central_difference, resolve_key
from flexure.core.analysis.sensitivity_analytic import nonlinearity
from flexure.core.analysis.sensitivity_quantities import Request, buckling_modes, evaluate, track
from flexure.core.cli.analyze import render_sensitivity
from flexure.core.errors import SceneError

FACTOR = 3.0  # how far beyond its error estimate a difference-scheme derivative may lie


def analytic_and_difference(model, key, request):
    """(the analytic derivatives, the difference scheme's and its error estimates)."""
    found = sensitivities(model, [key], modes=request.modes, buckling=request.buckling,
                          outputs=request.outputs, stress=request.stress,
                          compliance_nodes=request.compliance_nodes,
                          dc_gains=request.dc_gains)
    slope, error, _, _ = central_difference(model, resolve_key(model, key),
                                            evaluate(model, request), request)
    return found, slope, error


# -- closed forms ----------------------------------------------------------------------------

def test_truss_with_a_point_mass_closed_form():
    """f = sqrt(EA / (l0 m)) / (2 pi) with m = the node's mass plus a third of the truss's
    (consistent mass): df/dm = -f/(2m), df/dEA = f/(2 EA), df/drho_A = -f/(2m) l0/3; the
    scene without its 1 N load, so all three are analytic."""
    model = load_scene("truss_1dof_x", overrides={"nodes.2.force": [0.0, 0.0]})
    EA, l0, mass, rho_A = 94.5, 0.1, 0.206, 0.1413
    m = mass + rho_A * l0 / 3.0
    f = np.sqrt(EA / (l0 * m)) / (2 * np.pi)
    found = sensitivities(model, ["nodes.2.mass", "sections.springs.EA",
                                  "sections.springs.rho_A"], modes=1)
    assert isinstance(found, Sensitivities)
    assert found.quantities[0] == "frequency 1" and found.values[0] == pytest.approx(f, rel=1e-12)
    np.testing.assert_allclose(found.derivatives[0],
                               [-f / (2 * m), f / (2 * EA), -f / (2 * m) * l0 / 3], rtol=1e-9)
    assert list(found.methods[0]) == ["analytic"] * 3
    assert found.key_units == ["kg", "N", "kg/m"]


def test_loaded_truss_goes_to_the_difference_scheme_and_still_meets_the_closed_form():
    """With its 1 N the truss is preloaded, so the frequency's derivative is a central
    difference; the axial preload adds no stiffness along the truss, so the closed form
    holds and the scheme meets it within its estimate, itself below 1e-6 relative."""
    model = load_scene("truss_1dof_x")
    m = 0.206 + 0.1413 * 0.1 / 3.0
    f = np.sqrt(94.5 / (0.1 * m)) / (2 * np.pi)
    found = sensitivities(model, ["nodes.2.mass"], modes=1, dc_gains=False)
    assert found.methods[0, 0] == "central difference"
    exact = -f / (2 * m)
    assert abs(found.derivatives[0, 0] - exact) <= FACTOR * found.errors[0, 0]
    assert found.errors[0, 0] < 1e-6 * abs(exact)
    # the static displacement: exact with a preload, u = F l0 / EA, du/dEA = -u / EA
    by_ea = sensitivities(model, ["sections.springs.EA"], modes=0, dc_gains=False)
    assert by_ea.methods[0, 0] == "analytic"
    assert by_ea.derivatives[0, 0] == pytest.approx(-(0.1 / 94.5) / 94.5, rel=1e-9)


def cantilever(section, force=1e-3, L=0.1):
    """A clamped leaf, one PLBEAM, a small sideways tip force (N) and the tip's y as output."""
    return build_model({
        "scene": {"name": "leaf"},
        "sections": {"s": section},
        "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "2": {"angle": 0.0, "fixed": ["phi"]},
                  "3": {"position": [L, 0.0], "dof": ["x", "y"], "force": [0.0, force]},
                  "4": {"angle": 0.0, "dof": ["phi"]}},
        "elements": {"leaf": {"type": "PLBEAM", "nodes": ["1", "2", "3", "4"], "section": "s",
                              "released": ["e1", "e2", "e3"]}},
        "outputs": {"y": {"node": "3", "coordinate": "y", "quantity": "position"}}})


def test_leaf_tip_displacement_closed_form():
    """u = F L^3 / (3 EI): du/dEI = -u/EI analytic (EI given), du/dE = -u/E analytic and
    du/dheight = -3u/height by differences (EI ~ height^3). The force makes u/L = 1e-5, so
    the geometric nonlinearity changes u by about 1e-10 relative."""
    F, L, EI = 1e-3, 0.1, 0.039375
    u = F * L**3 / (3 * EI)
    given = cantilever({"EA": 1.89e6, "EI": EI})
    found = sensitivities(given, ["sections.s.EI"], modes=0, stress=False)
    assert found.quantities == ["output y"] and found.values[0] == pytest.approx(u, rel=1e-8)
    assert found.methods[0, 0] == "analytic"
    assert found.derivatives[0, 0] == pytest.approx(-u / EI, rel=1e-8)
    shaped = cantilever({"E": 2.1e11, "width": 0.018, "height": 0.0005})
    found = sensitivities(shaped, ["sections.s.E", "sections.s.height"], modes=0,
                          stress=False)
    assert list(found.methods[0]) == ["analytic", "central difference"]
    assert found.derivatives[0, 0] == pytest.approx(-u / 2.1e11, rel=1e-8)
    exact = -3 * u / 0.0005
    assert abs(found.derivatives[0, 1] - exact) <= FACTOR * found.errors[0, 1] + 1e-8 * abs(
        exact)  # the closed form's own 1e-10 of geometric nonlinearity, times the 3 of h^3
    assert found.errors[0, 1] < 1e-6 * abs(exact)


def test_stage_buckling_scales_with_ei():
    """The stage's 78.75 N (stage_planar_1dof, its leaves do not stretch) is proportional to
    EI = E width height^3 / 12: dl/dE = l/E, dl/dwidth = l/width, dl/dheight = 3 l/height, by
    the difference scheme (G0 of the reference load), each within its estimate."""
    found = sensitivities("stage_planar_1dof", ["sections.leaf.E", "sections.leaf.width",
                                                "sections.leaf.height"],
                          modes=0, buckling=1, outputs=False, stress=False, dc_gains=False)
    assert found.quantities == ["buckling factor 1"]
    factor = found.values[0]
    assert factor == pytest.approx(78.75, rel=1e-4)
    exact = [factor / 2.1e11, factor / 0.018, 3 * factor / 0.0005]
    assert list(found.methods[0]) == ["central difference"] * 3
    assert np.all(np.abs(found.derivatives[0] - exact) <= FACTOR * found.errors[0])
    assert np.all(found.errors[0] < 1e-6 * np.abs(exact))


def test_buckling_modes_are_the_buckling_analysis():
    model = load_scene("stage_planar_3dof")
    factors, shapes, _ = buckling_modes(model)
    np.testing.assert_allclose(factors, buckling_load_factors(model), rtol=1e-12)
    assert shapes.shape == (3, factors.size)


def test_largest_stress_of_a_sideways_loaded_stage():
    """1 N sideways: the largest von Mises stress is sigma = N/A + M/W = g(E width, height) /
    width (A, W ~ width; the forces follow EI = E width height^3 / 12), so exactly
    width dsigma/dwidth = E dsigma/dE - sigma. Both by the difference scheme, within their
    estimates. dsigma/dheight is -2 sigma/height (M/W) to 5e-3: the normal force's share of
    the moment (2.1e-3 of it, ~ the deflection, ~ height^-3) and N/A move it."""
    model = load_scene("stage_planar_1dof", overrides={"nodes.3.force": [1.0, 0.0]})
    found = sensitivities(model, ["sections.leaf.height", "sections.leaf.width",
                                  "sections.leaf.E"], modes=0, outputs=False, dc_gains=False)
    assert found.quantities == ["largest von Mises (at leaf_left p)"]
    assert list(found.methods[0]) == ["central difference"] * 3
    sigma = found.values[0]
    assert sigma == pytest.approx(33.46e6, rel=1e-3)
    assert found.derivatives[0, 0] == pytest.approx(-2 * sigma / 0.0005, rel=5e-3)
    w, E = 0.018, 2.1e11
    identity = w * found.derivatives[0, 1] - E * found.derivatives[0, 2] + sigma
    assert abs(identity) <= FACTOR * (w * found.errors[0, 1] + E * found.errors[0, 2])
    assert w * found.errors[0, 1] + E * found.errors[0, 2] < 1e-6 * sigma


# -- analytic against the full analysis' central differences ---------------------------------

@pytest.mark.parametrize("key", ["sections.leaf.width", "sections.bar.rho_A",
                                 "sections.leaf.E", "sections.leaf.rho"])
def test_analytic_meets_central_differences_on_the_3dof_stage(key):
    """Frequencies, compliance of node 3 and DC gains of stage_planar_3dof (no load, so all
    analytic for these keys) against the difference scheme within its estimate; the entries
    that are round-off in both (a zero compliance, a mass key's DC gain) within 1e-9 of the
    column's largest."""
    model = load_scene("stage_planar_3dof")
    request = Request(modes=3, compliance_nodes=("3",), stress=False, outputs=False)
    found, slope, error = analytic_and_difference(model, key, request)
    assert set(found.methods[:, 0]) == {"analytic"}
    floor = 1e-9 * np.max(np.abs(found.derivatives[:, 0]))
    assert np.all(np.abs(found.derivatives[:, 0] - slope) <= FACTOR * error + floor)


@pytest.mark.parametrize("key", ["sections.leaf.height", "sections.leaf.width",
                                 "nodes.1.position[1]"])
def test_stage_frequencies_match_plain_central_differences(key):
    """The issue's check: stage_planar_3dof's three frequencies to the leaf thickness, width
    and (through its clamped end) the left leaf's length, against central differences
    computed here with natural_frequencies at p (1 +- 1e-4), or +- 1e-5 m, within 1e-6
    relative."""
    model = load_scene("stage_planar_3dof")
    found = sensitivities(model, [key], modes=3, outputs=False, stress=False, dc_gains=False)
    resolved = resolve_key(model, key)
    h = 1e-5 if resolved.index is not None else 1e-4 * resolved.value
    side = [natural_frequencies(load_scene("stage_planar_3dof", overrides={
        resolved.key: resolved.value_for(model.scene, resolved.value + s * h)})).frequencies_hz
        for s in (-1, 1)]
    np.testing.assert_allclose(found.derivatives[:, 0], (side[1] - side[0]) / (2 * h),
                               rtol=1e-6)


def test_the_static_displacement_is_analytic_under_a_preload():
    """dq/dp = K^-1 dQ/dp at the equilibrium, K = K0 + G0 with the preload's G0: the stage
    under 1 N sideways and 10 N down, against the difference scheme within its estimate."""
    model = load_scene("stage_planar_3dof", overrides={"nodes.3.force": [1.0, -10.0]})
    request = Request(modes=0, stress=False, dc_gains=False)
    found, slope, error = analytic_and_difference(model, "sections.leaf.width", request)
    assert found.quantities == ["output x", "output y"]
    assert list(found.methods[:, 0]) == ["analytic"] * 2
    assert np.all(np.abs(found.derivatives[:, 0] - slope) <= FACTOR * error)
    # its frequencies go to the difference scheme: G0 follows the key through the stresses
    loaded = sensitivities(model, ["sections.leaf.width"], modes=1, outputs=False,
                           stress=False, dc_gains=False)
    assert loaded.methods[0, 0] == "central difference"


def test_which_keys_the_matrices_are_linear_in():
    """Checked on the model (sensitivity_analytic.nonlinearity): a mass, rho_A, E and a
    planar width are linear; the height (EI ~ h^3) and a position (the geometry) are not."""
    model = load_scene("stage_planar_3dof")

    def reason(key, scale):
        resolved = resolve_key(model, key)
        return nonlinearity(tuple(build_model(model.scene, overrides={
            resolved.key: resolved.value_for(model.scene, resolved.value * s)})
            for s in scale))

    for key in ("sections.bar.rho_A", "sections.leaf.E", "sections.leaf.width"):
        assert reason(key, (1, 2, 3)) == ""
    assert reason("sections.leaf.height", (1, 2, 3)) == "the stiffness or mass is not linear in it"
    assert reason("nodes.3.position[1]", (1, 2, 3)).startswith("it changes the geometry")


# -- mode tracking ---------------------------------------------------------------------------

def crossing_pair(ratio):
    """A point mass (1 kg) on two massless trusses, along x (l = 0.1 m) and along y: the
    x mode sqrt(EA_x / (l m)) and the y mode, `ratio` times it."""
    k = 1000.0
    return build_model({
        "scene": {"name": "pair"},
        "sections": {"sx": {"EA": k * 0.1}, "sy": {"EA": ratio**2 * k * 0.1}},
        "nodes": {"a": {"position": [-0.1, 0.0], "fixed": ["x", "y"]},
                  "b": {"position": [0.0, -0.1], "fixed": ["x", "y"]},
                  "m": {"position": [0.0, 0.0], "dof": ["x", "y"], "mass": 1.0}},
        "elements": {"tx": {"type": "PLTRUSS", "nodes": ["a", "m"], "section": "sx",
                            "released": ["e1"]},
                     "ty": {"type": "PLTRUSS", "nodes": ["b", "m"], "section": "sy",
                            "released": ["e1"]}}})


def test_mode_tracking_follows_a_mode_through_a_crossing():
    """The y mode lies 1e-5 above the x mode; moving node a by the scheme's step (1e-4 m)
    changes the x mode by 5e-4 relative, so the two cross between p - h and p + h. Matched by
    MAC, mode 1 (x) has df/da_x = f/(2 l) and mode 2 (y) none; sorted by frequency instead,
    each would take half the other's slope."""
    model = crossing_pair(1.0 + 1e-5)
    found = sensitivities(model, ["nodes.a.position[0]"], modes=2, stress=False,
                          dc_gains=False)
    f = found.values[0]
    assert f == pytest.approx(np.sqrt(1000.0) / (2 * np.pi), rel=1e-12)
    assert found.steps[0] == pytest.approx(1e-4)
    assert list(found.methods[:, 0]) == ["central difference"] * 2
    assert abs(found.derivatives[0, 0] - f / 0.2) <= FACTOR * found.errors[0, 0]
    assert abs(found.derivatives[1, 0]) <= FACTOR * found.errors[1, 0]
    assert found.errors[0, 0] < 1e-6 * f / 0.2
    assert found.worst_mac == pytest.approx(1.0, abs=1e-12)
    # the crossing happens: at p + h (the x truss shorter, stiffer) the lowest mode is the y one
    moved = build_model(model.scene, overrides={"nodes.a.position": [-0.1 + 1e-4, 0.0]})
    shapes = natural_frequencies(moved).shapes
    assert abs(shapes[1, 0]) > abs(shapes[0, 0])


def test_track_takes_the_largest_mac_and_breaks_ties_in_order():
    eye = np.eye(2)
    assert track(eye, eye[:, ::-1], eye) == ([1, 0], [1.0, 1.0])
    # a degenerate pair: both candidates 0.5 to the first base mode, the first one wins
    both = np.array([[1.0, 1.0], [1.0, -1.0]]) / np.sqrt(2)
    assert track(eye, both, eye)[0] == [0, 1]


# -- the command line ------------------------------------------------------------------------

def test_cli_table_and_json(capsys):
    code, out, _ = run(capsys, "analyze", "stage_planar_3dof", "--modes", "3",
                       "--sensitivity", "sections.leaf.width", "sections.leaf.height")
    assert code == 0
    assert "d/dsections.leaf.width (per m)" in out and "d/dsections.leaf.height (per m)" in out
    assert "analytic" in out and "central difference ± " in out
    code, out, _ = run(capsys, "analyze", "stage_planar_3dof", "--modes", "3", "--json",
                       "--sensitivity", "sections.leaf.width")
    entry = json.loads(out)["sensitivity"]
    direct = sensitivities("stage_planar_3dof", ["sections.leaf.width"], modes=3,
                           outputs=False, stress=False, dc_gains=False)
    assert entry["quantities"] == direct.quantities
    np.testing.assert_allclose(entry["derivatives"], direct.derivatives, rtol=1e-12)
    assert entry["methods"] == [["analytic"]] * 3 and entry["key_units"] == ["m"]
    assert "frequency 1 (Hz)" in render_sensitivity(entry)


@pytest.mark.parametrize("key, says", [
    ("sections.leaf.heigth", "the scene gives no value for it"),
    ("sections.lef.height", "unknown section 'lef'"),
    ("nodes.3.position", "name one element, e.g. nodes.3.position[0]"),
    ("nodes.3.position[2]", "has 2 elements, so no element [2]"),
    ("elements.bar.type", "the value is str 'PLBEAM'"),
    ("nodes.3.dof", "the value is a list of 2, ['x', 'y']"),
])
def test_cli_refuses_a_key_naming_it(capsys, key, says):
    code, out, err = run(capsys, "analyze", "stage_planar_3dof", "--sensitivity", key)
    assert code == 2 and out == ""
    assert f"--sensitivity {key}: " in err and says in err


def test_api_refuses_before_any_analysis():
    with pytest.raises(SceneError, match=r"--sensitivity scene\.name: the value is str"):
        sensitivities("stage_planar_3dof", ["sections.leaf.width", "scene.name"])
