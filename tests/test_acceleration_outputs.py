"""Acceleration outputs (`quantity = "acceleration"`, m/s2; rad/s2 about a global axis):
xddot_c = DF_c qddot + ((D2F qdot) qdot)_c of a coordinate, alpha_k = 2 E_k lambda_ddot about
a global axis k (`flexure.core.mechanics.output_quantities`). Checked against:

- the analytic mass-spring-damper (truss_1dof_x, linear along its axis): a = (F - k (x - l0)
  - d v) / m at every state of the simulation and of the linear simulator, and the state
  space's transfer s^2 / (m s^2 + d s + k) with its feedthrough 1 / m;
- central differences of the simulated velocity outputs on a spatial body on a rod (a
  rotation about a global axis and a translation, both with their convective terms): the
  difference converges to the acceleration output as h^2;
- the state space's acceleration rows against the velocity rows' dynamics (C_vel A, C_vel B)
  and, from a kinematic input, against s^2 times the chain's analytic transfer;
- the FMU's output against the in-process simulator;
- the refusals: an acceleration output of a simulation with kinematic inputs, and a quantity
  no table row names.
"""

import numpy as np
import pytest
from kinematic_scenes import C2, K2, M2, chain, with_motion
from test_rotation_ports import rod_body

from flexure.core import SceneError, Simulator, build_model, scene_toml, state_space_matrices
from flexure.core.analysis.motion_statespace import motion_state_space
from flexure.core.errors import SimulationError
from flexure.core.scene.building import parse_toml, scene_path
from flexure.core.simulation.linear_simulator import LinearSimulator

# truss_1dof_x: EA = 94.5 N, EdA = 0.0036494 N s, rho_A = 0.1413 kg/m over l0 = 0.1 m, 0.206 kg
# on node 2 (its consistent mass adds rho_A l0 / 3), a 1 N constant load
L0, K, D, MASS, LOAD = 0.1, 94.5 / 0.1, 0.0036494 / 0.1, 0.206 + 0.1413 * 0.1 / 3, 1.0


def mass_spring():
    """truss_1dof_x with the position, velocity and acceleration of its node 2."""
    data = parse_toml(scene_path("truss_1dof_x"))
    data["outputs"]["v"] = {"node": "2", "coordinate": "x", "quantity": "velocity"}
    data["outputs"]["a"] = {"node": "2", "coordinate": "x", "quantity": "acceleration"}
    return data


def test_the_quantity_has_its_units_on_translations_and_rotations():
    model = build_model(mass_spring())
    assert [(p.quantity, p.unit) for p in model.outputs] == [
        ("position", "m"), ("velocity", "m/s"), ("acceleration", "m/s2")]
    data = rod_body()
    data["outputs"]["alpha"] = {"node": "4", "coordinate": "rx", "quantity": "acceleration"}
    assert build_model(data).outputs[-1].unit == "rad/s2"
    planar = parse_toml(scene_path("stage_planar_3dof"))
    node = next(name for name, node in planar["nodes"].items() if "angle" in node
                and node.get("fixed") is not True)
    planar["outputs"] = {"a": {"node": node, "coordinate": "phi", "quantity": "acceleration"}}
    assert build_model(planar).outputs[0].unit == "rad/s2"


def test_a_quantity_no_row_names_is_refused_with_the_table():
    data = mass_spring()
    data["outputs"]["a"]["quantity"] = "jerk"
    with pytest.raises(SceneError, match="outputs.a.quantity: expected one of position, "
                                         "velocity, acceleration, got 'jerk'"):
        build_model(data)


@pytest.mark.parametrize("method", ["esdirk", "cvode-bdf"])
def test_mass_spring_acceleration_is_the_closed_form_at_every_state(method):
    """a = (F + 1 N - k (x - l0) - d v) / m at each state the simulation reaches, to 1e-10
    of the largest acceleration: the truss is linear along its axis, so the closed form holds
    exactly at any state, whatever the integration error of that state."""
    v, a, expected = _pushed_mass_spring(Simulator(build_model(mass_spring()), method=method,
                                                   rtol=1e-6))
    assert np.abs(v).max() > 1e-3  # it moves
    np.testing.assert_allclose(a, expected, rtol=0, atol=1e-10 * np.abs(expected).max())


def _pushed_mass_spring(sim, force=0.7):
    """(velocities, accelerations, the closed form's accelerations) of the mass-spring
    simulator `sim` at 41 states 0.5 ms apart, pushed by `force` (N) from its start."""
    sim.set_inputs([force])
    rows = [sim.outputs()]
    for k in range(1, 41):
        sim.advance_to(k * 5e-4)
        rows.append(sim.outputs())
    x, v, a = np.array(rows).T
    return v, a, (force + LOAD - K * (x - L0) - D * v) / MASS


def test_an_input_change_is_seen_by_the_acceleration_at_the_same_state():
    """set_inputs between two readings at one state: the acceleration jumps by dF / m (to
    1e-12), the position and velocity stay bit for bit."""
    sim = Simulator(build_model(mass_spring()), method="esdirk")
    sim.set_inputs([0.3])
    sim.advance_to(2e-3)
    before = sim.outputs()
    sim.set_inputs([0.8])
    after = sim.outputs()
    np.testing.assert_array_equal(after[:2], before[:2])
    assert after[2] - before[2] == pytest.approx(0.5 / MASS, rel=1e-12)


def test_an_input_function_is_read_at_the_state_s_time():
    """With the force an input function of time, the acceleration at each state is the
    closed form with the function's value there (to 1e-10 of the largest acceleration)."""
    def force(t):
        return 0.4 * np.sin(300.0 * t)

    sim = Simulator(build_model(mass_spring()), method="cvode-bdf", input_functions={0: force})
    rows, times = [], np.arange(1, 21) * 5e-4
    for t in times:
        sim.advance_to(t)
        rows.append(sim.outputs())
    x, v, a = np.array(rows).T
    expected = (force(times) + LOAD - K * (x - L0) - D * v) / MASS
    np.testing.assert_allclose(a, expected, rtol=0, atol=1e-10 * np.abs(expected).max())


def test_linear_simulator_acceleration_is_the_closed_form():
    """The linear simulator of the mass-spring (exact: the system is linear) reads the same
    closed form, its feedthrough D = 1/m included, to 1e-9 of the largest acceleration."""
    _, a, expected = _pushed_mass_spring(LinearSimulator(build_model(mass_spring())))
    np.testing.assert_allclose(a, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def test_state_space_acceleration_is_the_mass_spring_transfer():
    """C (sI - A)^-1 B + D of the acceleration output = s^2 / (m s^2 + d s + k) at five
    frequencies to 1e-10, D = 1/m: an accelerometer feeds the force through."""
    A, B, C, Dm = state_space_matrices(build_model(mass_spring()))
    assert Dm[2, 0] == pytest.approx(1.0 / MASS, rel=1e-12)
    np.testing.assert_array_equal(Dm[:2], 0.0)
    for omega in (1.0, 30.0, 67.0, 300.0, 1e4):
        s = 1j * omega
        G = C[2] @ np.linalg.solve(s * np.eye(2) - A, B[:, 0]) + Dm[2, 0]
        assert G == pytest.approx(s * s / (MASS * s * s + D * s + K), rel=1e-10)


def spatial_body():
    """rod_body (a body on a round rod, 6 DOFs) turned about a skew axis, a moment about x and
    a force along y; the angular velocity and acceleration about x, the velocity and
    acceleration of node 3 along y."""
    data = rod_body()
    data["nodes"]["4"]["rotation"] = [0.2, 0.1, -0.1]
    data["inputs"]["Fy"] = {"node": "3", "coordinate": "y"}
    data["outputs"] = {
        "omega": {"node": "4", "coordinate": "rx", "quantity": "velocity"},
        "alpha": {"node": "4", "coordinate": "rx", "quantity": "acceleration"},
        "vy": {"node": "3", "coordinate": "y", "quantity": "velocity"},
        "ay": {"node": "3", "coordinate": "y", "quantity": "acceleration"}}
    return data


def test_acceleration_is_the_rate_of_the_simulated_velocity():
    """Central differences of the velocity outputs along a tight cvode-bdf run (rtol 1e-11)
    converge to the acceleration outputs as h^2: the error relative to the largest
    acceleration is below 2e-3 at h = 0.1 ms (measured 4.7e-4 and 1.2e-3) and falls by
    3.5 to 4.5 from h = 0.2 ms (measured 4.0 and 3.8)."""
    model = build_model(spatial_body())
    errors = []
    for h in (2e-4, 1e-4):
        sim = Simulator(model, method="cvode-bdf", rtol=1e-11)
        sim.set_inputs([1e-3, 0.05])
        rows = [sim.outputs()]
        for k in range(1, round(0.01 / h) + 1):
            sim.advance_to(k * h)
            rows.append(sim.outputs())
        rows = np.array(rows)
        error = []
        for rate, value in ((0, 1), (2, 3)):
            difference = (rows[2:, rate] - rows[:-2, rate]) / (2 * h)
            error.append(np.abs(difference - rows[1:-1, value]).max()
                         / np.abs(rows[:, value]).max())
        errors.append(error)
    errors = np.array(errors)
    assert np.all(errors[1] < 2e-3)
    assert np.all((errors[0] / errors[1] > 3.5) & (errors[0] / errors[1] < 4.5))


def test_state_space_acceleration_rows_are_the_velocity_rows_dynamics():
    """On the spatial body: the acceleration rows are C_vel A and C_vel B (the rate of
    y_vel = C_vel z), to 1e-12 of the row."""
    A, B, C, Dm = state_space_matrices(build_model(spatial_body()))
    for velocity, acceleration in ((0, 1), (2, 3)):
        np.testing.assert_allclose(C[acceleration], C[velocity] @ A, rtol=0,
                                   atol=1e-12 * np.abs(C[acceleration]).max())
        np.testing.assert_allclose(Dm[acceleration], C[velocity] @ B, rtol=0,
                                   atol=1e-12 * np.abs(Dm[acceleration]).max())
        assert np.abs(Dm[acceleration]).max() > 0.0
    np.testing.assert_array_equal(Dm[[0, 2]], 0.0)


@pytest.mark.parametrize("rho_A", [0.0, 0.5])
def test_acceleration_from_a_kinematic_input_is_s_squared_times_the_position(rho_A):
    """The chain driven by the position of node 1: the acceleration of node 2 per m of input
    is s^2 times the analytic position transfer, to 1e-12, and needs the input's rates."""
    data = chain(rho_A=rho_A)
    data["outputs"]["a2"] = {"node": "2", "coordinate": "x", "quantity": "acceleration"}
    space = motion_state_space(build_model(data))
    m12, m22 = rho_A * 0.1 / 6, rho_A * 0.1 / 3
    row = space.outputs.index("a2")
    for omega in (0.5, 30.0, 44.7, 300.0):
        s = 1j * omega
        y = (K2 + C2 * s - m12 * s * s) / ((M2 + m22) * s * s + C2 * s + K2)
        assert space.frequency_response(s)[row, 0] == pytest.approx(s * s * y, rel=1e-12)
    assert "a2" in space.needs_rates()


def test_a_simulation_with_kinematic_inputs_refuses_an_acceleration_output():
    data = with_motion("truss_1dof_x", "2", "x", value=0.101)
    data["outputs"]["a"] = {"node": "2", "coordinate": "x", "quantity": "acceleration"}
    with pytest.raises(SimulationError, match="output 'a' is an acceleration: a simulation of "
                                              "a model with kinematic inputs \\(X\\) does not "
                                              "measure accelerations"):
        Simulator(build_model(data), method="esdirk", stepwise_motion=True)


def test_fmu_acceleration_output_equals_the_simulator(tmp_path):
    """The FMU of the spatial body under fmpy: alpha (rad/s2) and ay (m/s2), described; a
    step of both inputs stepped at 1 ms for 10 ms equals the in-process simulator on the same
    grid to 1e-7 of the largest value. Not to round-off: the FMU's engine is compiled for a
    generic CPU, and its trajectory differs from the in-process one by as much in the
    velocities as in the accelerations (measured: 1.4e-9 on vy, 2.4e-11 on omega; 2.5e-10 on
    alpha, 7.7e-11 on ay)."""
    from fmpy import read_model_description, simulate_fmu
    from fmpy.simulation import Input

    from flexure.fmu import build_scene_fmu
    from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS

    path = tmp_path / "spatial_body.toml"
    path.write_text(scene_toml(spatial_body()))
    fmu = build_scene_fmu(path, tmp_path / "spatial_body.fmu")
    variables = {v.name: v for v in read_model_description(str(fmu)).modelVariables}
    assert (variables["alpha"].unit, variables["ay"].unit) == ("rad/s2", "m/s2")
    assert (variables["alpha"].description
            == "angular acceleration about the global x axis of node 4")
    assert variables["ay"].description == "acceleration of coordinate 3.y"
    inputs, h, steps = (1e-3, 0.05), 1e-3, 10
    signal = np.array([(0.0, *inputs), (steps * h, *inputs)],
                      dtype=[("time", float), ("M", float), ("Fy", float)])
    run = simulate_fmu(str(fmu), stop_time=steps * h, step_size=h, output_interval=h,
                       input=signal, output=["omega", "alpha", "vy", "ay"])
    sim = Simulator(build_model(spatial_body()), method=METHODS[0], rtol=DEFAULT_RTOL)
    expected = [sim.outputs()]
    table = np.array([signal["M"], signal["Fy"]])
    for k in range(steps):
        # the inputs as fmpy gives them at each doStep: its interpolation of the constant
        # signal differs from it by an ulp at some steps (Fy 0.049999999999999996 at 7 ms),
        # an input change the ESDIRK's first step answers (`esdirk_kernels.restart`)
        held, _ = Input.interpolate(k * h, signal["time"], table)
        sim.set_inputs(list(held))
        sim.advance_to((k + 1) * h)
        expected.append(sim.outputs())
    expected = np.array(expected)
    for column, name in enumerate(("omega", "alpha", "vy", "ay")):
        assert np.abs(expected[1:, column]).max() > 0.0
        np.testing.assert_allclose(run[name], expected[:, column], rtol=0,
                                   atol=1e-7 * np.abs(expected[:, column]).max())
