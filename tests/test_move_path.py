"""Move paths: loops' references from a move of other coordinates, and the loop that follows
them, checked against the single-axis move they generalise and the statics they come from."""

import numpy as np
import pytest

from flexure.controllers.feedback import ControlDesignError, DiscreteController, design_feedback
from flexure.controllers.feedforward import low_frequency_model
from flexure.controllers.loop_controller import LoopController
from flexure.controllers.move_path import MovePath, move_path
from flexure.controllers.profiles import ThirdOrderProfile
from flexure.core import load_scene, static_equilibrium


@pytest.mark.parametrize("kind", ["linear", "nonlinear"])
def test_moving_the_loops_own_output_is_that_output(stage, kind):
    path = move_path(stage, {"3.x": 1e-3}, kind=kind, points=5)
    np.testing.assert_allclose(path.displacement([0.0, 0.5, 1.0])[:, 0], [0.0, 0.5e-3, 1e-3],
                               atol=1e-12)


def test_the_nonlinear_paths_forces_are_its_statics(stage):
    path = move_path(stage, {"3.x": 1e-3}, kind="nonlinear", points=5)
    for s, force in zip(path.s, path.forces[:, 0], strict=True):
        x = static_equilibrium(stage, inputs={"F": force}).x[stage.coordinate_index("3.x")]
        assert x - stage.initial_coordinates[stage.coordinate_index("3.x")] == pytest.approx(
            s * 1e-3, abs=1e-10)


def _path_controller(model, path, *, fs=4000.0, duration=1.0, samples=4400):
    design = design_feedback(model, crossover=300.0, fs=fs)
    lf = low_frequency_model(model)
    offsets = [model.initial_coordinates[model.outputs[p.output_index].coordinate]
               for p in design.pairs]
    return design, lf, offsets, LoopController(
        DiscreteController(design.controller), ThirdOrderProfile(1.0, duration), fs=fs,
        samples=samples, offsets=offsets, feedforward=lf, path=path)


def test_a_straight_path_gives_the_single_axis_references_and_feedforward(stage):
    path = MovePath(np.array([0.0, 0.5, 1.0]), np.array([[0.0], [0.5e-3], [1e-3]]), None,
                    "linear", {"3.x": 1e-3})
    design, lf, offsets, along = _path_controller(stage, path)
    axis = LoopController(DiscreteController(design.controller), ThirdOrderProfile(1e-3, 1.0),
                          fs=4000.0, samples=4400, offsets=offsets, feedforward=lf)
    np.testing.assert_allclose(along.reference, axis.reference, rtol=0, atol=1e-15)
    # the exact interval means against 4-point Gauss quadrature of a piecewise cubic: they
    # differ only on the intervals across the profile's knots
    scale = np.max(np.abs(axis.feedforward))
    np.testing.assert_allclose(along.feedforward, axis.feedforward, rtol=0, atol=1e-9 * scale)


def test_a_path_controller_survives_its_dictionary(stage):
    path = move_path(stage, {"3.x": 1e-3}, kind="nonlinear", points=5)
    _, _, _, controller = _path_controller(stage, path)
    again = LoopController.from_dict(controller.to_dict())
    np.testing.assert_array_equal(again.reference, controller.reference)
    np.testing.assert_array_equal(again.feedforward, controller.feedforward)


@pytest.mark.parametrize("targets, options, match", [
    ({"3.x": 1e-3, "3.y": 0.0}, {}, "2 target"),
    ({"9.x": 1e-3}, {}, "move target.*9.x"),
    ({"3.x": 1e-3}, {"kind": "cubic"}, "kind must be one of"),
    ({"3.x": 1e-3}, {"points": 3}, "at least 4 points"),
])
def test_moves_that_do_not_fit_are_named(stage, targets, options, match):
    with pytest.raises(ControlDesignError, match=match):
        move_path(stage, targets, **options)


@pytest.fixture(scope="module")
def manipulator():
    return load_scene("manipulator_control")


def _translation(model, dx, dy):
    held = {"E.z": 0.0, "E_M1.z": 0.0, "E_M2.z": 0.0}
    return {"E.x": dx, "E.y": dy, "E_M1.x": dx} | held


@pytest.mark.slow
def test_the_manipulators_paths_agree_for_a_small_move_and_part_for_a_large_one(manipulator):
    small = _translation(manipulator, 1e-6, 0.0)
    linear = move_path(manipulator, small, kind="linear").displacement([1.0])[0]
    nonlinear = move_path(manipulator, small, kind="nonlinear", points=4).displacement([1.0])[0]
    np.testing.assert_allclose(nonlinear, linear, rtol=0, atol=1e-4 * np.abs(linear).max())
    # 4 mm along x: the y actuators move with the square of the stroke (0.2 mm, 50 times
    # the 0.1 % tracking target of the x actuators), which the linear path leaves out
    large = _translation(manipulator, 4e-3, 0.0)
    linear = move_path(manipulator, large, kind="linear").displacement([1.0])[0]
    nonlinear = move_path(manipulator, large, kind="nonlinear", points=4).displacement([1.0])[0]
    assert np.min(np.abs(nonlinear[1::2])) > 0.15e-3
    assert np.max(np.abs(linear[1::2])) < 0.1 * np.min(np.abs(nonlinear[1::2]))
