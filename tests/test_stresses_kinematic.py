"""Stresses along a motion driven by a kinematic input: the input's acceleration is given,
and what moves the input is a reaction of the structure.

A point mass m on a link of length L (a PLBEAM whose deformations are rigid, no mass of its
own) is turned about its pivot by the kinematic input A on the hinge's angle phi (from
hanging straight down). With phi, phi' and phi'' given, the link carries

    N = m (L phi'^2 + g cos phi)         (tension, along the link)
    M = m L (L phi'' + g sin phi)        (bending moment at the hinge; zero at the mass)

so at its ends the von Mises stress is N / A + |M| / W at the hinge and N / A at the mass
(A = b h, W = b h^2 / 6; `stresses.von_mises`). Evaluating the motion as if the hinge were
free (phi'' from the free pendulum) gives M = 0 instead.
"""

import numpy as np
import pytest
from fmpy_slave import Slave
from kinematic_scenes import turned_pendulum

from flexure.core import Simulator, build_model, scene_toml, stresses_along
from flexure.core.errors import UsageError
from flexure.fmu import build_scene_fmu

MASS, LENGTH, G = 0.5, 0.2, 9.81  # kg, m, m/s^2
WIDTH = HEIGHT = 0.01  # m
AREA, MODULUS = WIDTH * HEIGHT, WIDTH * HEIGHT**2 / 6  # m^2, m^3


def pendulum_data(**motion):
    data = turned_pendulum(MASS, LENGTH, G, name="turned", **motion)
    data["sections"]["link"] = {"E": 2e11, "width": WIDTH, "height": HEIGHT, "rho": 0.0}
    return data


def analytic(phi, rate, acceleration):
    """(hinge end, mass end) von Mises stresses, Pa (module docstring)."""
    tension = MASS * (LENGTH * rate**2 + G * np.cos(phi))
    moment = MASS * LENGTH * (LENGTH * acceleration + G * np.sin(phi))
    return tension / AREA + abs(moment) / MODULUS, tension / AREA


@pytest.fixture(scope="module")
def along_the_move():
    """States and the input's accelerations along a 0.1 s quintic from 0 to 0.5 rad."""
    model = build_model(pendulum_data(start=0.0, value=0.5))
    sim = Simulator(model, motion_duration=0.1, rtol=1e-9)
    sim.reset()
    times, states, moved = [0.0, 0.02, 0.05, 0.08, 0.1], [], []
    for t in times:
        sim.advance_to(t) if t > 0 else None
        u, rate, acceleration = sim.prescribed_values()
        states.append(np.concatenate([u, rate]))  # the state on the input's path
        moved.append(acceleration)
    return model, np.array(states), np.array(moved)


@pytest.mark.parametrize("compiled", [True, False])
def test_the_stresses_of_a_turned_pendulum_are_the_analytic_ones(along_the_move, compiled):
    """Through the engine's prescribed form and through numpy, within 1e-12 of the closed
    form (the link is rigid: measured 2e-15), at rest, accelerating, at full speed,
    braking and at rest at the end."""
    model, states, moved = along_the_move
    names, stresses = stresses_along(model, states, prescribed_accelerations=moved,
                                     compiled=compiled)
    assert names == ["link"]
    for state, acceleration, (hinge, mass) in zip(states, moved, stresses[:, 0], strict=True):
        expected = analytic(state[0], state[1], acceleration[0])
        np.testing.assert_allclose([hinge, mass], expected, rtol=1e-12)
    assert np.max(stresses[:, 0, 0]) > 10 * np.max(stresses[:, 0, 1])  # the bending counts


def test_a_model_with_kinematic_inputs_needs_their_accelerations(along_the_move):
    model, states, moved = along_the_move
    with pytest.raises(UsageError, match=r"'turned' has kinematic inputs \(A\): give their "
                                         r"accelerations at each state"):
        stresses_along(model, states)
    with pytest.raises(UsageError, match=r"must be 5 rows \(one per state\) of 1 finite "
                                         r"values \(A\); got shape \(4, 1\)"):
        stresses_along(model, states, prescribed_accelerations=moved[:4])
    bad = moved.copy()
    bad[2, 0] = np.nan
    with pytest.raises(UsageError, match="finite values"):
        stresses_along(model, states, prescribed_accelerations=bad)
    free = build_model({**pendulum_data(), "inputs": {}} | {
        "nodes": {**pendulum_data()["nodes"], "hinge": {"angle": 0.0, "dof": ["phi"]}}})
    with pytest.raises(UsageError, match="'turned' has no kinematic inputs"):
        stresses_along(free, np.zeros((1, 2)), prescribed_accelerations=[[]])


def test_a_motion_fmu_reports_the_stress_that_holds_the_turned_pendulum(tmp_path):
    """The FMU's von_mises_max with its angle input set to 0.8 rad in the first 1 ms step and
    held for four more (at rest after them): the hinge's N / A + M / W of the static
    pendulum at 0.8 rad, M = m g L sin 0.8."""
    scene = tmp_path / "turned.toml"
    scene.write_text(scene_toml(pendulum_data(), "a pendulum turned at its pivot"))
    slave = Slave(build_scene_fmu(scene, tmp_path / "turned.fmu", von_mises=True))
    try:
        for k in range(5):
            slave.fmu.setReal([slave.vr["A"]], [0.8])
            outputs = slave.step(k * 1e-3, 1e-3)
        stress = outputs[slave.outputs.index("von_mises_max")]
    finally:
        slave.close()
    assert stress == pytest.approx(analytic(0.8, 0.0, 0.0)[0], rel=1e-12)  # 2e-16
