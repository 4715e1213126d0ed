"""The feedforward from the nonlinear inverse dynamics (controllers/dynamic_feedforward.py)
and given feedforward forces in the loop (`run_loop(feedforward_forces=...)`)."""

import numpy as np
import pytest

from flexure.controllers.dynamic_feedforward import dynamic_feedforward, move_inverse_dynamics
from flexure.controllers.errors import LoopError
from flexure.controllers.feedback import ControlDesignError
from flexure.controllers.profiles import ThirdOrderProfile
from flexure.controllers.runner import run_loop
from flexure.core import load_scene, static_equilibrium

STROKE, DURATION, SETTLE, FS, STEP = 1e-5, 0.05, 0.01, 4000.0, 1e-3


@pytest.fixture(scope="module")
def stage():
    return load_scene("stage_planar_3dof")


@pytest.fixture(scope="module")
def feedforward(stage):
    return dynamic_feedforward(stage, {"3.x": STROKE}, duration=DURATION, settle=SETTLE,
                               fs=FS, step=STEP)


def test_the_reference_is_the_move_and_the_forces_are_interval_means(stage, feedforward):
    """The loop's output is the target (3.x), and the move is a cubic between the profile's
    knots, which are steps' ends: the cubic through each step's nodes is the move itself, at
    every sample to 1e-15 m. Each held force is the mean of the forces' piecewise cubic over
    its sample interval (a midpoint sum of 2000 points, to 1e-6 of the largest: the sum's
    own error, (1/2000)^2 / 24 of the second derivative's)."""
    x0 = static_equilibrium(stage).x[stage.coordinate_index("3.x")]
    k = np.arange(feedforward.reference.shape[0])
    move = x0 + STROKE * ThirdOrderProfile(1.0, DURATION).position(k / FS)
    np.testing.assert_allclose(feedforward.reference[:, 0], move, rtol=0, atol=1e-15)
    polynomial = feedforward.inverse.force_polynomial()
    fraction = (np.arange(2000) + 0.5) / 2000
    means = [np.mean(polynomial((j + fraction) / FS)[:, 0])
             for j in range(feedforward.forces.shape[0])]
    scale = np.max(np.abs(feedforward.forces))
    np.testing.assert_allclose(feedforward.forces[:, 0], means, rtol=0, atol=1e-6 * scale)


def test_the_steps_end_on_the_profiles_knots(feedforward):
    """step 1 ms into duration / 8 = 6.25 ms: seven steps of 0.893 ms, every knot of the
    profile (multiples of duration / 8) a step's end to 1e-15 s, to past the last sample."""
    times = feedforward.inverse.times
    np.testing.assert_allclose(np.diff(times), DURATION / 8 / 7, rtol=1e-12)
    for knot in DURATION / 8 * np.arange(9):
        assert np.min(np.abs(times - knot)) < 1e-15
    assert times[-1] >= (feedforward.forces.shape[0]) / FS


def test_the_given_forces_do_the_loops_work(stage, feedforward):
    """In the loop on the nonlinear stage, the inverse dynamics' forces leave the loop's
    error below 0.1 % of its error with feedback alone (measured: 0.014 %; BDF2's forces
    left 0.13 %)."""
    runs = [run_loop(stage, reference=feedforward.reference, feedforward_forces=forces, fs=FS)
            for forces in (feedforward.forces, np.zeros_like(feedforward.forces))]
    errors = [np.max(np.abs(run.position - run.reference)) for run in runs]
    assert runs[0].settings["feedforward_kind"] == "given"
    assert errors[0] < 1e-3 * errors[1]


@pytest.mark.parametrize("call, error, words", [
    (lambda m: dynamic_feedforward(m, {"3.x": 1e-5, "3.y": 0.0}), ControlDesignError,
     "2 target"),
    (lambda m: dynamic_feedforward(m, {"9.q": 1e-5}), ControlDesignError, "move target"),
    (lambda m: dynamic_feedforward(m, {"3.x": 1e-5}, duration=0.0), ControlDesignError,
     "duration must be"),
    (lambda m: dynamic_feedforward(m, {"3.x": 1e-5}, step=np.nan), ControlDesignError,
     "step must be"),
    (lambda m: dynamic_feedforward(m, {"3.x": 1e-5}, settle=-1.0), ControlDesignError,
     "settle must be"),
    (lambda m: dynamic_feedforward(m, {"3.x": 1e-5}, fs=0.0), ControlDesignError,
     "fs must be"),
    (lambda m: move_inverse_dynamics(m, {"3.x": 1e-5}, end=-0.1), ControlDesignError,
     "end must be"),
    (lambda m: run_loop(m, reference=np.zeros(5), feedforward_forces=np.zeros((5, 1)),
                        fs=FS), LoopError, r"expected finite forces of shape \(6, 1\)"),
])
def test_bad_settings_are_refused(stage, call, error, words):
    with pytest.raises(error, match=words):
        call(stage)
