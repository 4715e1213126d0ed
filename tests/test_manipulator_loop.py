"""The six-actuator loop of the manipulator (examples/manipulator_loop.py), as a user runs it."""

import numpy as np
import pytest

from examples import manipulator_loop


@pytest.mark.slow
def test_the_loops_hold_on_every_model_and_the_linear_strokes_miss_quadratically(capsys):
    design, rows = manipulator_loop.robustness()
    assert [row.states for row in rows] == [12, 150, 1014]
    for row in rows:
        assert row.stable
        assert np.all(row.closed_margins[:, 1] > 35.0)  # degrees, the other loops closed
        assert row.sensitivity_peak < 2.0
    moves = {row["move"]: row for row in manipulator_loop.moves(
        manipulator_loop.load_scene(manipulator_loop.CONTROL))}
    # the end effector's height on the linear strokes misses by the square of the stroke
    ratio = moves["4 mm x"]["position_error"][2] / moves["1 mm x"]["position_error"][2]
    assert ratio == pytest.approx(16.0, rel=0.05)
    assert abs(moves["6 mm x"]["position_error"][2]) > 0.2  # mm: 0.29 mm at 6 mm
    manipulator_loop.print_moves(list(moves.values()))
    assert "6 mm xy" in capsys.readouterr().out


@pytest.mark.slow
def test_the_six_mm_xy_move_tracks_within_the_target_on_every_actuator(tmp_path):
    design, _ = manipulator_loop.robustness()
    result = manipulator_loop.closed_loop(design, tmp_path)
    rows = result.per_loop()
    assert len(rows) == 6
    assert all(row["error_ratio"] < 1e-3 for row in rows)
    assert (tmp_path / "manipulator_loop.png").stat().st_size > 10_000
