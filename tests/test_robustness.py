"""Robust stability: the fast frequency response, the loops with the others closed and the
MIMO sensitivity, against python-control's own computations."""

import control
import numpy as np
import pytest

from flexure.controllers.feedback import colocated_pairs, design_feedback
from flexure.controllers.feedforward import low_frequency_model
from flexure.controllers.robustness import (
    check_robustness,
    delay_block,
    frequency_response,
    loop_response,
    others_closed,
    siso_margins,
)
from flexure.controllers.spline import cubic_pieces, roots_within
from flexure.core import load_scene, state_space


def _random_plant(seed, states=8, loops=2, dt=1e-3):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(states, states))
    A *= 0.9 / np.max(np.abs(np.linalg.eigvals(A)))  # stable
    return control.ss(A, rng.normal(size=(states, loops)), rng.normal(size=(loops, states)),
                      np.zeros((loops, loops)), dt)


def test_the_frequency_response_is_python_controls():
    plant = _random_plant(1)
    omega = np.geomspace(1.0, np.pi / plant.dt * 0.99, 50)
    expected = np.stack([plant(np.exp(1j * w * plant.dt)) for w in omega], axis=2)
    np.testing.assert_allclose(frequency_response(plant, omega), expected, rtol=1e-10,
                               atol=1e-12)


def test_a_defective_system_falls_back_to_the_solves():
    chain = control.ss(control.tf([1], [1, 0, 0, 0], 1e-3))  # a triple pole at z = 0
    omega = np.array([10.0, 100.0, 1000.0])
    expected = np.array([chain(np.exp(1j * w * 1e-3)) for w in omega]).reshape(1, 1, -1)
    np.testing.assert_allclose(frequency_response(chain, omega), expected, rtol=1e-10)


def test_a_loop_with_the_other_closed_is_the_loop_around_the_closed_plant():
    plant = _random_plant(2)
    gains = [0.3, -0.2]
    controller = control.append(*[control.ss([], [], [], [[g]], plant.dt) for g in gains])
    omega = np.geomspace(1.0, 3000.0, 40)
    L = loop_response(plant, controller, 1, omega)
    # independently: close loop 2 around the plant with its delay, then loop 1's return ratio
    delay = control.ss(control.tf([1], [1, 0], plant.dt))
    k2 = gains[1] * delay
    closed = control.feedback(plant, control.append(control.ss([], [], [], [[0.0]], plant.dt),
                                                    k2))
    p11 = control.ss(closed.A, closed.B[:, [0]], closed.C[[0], :], closed.D[[0], [0]],
                     plant.dt)
    expected = np.array([complex(p11(np.exp(1j * w * plant.dt))) * gains[0]
                         * np.exp(-1j * w * plant.dt) for w in omega])
    np.testing.assert_allclose(others_closed(L, 0), expected, rtol=1e-9)


# (seed, gain, loop 1 alone or with loop 2 closed): random plants' loop gains with two or
# more crossings of |L| = 1 and of the negative real axis and two or more local minima of
# |1 + L|, so that the choice among them is tested too
MARGIN_CASES = [(7, 0.3, True), (8, 0.3, True), (11, 0.3, False), (11, 1.0, False)]


@pytest.mark.parametrize(("seed", "gain", "others_closed_too"), MARGIN_CASES)
def test_the_margins_are_python_controls_frd_margins(seed, gain, others_closed_too):
    """The same gain, phase and modulus margins and cross-over as python-control's 'frd'
    method on the same response (both refine on the cubic spline through it)."""
    plant = _random_plant(seed, states=10)
    omega = np.geomspace(0.5, np.pi / plant.dt * 0.999, 400)
    controller = control.append(*[control.ss([], [], [], [[gain]], plant.dt)] * 2)
    L = loop_response(plant, controller, 1, omega)
    response = others_closed(L, 1) if others_closed_too else L[0, 0]
    frd = control.frd(response, omega, dt=plant.dt)
    crossings = control.stability_margins(frd, method="frd", returnall=True)[:3]
    assert min(len(c) for c in crossings) >= 2  # several of each to choose from
    gm, pm, sm, _, wc, _ = control.stability_margins(frd, method="frd")
    ours = siso_margins(response, omega, with_crossover=True)
    # python-control's Brent iterations stop at 2e-12 rad/s (roots) and 1.5e-8 relative
    # (minima, where |1 + L| is flat to second order); ours are exact on the interpolant:
    # 4e-13 apart at most on these cases
    np.testing.assert_allclose(ours, [gm, pm, sm, wc], rtol=1e-11)


def test_the_spline_pieces_are_scipys_not_a_knot_cubic_spline():
    """The interpolant the margins are refined on, against scipy's CubicSpline (not-a-knot)
    on an uneven grid of complex samples, to 1e-12 of the largest coefficient of each
    power; and the roots of a piece in its interval."""
    from scipy.interpolate import CubicSpline

    rng = np.random.default_rng(3)
    x = np.cumsum(rng.uniform(0.1, 2.0, 40))
    y = rng.normal(size=40) + 1j * rng.normal(size=40)
    ours, theirs = cubic_pieces(x, y), CubicSpline(x, y).c.T
    for power in range(4):
        np.testing.assert_allclose(ours[:, power], theirs[:, power], rtol=0,
                                   atol=1e-12 * np.max(np.abs(theirs[:, power])))
    # (t - 0.25)(t - 0.5)(t - 3): two roots in [0, 1], the third outside
    np.testing.assert_allclose(roots_within(np.poly([0.25, 0.5, 3.0]), 1.0), [0.25, 0.5],
                               rtol=1e-14)
    assert roots_within([1.0, 0.0, 1.0], 1.0).size == 0  # t^2 + 1: no real root


def test_a_loop_that_never_crosses_has_infinite_margins():
    """|L| < 1 everywhere and never on the negative real axis: python-control's answer,
    infinite gain and phase margins and no cross-over."""
    omega = np.geomspace(1.0, 3000.0, 200)
    response = 0.5 / (1.0 + 1j * omega / 100.0)  # a first-order lag, gain 0.5
    gm, pm, sm, wc = siso_margins(response, omega, with_crossover=True)
    expected = control.stability_margins(control.frd(response, omega, dt=1e-3), method="frd")
    assert gm == expected[0] == np.inf and pm == expected[1] == np.inf and np.isnan(wc)
    assert sm == pytest.approx(expected[2], rel=1e-9)


def test_one_loop_has_one_set_of_margins_and_its_sensitivity_peak_is_one_over_the_modulus():
    model = load_scene("stage_planar_1dof")
    design = design_feedback(model)
    robust = design.robustness
    np.testing.assert_array_equal(robust.open_margins, robust.closed_margins)
    assert robust.sensitivity_peak == pytest.approx(1.0 / design.modulus_margin, rel=1e-6)
    assert robust.stable and robust.spectral_radius == pytest.approx(design.spectral_radius)


def test_a_plant_sampled_at_the_loops_period_is_checked_as_its_continuous_one():
    """The designer hands its sampled plant over: the same report as from the continuous
    plant (sampled with a zero-order hold inside), and another period is refused."""
    model = load_scene("stage_planar_3dof")
    design = design_feedback(model)
    pairs = colocated_pairs(model)
    plant = state_space(model)[[p.output_index for p in pairs], [p.input_index for p in pairs]]
    dt = 1.0 / design.sample_rate_hz
    continuous = check_robustness(design, plant)
    sampled = check_robustness(design, control.c2d(plant, dt, method="zoh"))
    for field in ("open_margins", "closed_margins", "closed_loop_poles", "crossovers_rad_s"):
        np.testing.assert_array_equal(getattr(sampled, field), getattr(continuous, field))
    assert sampled.sensitivity_peak == continuous.sensitivity_peak
    np.testing.assert_array_equal(design.robustness.open_margins, continuous.open_margins)
    with pytest.raises(ValueError, match="needs the loops' sample period 0.00025 s, got 0.001"):
        check_robustness(design, control.c2d(plant, 1e-3, method="zoh"))


def test_a_zero_delay_block_is_the_identity():
    block = delay_block(3, 0, 1e-3)
    np.testing.assert_array_equal(block.D, np.eye(3))
    with pytest.raises(ValueError, match="delay_samples"):
        delay_block(2, -1, 1e-3)


@pytest.mark.slow
def test_the_manipulator_designed_on_its_six_modes_holds_with_its_parasitic_ones():
    model = load_scene("manipulator_control")
    lf = low_frequency_model(model)
    design = design_feedback(model, plant=lf.state_space())
    pairs = colocated_pairs(model)
    plant = state_space(model)[[p.output_index for p in pairs], [p.input_index for p in pairs]]
    robust = check_robustness(design, plant, name=model.name)
    assert robust.states == 2 * model.ndof
    assert robust.stable
    # with the others closed every loop keeps 35 degrees and a modulus margin of 0.5
    assert np.all(robust.closed_margins[:, 1] > 35.0)
    assert np.all(robust.closed_margins[:, 2] > 0.5)
    assert robust.sensitivity_peak < 2.0


@pytest.mark.slow
def test_a_multi_loop_summary_gives_the_margins_with_the_other_loops_closed():
    model = load_scene("manipulator_control")
    design = design_feedback(model)
    summary = design.summary()
    closed = design.robustness.closed_margins
    assert summary["phase_margin_others_closed_deg"] == closed[:, 1].min()
    assert summary["modulus_margin_others_closed"] == closed[:, 2].min()
    assert summary["sensitivity_peak"] == design.robustness.sensitivity_peak
    assert summary["phase_margin_others_closed_deg"] > summary["phase_margin_deg"]
    assert "phase_margin_others_closed_deg" not in design_feedback(
        load_scene("stage_planar_1dof")).summary()
