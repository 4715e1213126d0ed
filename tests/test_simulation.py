"""Nonlinear time-domain simulation against analytic solutions and independent computations.

Scenes: truss_1dof_x (a linear mass-spring-damper), stage_planar_1dof / _3dof (leaf-spring
stages), and two pendulums built here from dicts.
"""

import pickle
import tomllib

import numpy as np
import pytest
import scipy.special

from examples.energy_drift import modal_release
from flexure.core import (
    Simulator,
    build_model,
    load_scene,
    scene_path,
    simulate,
    static_equilibrium,
)
from flexure.core.mechanics.energy import mechanical_energy


def scene_dict(name):
    return tomllib.loads(scene_path(name).read_text())


def undamped(name):
    data = scene_dict(name)
    for section in data["sections"].values():
        section.pop("EdA", None)
        section.pop("EdI", None)
    return build_model(data, source=f"{name} (undamped)")


def pendulum(length=0.5, mass=2.0):
    """A rigid pendulum: a PLBEAM with all deformations prescribed zero, the angle of its
    hinge node the DOF (a coordinate DOF of a truss would be singular at 90 degrees or at
    the bottom), a point mass at its end, gravity."""
    return build_model({
        "scene": {"name": "pendulum", "gravity": [0.0, -9.81]},
        "sections": {"rod": {"EA": 1.0}},
        "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "2": {"angle": 0.0, "dof": ["phi"]},
                  "3": {"position": [length, 0.0], "mass": mass},
                  "4": {"angle": 0.0}},
        "elements": {"rod": {"type": "PLBEAM", "nodes": ["1", "2", "3", "4"],
                             "section": "rod"}},
        "outputs": {"phi": {"node": "2", "coordinate": "phi"},
                    "y": {"node": "3", "coordinate": "y"}},
    })


# -- accuracy --------------------------------------------------------------------------------
@pytest.mark.parametrize("method", ["cvode-bdf", "cvode-adams"])
@pytest.mark.parametrize("rtol", [1e-6, 1e-8])
def test_linear_one_dof_step_response_matches_the_analytic_solution(method, rtol):
    """Over one period of the step response, the error stays within 10 rtol of the solution
    (the DOF is the absolute x of the mass, about 0.1 m: the magnitude rtol applies to)."""
    model = load_scene("truss_1dof_x")  # its scene load: 1 N sideways from t = 0
    m = 0.206 + 0.1413 * 0.1 / 3.0
    k, c, force = 94.5 / 0.1, 0.0036494 / 0.1, 1.0
    wn = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - zeta**2)
    period = 2 * np.pi / wd
    times = np.linspace(0.0, period, 101)
    result = simulate(model, period, method=method, rtol=rtol, output_times=times)
    exact = 0.1 + force / k * (1 - np.exp(-zeta * wn * times) * (
        np.cos(wd * times) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * times)))
    error = np.max(np.abs(result.outputs["x"] - exact))
    assert error <= 10 * rtol * np.max(np.abs(exact))
    assert np.max(exact) - 0.1 > 2e-3  # the step response overshoots to twice 1/k


def test_undamped_3dof_stage_conserves_energy():
    """Free vibration at rtol 1e-9: the relative energy drift stays below 1e-8 (2.4e-10
    measured with the deviation state). The test runs 0.5 s (CPU time);
    examples/energy_drift.py runs the full 10 s against its target, a drift below 1e-6."""
    model = undamped("stage_planar_3dof")
    q0 = modal_release(model)  # the example's release: vibrates in the first mode
    sim = Simulator(model, method="cvode-adams", rtol=1e-9)
    sim.reset(q0=q0)
    e0 = mechanical_energy(model, q0, np.zeros(3))
    drift, lowest = 0.0, q0[0]
    for t in np.linspace(0.05, 0.5, 10):
        sim.advance_to(t)
        drift = max(drift, abs(mechanical_energy(model, sim.q, sim.qdot) - e0) / e0)
        lowest = min(lowest, sim.q[0])
    assert drift < 1e-8
    assert lowest < 0.0  # it did swing through the rest position


def test_pendulum_with_a_heavy_rod_conserves_energy_with_the_work_of_gravity():
    """Released from horizontal, a pendulum of a point mass on a rod with distributed mass
    swings through the bottom; the energy of `mechanical_energy` (kinetic, less the work of
    gravity on the lumped mass and on the rod's inertia points) stays within 1e-8 of m g L."""
    model = build_model({
        "scene": {"name": "heavy_pendulum", "gravity": [0.0, -9.81]},
        "sections": {"rod": {"EA": 1.0, "rho_A": 0.8}},  # 0.4 kg over 0.5 m
        "nodes": {"1": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "2": {"angle": 0.0, "dof": ["phi"]},
                  "3": {"position": [0.5, 0.0], "mass": 0.3},
                  "4": {"angle": 0.0}},
        "elements": {"rod": {"type": "PLBEAM", "nodes": ["1", "2", "3", "4"],
                             "section": "rod"}},
        "outputs": {"phi": {"node": "2", "coordinate": "phi"}},
    })
    scale = (0.3 + 0.4 / 2) * 9.81 * 0.5  # J: the potential energy of the swing
    sim = Simulator(model, rtol=1e-10)
    e0 = mechanical_energy(model, sim.q, sim.qdot)
    drift = 0.0
    for t in np.linspace(0.05, 0.4, 8):
        sim.advance_to(t)
        drift = max(drift, abs(mechanical_energy(model, sim.q, sim.qdot) - e0))
        assert 0.5 * sim.qdot @ sim.qdot > 1.0 or t < 0.2  # it did swing
    assert drift < 1e-8 * scale


def test_rigid_pendulum_period_matches_the_elliptic_integral():
    length, g = 0.5, 9.81
    model = pendulum(length)
    exact = 4 * np.sqrt(length / g) * scipy.special.ellipk(np.sin(np.pi / 4) ** 2)
    sim = Simulator(model, method="cvode-bdf", rtol=1e-11)
    crossings, previous = [], (0.0, sim.q[0], sim.qdot[0])
    while len(crossings) < 2:  # the angle passes -90 degrees at T/4 and 3T/4
        sim.advance_to(sim.time + 2e-3)
        t, phi, w = sim.time, sim.q[0], sim.qdot[0]
        if (previous[1] + np.pi / 2) * (phi + np.pi / 2) < 0:
            crossings.append(_hermite_root(previous, (t, phi, w), -np.pi / 2))
        previous = (t, phi, w)
    period = 2 * (crossings[1] - crossings[0])
    assert abs(period - exact) / exact < 1e-6


def _hermite_root(a, b, level):
    """Time where the cubic Hermite interpolant of (t, value, slope) a -> b reaches level."""
    (t0, y0, d0), (t1, y1, d1) = a, b
    h = t1 - t0
    lo, hi = 0.0, 1.0
    for _ in range(60):
        s = 0.5 * (lo + hi)
        value = ((2 * s**3 - 3 * s**2 + 1) * y0 + (s**3 - 2 * s**2 + s) * h * d0
                 + (-2 * s**3 + 3 * s**2) * y1 + (s**3 - s**2) * h * d1)
        if (value - level) * (y0 - level) > 0:
            lo = s
        else:
            hi = s
    return t0 + 0.5 * (lo + hi) * h


def test_cvode_and_ida_agree_on_the_same_scene_and_input():
    model = load_scene("stage_planar_1dof")
    times = np.linspace(0.0, 0.3, 31)
    inputs = {"F": lambda t: 2.0 * np.sin(20.0 * t)}
    a = simulate(model, 0.3, inputs=inputs, method="cvode-bdf", rtol=1e-10,
                 output_times=times)
    b = simulate(model, 0.3, inputs=inputs, method="ida", rtol=1e-10, output_times=times)
    assert np.max(np.abs(a.output_array - b.output_array)) < 1e-7
    assert np.max(np.abs(a.outputs["x"])) > 1e-3  # a real motion was compared


def test_slow_force_ramp_follows_the_nonlinear_static_solution():
    """A smooth 8 N ramp over 3 s (30 periods of the stage): the motion stays within 5e-4
    of the stroke from the static solution, and the parasitic vertical motion of the bar
    (of second order in the stroke, absent from a linear model) within 1e-3 of its value."""
    model = load_scene("stage_planar_1dof")
    port = model.inputs[0].coordinate
    F_max, T = 8.0, 3.0
    ramp = lambda t: F_max * 0.5 * (1 - np.cos(np.pi * min(t, T) / T))  # noqa: E731
    times = np.array([0.25, 0.5, 0.75, 1.0]) * T
    result = simulate(model, T, inputs={"F": ramp}, rtol=1e-8, output_times=times)
    x0, y0 = model.initial_coordinates[[port, port + 1]]
    statics = []
    for t in times:
        loads = model.loads.copy()
        loads[port] += ramp(t)
        static = static_equilibrium(model, loads=loads)
        statics.append((static.x[port] - x0, static.x[port + 1] - y0))
    dx, dy = np.array(statics).T
    assert dx[-1] > 8e-3 and dy[-1] < -4e-4
    assert np.all(np.abs(result.outputs["x"] - x0 - dx) < 5e-4 * dx[-1])
    assert np.all(np.abs(result.outputs["y"] - y0 - dy) < 1e-3 * abs(dy[-1]))


# -- Jacobian, statistics, state -------------------------------------------------------------
def test_model_jacobian_matches_finite_differences_at_an_equilibrium_in_motion():
    model = load_scene("stage_planar_3dof")
    sim = Simulator(model)
    sim.set_inputs([3.0])
    loads = model.loads.copy()
    loads[model.inputs[0].coordinate] += 3.0
    q = static_equilibrium(model, loads=loads).q
    for qdot in (np.zeros(3), np.array([0.02, 1e-4, 1e-3])):
        y = np.concatenate([q - sim.q_ref, qdot])  # the integrator's (deviation) state
        analytic = sim.jacobian_matrix(0.0, y)
        numeric = np.zeros_like(analytic)
        steps = np.array([1e-7, 1e-8, 1e-7, 1e-4, 1e-5, 1e-4])
        for j, h in enumerate(steps):
            up, down = y.copy(), y.copy()
            up[j] += h
            down[j] -= h
            numeric[:, j] = (sim.derivative(0.0, up) - sim.derivative(0.0, down)) / (2 * h)
        scale = np.max(np.abs(numeric), axis=1, keepdims=True)
        tolerance = 1e-5 if not np.any(qdot) else 1e-3  # exact at rest, close in motion
        assert np.all(np.abs(analytic - numeric) <= tolerance * scale)


def test_finite_difference_jacobian_gives_the_same_motion():
    model = load_scene("stage_planar_1dof")
    times = np.linspace(0, 0.1, 11)
    a = simulate(model, 0.1, inputs={"F": 1.0}, rtol=1e-9, output_times=times)
    b = simulate(model, 0.1, inputs={"F": 1.0}, rtol=1e-9, output_times=times,
                 jacobian="finite-difference")
    assert np.max(np.abs(a.output_array - b.output_array)) < 1e-9
    assert a.statistics["jacobian_evaluations"] > 0 and b.statistics["jacobian_evaluations"] > 0


def saved_state_at(t):
    """stage_planar_1dof under F = 1 N from rest at rtol 1e-7: the model, its Simulator at
    time t (s), and the state it gives there (pickled and unpickled, as a host stores it)."""
    model = load_scene("stage_planar_1dof")
    sim = Simulator(model, rtol=1e-7)
    sim.set_inputs([1.0])
    sim.advance_to(t)
    return model, sim, pickle.loads(pickle.dumps(sim.get_state()))


def test_restored_state_continues_bit_for_bit():
    model, sim, state = saved_state_at(0.05)
    sim.advance_to(0.1)
    sim.set_inputs([-0.5])
    sim.advance_to(0.15)
    first = (sim.q, sim.qdot, sim.outputs())
    other = Simulator(model, rtol=1e-7)
    other.set_state(state)
    other.advance_to(0.1)
    other.set_inputs([-0.5])
    other.advance_to(0.15)
    assert other.time == sim.time
    for a, b in zip(first, (other.q, other.qdot, other.outputs()), strict=True):
        assert np.array_equal(a, b)
    stats = sim.statistics
    assert stats["steps"] > 0 and stats["rhs_evaluations"] >= stats["steps"]
    assert stats["wall_time_s"] > 0


def test_zero_order_hold_samples_equal_manual_set_inputs():
    model = load_scene("stage_planar_1dof")
    times, values = np.array([0.0, 0.02, 0.05]), np.array([1.0, -2.0, 0.5])
    result = simulate(model, 0.08, inputs={"F": (times, values)}, rtol=1e-8,
                      output_times=[0.08])
    sim = Simulator(model, rtol=1e-8)
    for _t, u, t_next in zip(times, values, [0.02, 0.05, 0.08], strict=True):
        sim.set_inputs([u])
        sim.advance_to(t_next)
    assert np.allclose(result.outputs["x"][-1], sim.outputs()[0], atol=1e-12, rtol=0)


def test_outputs_that_are_dofs_are_read_from_q_and_equal_the_kinematics():
    """stage_planar_3dof's outputs x, y are its DOFs 3.x, 3.y: `outputs` reads them from q
    (no kinematics), equal to the kinematics' solution at that state to round-off; an
    output that is not a DOF (truss_1dof_e's x, its DOF an elongation) is marked -1.
    `output_values` gives the same floats as a list, by either path."""
    from flexure.core.mechanics.ports import output_dofs

    model = load_scene("stage_planar_3dof")
    assert output_dofs(model).tolist() == [0, 1]
    assert output_dofs(load_scene("truss_1dof_e")).tolist() == [-1]
    assert output_dofs(load_scene("stage_planar_1dof")).tolist() == [0, -1]
    sim = Simulator(model, method="esdirk", rtol=1e-6)
    sim.set_inputs([1.0])
    sim.advance_to(0.02)
    direct = sim.outputs()
    assert direct.tolist() == (sim.q[:2]).tolist() == sim.output_values()
    assert all(type(value) is float for value in sim.output_values())
    kinematic = Simulator(load_scene("truss_1dof_e"), method="esdirk", rtol=1e-6)
    kinematic.set_inputs([1.0])
    kinematic.advance_to(0.02)
    assert kinematic.output_values() == kinematic.outputs().tolist()
    solved = sim.outputs_along(sim.absolute(sim.state)[None])[0]
    np.testing.assert_allclose(direct, solved, rtol=0.0, atol=1e-15)
    assert abs(direct[0]) > 1e-6  # the stage moved


def test_cvode_keeps_its_jacobian_for_the_restart_of_a_sampled_loop():
    """A held-input change restarts CVODE, which is handed the Jacobian of its last setup
    instead of computing one (`Cvode.reset`): that kept Jacobian is the model's first-order
    Jacobian where CVODE computed it (here once, at the start: equal to round-off), and a
    sampled loop on stage_planar_3dof needs almost no new ones (it needed one per restart
    while the kept one was left at zero)."""
    from flexure.controllers.runner import run_loop

    model = load_scene("stage_planar_3dof")
    sim = Simulator(model, method="cvode-bdf", rtol=1e-6)
    at_start = sim.jacobian_matrix(0.0, sim.state)
    sim.advance_to(2e-4)  # a few steps: one Jacobian, at the start
    assert sim.statistics["jacobian_evaluations"] == 1
    kept = sim.integrator.restart_memory["jacobian"]
    n = 2 * sim.ndof
    assert kept.size == n * n
    np.testing.assert_allclose(kept.reshape(n, n, order="F"), at_start, rtol=1e-12,
                               atol=1e-12 * np.max(np.abs(at_start)))
    # the compiled sampled loop: 4000 restarts at 4 kHz, and CVODE computes 1 Jacobian
    jacobians = []
    original = Simulator._resume_after_drive  # where the simulator takes the loop's end back

    def resume(self, *args, **kwargs):
        original(self, *args, **kwargs)
        jacobians.append(self.statistics["jacobian_evaluations"])

    Simulator._resume_after_drive = resume
    try:
        result = run_loop(model, method="cvode-bdf", duration=0.5, settle=0.0)
    finally:
        Simulator._resume_after_drive = original
    assert result.summary()["passed"] and jacobians[-1] <= 2


@pytest.mark.parametrize("kind", ["Simulator", "LinearSimulator"])
def test_advance_is_the_deprecated_name_of_advance_to(kind):
    """advance(t_end) read like a step length; advance_to(t_end) says it is the end time. The
    old name still works, with a DeprecationWarning, to the same state bit for bit (the same
    computation in one process)."""
    import flexure.core as core

    model = load_scene("stage_planar_3dof")
    new, old = (getattr(core, kind)(model) for _ in range(2))
    for sim in (new, old):
        sim.set_inputs([1.0])
    new.advance_to(0.01)
    with pytest.warns(DeprecationWarning, match=r"advance\(t_end\) is renamed advance_to"):
        old.advance(0.01)
    assert old.time == new.time == 0.01
    np.testing.assert_array_equal(old.outputs(), new.outputs())
