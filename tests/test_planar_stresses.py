"""Stresses of planar scenes against hand calculations: the leaf-spring stage's clamped-guided
leaves under a lateral force (sigma = N/A + M/W), a truss under axial load (N/A), the plot
and the units of `flexure analyze --json`."""

import json

import numpy as np
import pytest

from flexure.core import beam_stresses, build_model, load_scene, static_equilibrium
from flexure.core.cli import main

WIDTH, HEIGHT, E = 0.018, 0.0005, 2.1e11  # m, m, Pa: stage_planar_1dof's leaves
L, D = 0.1, 0.1  # m: leaf length, distance between the leaves
A, W, EI = WIDTH * HEIGHT, WIDTH * HEIGHT**2 / 6, E * WIDTH * HEIGHT**3 / 12


def stage_stresses(force):
    model = load_scene("stage_planar_1dof", overrides={"nodes.3.force": [force, 0.0]})
    solution = static_equilibrium(model)
    return beam_stresses(model, solution.x, solution.stress_resultants)


def hand_stress(force, normal_share=0.0):
    """Root stress of a leaf: two clamped-guided leaves share F, so each carries F/2 and the
    moment F L / 4 at both ends; the overturning moment F L less the four end moments F L / 2
    is carried by a couple of normal forces N = F L / (2 D) in the leaves. A normal force in
    a deflected leaf changes its end moments: M = F L / 4 - N delta / 10 (clamped-guided
    beam-column to first order in N, delta = F L^3 / (24 EI); +N in tension), which
    `normal_share` = +1 (tension) or -1 (compression) adds."""
    normal = force * L / (2 * D)
    delta = force * L**3 / (24 * EI)
    moment = force * L / 4 + normal_share * normal * delta / 10
    return normal / A + moment / W


def test_stage_leaf_root_stress_in_the_linear_range():
    """At 0.01 N the normal force's share of the moment is 2.1e-5 of it (N delta / 10 against
    F L / 4 scales with F): every leaf end to 1e-4 of the hand value N/A + F L / (4 W)."""
    stresses = stage_stresses(0.01)
    assert stresses.names == ["leaf_left", "leaf_right"]
    np.testing.assert_allclose(stresses.von_mises, hand_stress(0.01), rtol=1e-4)


def test_stage_leaf_root_stress_at_1_newton():
    """At 1 N: N/A = 0.056 MPa (1.7e-3 of the 33.3 MPa) is in the hand value; the normal
    force's share of the moment, N delta / 10 = 2.1e-3 of F L / 4, raises the left (tension)
    leaf and lowers the right one. With it each leaf to 1e-3 (what is left is of the order
    (delta / L)^2 = 1e-4: the deflection and the parasitic drop); without it the mean of
    both leaves to 1e-4, as the shares cancel. The stress is the same at both ends."""
    stresses = stage_stresses(1.0)
    left, right = stresses.von_mises
    np.testing.assert_allclose(left, hand_stress(1.0, +1.0), rtol=1e-3)
    np.testing.assert_allclose(right, hand_stress(1.0, -1.0), rtol=1e-3)
    np.testing.assert_allclose((left + right) / 2, hand_stress(1.0), rtol=1e-4)
    assert left[0] == pytest.approx(left[1], rel=1e-9)
    assert stresses.maximum()[0] == "leaf_left"
    # mid-leaf only N/A: the moment passes through zero there
    assert stresses.along[0][5] == pytest.approx(L / (2 * D) / A, rel=1e-4)


def test_truss_stress_is_normal_force_over_area():
    """A PLTRUSS of 2 mm x 1 mm pulled by 3 N: sigma = N / A = 1.5 MPa, N from statics
    (to the equilibrium's Newton tolerance, 1e-11 of the length)."""
    model = build_model({
        "scene": {"name": "bar", "dimension": 2},
        "sections": {"s": {"E": 7e10, "width": 0.002, "height": 0.001}},
        "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "2": {"position": [0.0, 0.5], "fixed": ["x"], "dof": ["y"],
                        "force": [0.0, 3.0]}},
        "elements": {"bar": {"type": "PLTRUSS", "nodes": ["1", "2"], "section": "s",
                             "released": ["e1"]}}})
    solution = static_equilibrium(model)
    stresses = beam_stresses(model, solution.x, solution.stress_resultants)
    np.testing.assert_allclose(stresses.von_mises, [[3.0 / 2e-6, 3.0 / 2e-6]], rtol=1e-9)
    np.testing.assert_allclose(stresses.along[0], 3.0 / 2e-6, rtol=1e-9)


def test_planar_plot_and_units_in_json(tmp_path, capsys):
    plot = tmp_path / "stresses.png"
    assert main(["analyze", "stage_planar_1dof", "--static", "--plot", str(plot), "--set",
                 "nodes.3.force=[1.0, 0.0]", "--json"]) == 0
    static = json.loads(capsys.readouterr().out)["static"]
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert static["units"]["von_mises_pa"] == "Pa"
    assert "divided by l0" in static["units"]["stress_resultants"]
    # the bending resultant times l0 is the end moment F L / 4 (to the normal force's share)
    moment = static["stress_resultants"]["leaf_left.e2"] * L
    assert moment == pytest.approx(L / 4, rel=3e-3)
    assert static["von_mises_pa"]["leaf_left"][0] == pytest.approx(hand_stress(1.0, 1.0),
                                                                   rel=1e-3)
