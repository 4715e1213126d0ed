"""Plot axes that do not magnify round-off (core/reporting/axes.py)."""

import numpy as np
import pytest
from matplotlib.figure import Figure

from flexure.core.reporting.axes import ROUND_OFF, hold_round_off, unit_scales


def axes():
    return Figure().subplots()


def test_an_output_still_to_round_off_is_drawn_flat():
    """A held coordinate wandering by 3e-20 m beside a 0.05 m one: its axis spans
    +-ROUND_OFF x 0.05 m around it, not the 3e-20 m of its wandering."""
    ax = axes()
    held = np.linspace(0.0, 3e-20, 50)
    ax.plot(held)
    assert hold_round_off(ax, held, 0.05)
    low, high = ax.get_ylim()
    assert high - low == pytest.approx(2 * ROUND_OFF * 0.05, rel=1e-9)
    assert low < 0.0 < 3e-20 < high


def test_a_real_motion_keeps_its_own_scale():
    """A nanometre on a 0.05 m model is motion, not round-off (ROUND_OFF x 0.05 m = 5e-14 m)."""
    ax = axes()
    moving = np.linspace(0.0, 1e-9, 50)
    ax.plot(moving)
    before = ax.get_ylim()
    assert not hold_round_off(ax, moving, 0.05)
    assert ax.get_ylim() == before


def test_each_unit_has_its_own_scale_and_an_angle_at_least_one_radian():
    values = np.array([[0.0, 0.05, 1e-17], [6e-4, 0.04999, 0.0]])
    assert unit_scales(values, ["m", "m", "rad"]) == {"m": 0.05, "rad": 1.0}


def test_a_simulation_plot_draws_held_outputs_flat(tmp_path):
    """The tripod pushed along x: y and rz stay put to round-off; their axes say so."""
    from flexure.core import load_scene, simulate

    result = simulate(load_scene("wire_tripod"), 0.02, inputs={"F": 1.0})
    assert np.ptp(result.output_array[:, 1]) < 1e-15  # y: round-off only
    result.plot(tmp_path / "step.png")
    assert (tmp_path / "step.png").stat().st_size > 10_000
