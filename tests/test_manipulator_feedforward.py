"""The manipulator's feedforward from the nonlinear inverse dynamics against the linear one
(examples/manipulator_feedforward.py), in its quick variant: 1 mm along x in 0.1 s, the
inverse dynamics at 2.5 ms (the documented run: 1 s moves at 5 ms, docs/manipulator.md); and
the forward check on the first 0.2 s of the 4 mm x move in 1 s."""

import numpy as np
import pytest

from examples import manipulator_feedforward


@pytest.mark.slow
def test_the_quick_comparison(capsys):
    """In the six loops on the nonlinear control model, the linear feedforward leaves the
    end effector at least 100 times further off its path than the inverse dynamics' does
    (measured 739; 7.5 with BDF2's forces) and turned at least 300 times more (measured
    1674; 68 with BDF2's); the forces replayed in `simulate` give the loop's encoders within
    20 nm (measured 6.4 nm: the loop's own esdirk2 at rtol 1e-5)."""
    results, _ = manipulator_feedforward.main(["--quick", "--no-figure"])
    _, rows = results["1 mm x"]
    worst = manipulator_feedforward.summary(rows)
    assert np.max(worst["linear"][:3]) > 100 * np.max(worst["dynamic"][:3])
    assert np.max(worst["linear"][3:]) > 300 * np.max(worst["dynamic"][3:])
    assert all(row["replay"] < 20e-9 for row in rows.values())
    assert "| 1 mm x | 1 | dynamic |" in capsys.readouterr().out


@pytest.mark.slow
def test_the_forces_drive_the_model_along_the_path_within_the_integrators_tolerance():
    """The forward check: the inverse dynamics' forces (Radau IIA at 1.25 ms, its Newton to
    1e-14 of the DOFs' unit, the piecewise cubic between the steps) alone drive the 75-DOF
    model in `simulate` (CVODE BDF) over the first 0.2 s of the 4 mm x move in 1 s (a jerk
    step at 0 and one at 0.125 s; the fast unstable zeros at 3.1e5 1/s on their bounded
    branch). At rtol 1e-8 the end effector's largest deviation from the path is within 1.5
    times the run's own error (its difference from the run at rtol 1e-11), in position and
    in rotation (measured 0.96 and 0.86 times: 0.036 nm and 0.23 nrad), and the run at 1e-11
    deviates by less than 0.75 times that error (measured 0.15 and 0.39): what is left is
    the integrator's, not the inverse dynamics'."""
    model = manipulator_feedforward.control_model()
    row = manipulator_feedforward.forward_check(
        model, manipulator_feedforward.MOVES["4 mm x"], duration=1.0, window=0.2,
        steps=(1.25e-3,))[1.25e-3]
    for part in (0, 1):  # position, rotation
        assert row["path"][part] < 1.5 * row["own"][part], row
        assert row["tight"][part] < 0.75 * row["own"][part], row
