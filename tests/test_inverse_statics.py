"""Inverse statics: the forces that hold coordinates, checked by the forward statics they
invert and by the compliance for small displacements."""

import numpy as np
import pytest

from flexure.core import (
    ConvergenceError,
    compliance,
    inverse_statics,
    load_scene,
    static_equilibrium,
)
from flexure.core.analysis.inverse_statics import InverseStaticsError


def test_a_small_displacement_takes_the_force_the_compliance_says(stage):
    x0 = stage.initial_coordinates[stage.coordinate_index("3.x")]
    d = 1e-7  # m: far inside the linear range of the 1 mm stage
    result = inverse_statics(stage, {"3.x": x0 + d})
    c_xx = compliance(stage, "3").matrix[0, 0]  # m/N
    assert result.forces[0] == pytest.approx(d / c_xx, rel=1e-6)
    assert result.residual <= 1e-10


def test_the_forward_statics_of_the_forces_puts_the_target_where_asked(stage):
    x0 = stage.initial_coordinates[stage.coordinate_index("3.x")]
    target = x0 + 2e-3  # m: twice the stroke, where the leaf springs stiffen
    result = inverse_statics(stage, {"3.x": target})
    forward = static_equilibrium(stage, inputs={"F": result.forces[0]})
    assert forward.x[stage.coordinate_index("3.x")] == pytest.approx(target, abs=1e-10)
    assert result.coordinate("3.x") == pytest.approx(target, abs=1e-10)
    # the stage stiffens: the force for 2 mm exceeds twice the small-motion stiffness times 1 mm
    small = inverse_statics(stage, {"3.x": x0 + 1e-6}).forces[0] / 1e-6
    assert result.forces[0] > small * 2e-3


def test_a_warm_start_along_a_path_gives_the_same_forces(stage):
    x0 = stage.initial_coordinates[stage.coordinate_index("3.x")]
    first = inverse_statics(stage, {"3.x": x0 + 0.9e-3})
    cold = inverse_statics(stage, {"3.x": x0 + 1e-3})
    warm = inverse_statics(stage, {"3.x": x0 + 1e-3}, start=first)
    assert warm.forces[0] == pytest.approx(cold.forces[0], rel=1e-9)
    assert warm.iterations <= cold.iterations


@pytest.mark.parametrize("targets, inputs, match", [
    ({"3.x": 0.0}, ["G"], "no input named G"),
    ({"3.x": 0.0, "3.y": 0.0}, None, "2 target.* for 1 input"),
    ({"9.x": 0.0}, None, "target.*9.x"),
    ({"3.x": float("nan")}, None, "finite"),
])
def test_targets_and_inputs_that_do_not_fit_are_named(stage, targets, inputs, match):
    with pytest.raises(InverseStaticsError, match=match):
        inverse_statics(stage, targets, inputs=inputs)


def test_a_target_the_input_cannot_move_is_refused(stage):
    # the stage's guided node moves along x only: its rotation does not follow the force
    with pytest.raises(ConvergenceError, match="cannot move the targets"):
        inverse_statics(stage, {"3.y": 1e-3})


def test_the_initial_forces_must_match_the_inputs(stage):
    with pytest.raises(InverseStaticsError, match="expected 1 forces"):
        inverse_statics(stage, {"3.x": 0.0}, initial=[1.0, 2.0])


@pytest.mark.slow
def test_the_manipulators_end_effector_goes_where_asked():
    model = load_scene("manipulator_control")
    x = model.initial_coordinates
    held = ("E.z", "E_M1.z", "E_M2.z")
    targets = {"E.x": x[model.coordinate_index("E.x")] + 1e-3,
               "E.y": x[model.coordinate_index("E.y")],
               "E_M1.x": x[model.coordinate_index("E_M1.x")] + 1e-3}
    targets |= {name: x[model.coordinate_index(name)] for name in held}
    result = inverse_statics(model, targets)
    forward = static_equilibrium(model, inputs=result.forces)
    for name, value in targets.items():
        assert forward.x[model.coordinate_index(name)] == pytest.approx(value, abs=1e-9)
    # a pure translation along x: the x actuators move about 1 mm, the y ones far less
    moved = np.array([result.coordinate(f"g{k}_H.{'x' if k % 2 else 'y'}")
                      - x[model.coordinate_index(f"g{k}_H.{'x' if k % 2 else 'y'}")]
                      for k in range(1, 7)])
    np.testing.assert_allclose(moved[::2], 1e-3, rtol=2e-3)
    assert np.all(np.abs(moved[1::2]) < 0.03e-3)


def test_an_actuated_input_is_found_as_its_drive_signal():
    import tomllib

    from flexure.core import build_model, scene_path

    data = tomllib.loads(scene_path("stage_planar_1dof").read_text())
    data["actuators"] = {"VCM": {"input": "F", "force_constant": 5.0, "resistance": 2.0,
                                 "inductance": 1e-3, "amplifier_gain": 2.0}}
    model = build_model(data)
    x0 = model.initial_coordinates[model.coordinate_index("3.x")]
    plain = inverse_statics(load_scene("stage_planar_1dof"), {"3.x": x0 + 1e-3})
    driven = inverse_statics(model, {"3.x": x0 + 1e-3})
    # the steady coil force Km G u / R equals the plain stage's force
    assert driven.forces[0] * 5.0 * 2.0 / 2.0 == pytest.approx(plain.forces[0], rel=1e-9)
    forward = static_equilibrium(model, inputs={"F": driven.forces[0]})
    assert forward.x[model.coordinate_index("3.x")] == pytest.approx(x0 + 1e-3, abs=1e-10)
