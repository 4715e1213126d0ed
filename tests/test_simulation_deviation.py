"""The integrator's state is the deviation from the start configuration, so that rtol acts on
the motion: against the analytic step response, the saved state and the outputs cache."""


import numpy as np
import pytest
from test_simulation import saved_state_at

from flexure.core import Simulator, build_model, default_atol, load_scene, simulate
from flexure.core.mechanics.kinematics import Kinematics


def step_response(periods, samples):
    """truss_1dof_x (a linear mass-spring-damper with a 1 N scene load): times (s), the
    analytic x(t) (m) and the motion amplitude (m)."""
    m = 0.206 + 0.1413 * 0.1 / 3.0
    k, c, force = 94.5 / 0.1, 0.0036494 / 0.1, 1.0
    wn = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - zeta**2)
    times = np.linspace(0.0, periods * 2 * np.pi / wd, samples)
    exact = 0.1 + force / k * (1 - np.exp(-zeta * wn * times) * (
        np.cos(wd * times) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * times)))
    return times, exact, np.max(np.abs(exact - 0.1))


@pytest.mark.parametrize("method, rtol, bound", [
    # the bound on error / (rtol x amplitude) is about three times the measured figure
    ("cvode-adams", 1e-6, 10),   # 2.3
    ("cvode-adams", 1e-9, 10),   # 7.7
    ("cvode-bdf", 1e-6, 10),     # 3.0
    ("ida", 1e-6, 10),           # 3.4
    ("ida", 1e-9, 60),           # 18
    ("cvode-bdf", 1e-9, 250),    # 76: the global error of BDF on an oscillation builds up
])                               # over the periods beyond the local tolerance
def test_five_periods_of_the_step_response_within_rtol_of_the_motion(method, rtol, bound):
    """Over five periods of the 1-DOF step response (x about 0.1 m, moving 2.1 mm), the error
    relative to the motion amplitude, not to the 0.1 m coordinate."""
    times, exact, amplitude = step_response(5, 501)
    result = simulate(load_scene("truss_1dof_x"), times[-1], method=method, rtol=rtol,
                      output_times=times)
    assert amplitude > 2e-3
    assert np.max(np.abs(result.outputs["x"] - exact)) <= bound * rtol * amplitude


def test_default_atol_lets_rtol_control_motions_above_a_thousandth_of_the_length_scale():
    model = load_scene("stage_planar_3dof")  # DOFs 3.x, 3.y (m), 4.phi (rad); L = 0.1 m
    atol = default_atol(model, 1e-6)
    L = Kinematics(model).length_scale
    omega = 2 * np.pi * 10.64471618  # the lowest natural frequency (rad/s)
    assert L == pytest.approx(0.1)
    assert np.allclose(atol[:3], [1e-9 * L, 1e-9 * L, 1e-9], rtol=1e-12)
    assert np.allclose(atol[3:], atol[:3] * omega, rtol=1e-6)


def test_the_state_is_the_deviation_from_the_start_configuration():
    model = load_scene("stage_planar_3dof")
    sim = Simulator(model, rtol=1e-6)
    assert np.array_equal(sim.q_ref, [0.0, 0.1, 0.0])
    assert np.array_equal(sim.q, sim.q_ref)
    q0 = np.array([1e-3, 0.1, 0.0])
    sim.reset(q0=q0)
    assert np.array_equal(sim.q_ref, q0) and not np.any(sim.state)
    sim.set_inputs([1.0])
    sim.advance_to(0.01)
    assert np.array_equal(sim.q, sim.q_ref + sim.state[:3])
    state = sim.get_state()
    assert state["version"] == 2 and np.array_equal(state["q_ref"], q0)


def test_a_restored_state_keeps_its_reference_and_continues_bit_for_bit():
    """A state restored into a simulator that started elsewhere (another q_ref) continues
    exactly like the original; an old (version 1, absolute) state is still accepted."""
    model, sim, state = saved_state_at(0.03)
    sim.advance_to(0.06)
    other = Simulator(model, rtol=1e-7)
    other.reset(q0=[2e-3])
    other.set_state(state)
    other.advance_to(0.06)
    assert np.array_equal(other.q, sim.q) and np.array_equal(other.qdot, sim.qdot)
    assert np.array_equal(other.outputs(), sim.outputs())
    old = dict(state, version=1, y=np.concatenate([state["q_ref"] + state["y"][:1],
                                                   state["y"][1:]]))
    del old["q_ref"]
    legacy = Simulator(model, rtol=1e-7)
    legacy.set_state(old)
    assert np.array_equal(legacy.q, state["q_ref"] + state["y"][:1])
    legacy.advance_to(0.06)
    assert np.allclose(legacy.q, sim.q, atol=1e-9, rtol=0)


def velocity_scene():
    """stage_planar_1dof with the bar's x velocity and y position as outputs."""
    import tomllib

    from flexure.core import scene_path

    data = tomllib.loads(scene_path("stage_planar_1dof").read_text())
    data["outputs"] = {"vx": {"node": "3", "coordinate": "x", "quantity": "velocity"},
                       "y": {"node": "5", "coordinate": "y"}}
    return build_model(data, source="stage_planar_1dof (velocity output)")


@pytest.mark.parametrize("model", [load_scene("stage_planar_3dof"), velocity_scene()],
                         ids=["positions", "velocity"])
def test_outputs_are_cached_per_state_and_equal_a_fresh_kinematic_solution(model):
    sim = Simulator(model, rtol=1e-8)
    sim.set_inputs([2.0])
    sim.advance_to(0.02)
    first = sim.outputs()
    first[:] = np.nan  # a copy: the cache is not exposed
    assert np.array_equal(sim.outputs(), sim.outputs()) and np.all(np.isfinite(sim.outputs()))
    # independent: the numpy kinematics, full Newton from the scene's configuration
    config = Kinematics(model).solve(sim.q, model.initial_coordinates)
    xdot = config.DF @ sim.qdot
    fresh = [xdot[p.coordinate] if p.quantity == "velocity" else config.x[p.coordinate]
             for p in model.outputs]
    assert np.allclose(sim.outputs(), fresh, rtol=1e-12, atol=1e-15)
    before = sim.outputs()
    sim.advance_to(0.03)  # a new state: new outputs
    assert not np.array_equal(sim.outputs(), before)


@pytest.mark.parametrize("scene", ["stage_planar_1dof", "stage_spatial_19dof"])
def test_the_measurement_starts_second_order_close_to_the_kinematics(scene):
    """`measuring.start_from_plant` moves the plant's last solution x_e to DOFs q = q_e + d u
    with J's factors: its distance to x(q) (the numpy kinematics, full Newton) falls as d^2
    on the free coordinates but the rigid clusters' slaves (which follow their masters in the
    Newton's first evaluation) falls as d^2 (by 4 within 1.5 when d halves) and stays below
    d^2 / 1 mm, where x_e is off by about d."""
    from flexure.core.engine.data import EngineData
    from flexure.core.simulation.measuring import start_from_plant

    model = load_scene(scene)
    output = EngineData(model)  # the measuring's own packed model, as the simulator's
    sim = Simulator(model, method="esdirk", rtol=1e-8)
    sim.set_inputs(np.full(len(sim.inputs), 1.0))
    sim.advance_to(0.01)
    kinematics = Kinematics(model)
    q_e = sim.data.float_array("q").copy()
    direction = np.random.default_rng(2).standard_normal(sim.ndof)
    distances = []
    for d in (1e-5, 5e-6, 2.5e-6):
        q = q_e + d * direction / np.linalg.norm(direction)
        start_from_plant(sim.data.address, output.address, q)
        exact = kinematics.solve(q, sim.data.float_array("x").copy()).x
        free = sim.data.int_array("free")  # the masters: the slaves follow at its first e
        distances.append(np.max(np.abs(output.float_array("x_start")[free]
                                       - exact[free])))
        assert distances[-1] <= d * d / 1e-3
        assert np.max(np.abs(sim.data.float_array("x")[free] - exact[free])) > 10 * distances[-1]
    ratios = np.array(distances[:-1]) / distances[1:]
    assert np.all(np.abs(ratios - 4.0) < 1.5), ratios


def test_outputs_after_a_set_state_do_not_start_from_the_plant_of_another_state():
    """A state set on a simulator whose plant last solved another configuration: its
    outputs are that state's (to 1e-12 of those of the simulator it came from), measured
    from the state's own coordinates, not from the plant's stale solution."""
    model = load_scene("stage_planar_1dof")  # its second output is not a DOF
    a, b = Simulator(model, rtol=1e-8), Simulator(model, rtol=1e-8)
    a.set_inputs([2.0])
    a.advance_to(0.02)
    b.set_inputs([-2.0])
    b.advance_to(0.05)
    b.set_state(a.get_state())
    np.testing.assert_allclose(b.outputs(), a.outputs(), rtol=1e-12, atol=1e-15)
