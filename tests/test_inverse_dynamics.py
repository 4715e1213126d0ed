"""Inverse dynamics along a prescribed path and the response to prescribed motion,
against F = m a + c v + k x, a pendulum's torque, a chain's equation written out
by hand, and the compiled engine's forward simulation under the computed torque."""

import copy

import numpy as np
import pytest
from kinematic_scenes import C1, C2, K1, K2, M1, M2, chain, pendulum, scene, sine, with_motion

from flexure.core import build_model, load_scene
from flexure.core.analysis.inverse_dynamics import inverse_dynamics, sampled_path
from flexure.core.errors import ConstraintError, SceneError

# -- inverse dynamics ---------------------------------------------------------------------

def test_inverse_dynamics_of_the_truss_stage():
    """truss_1dof_x: F = m a + c v + k u - f0 with m = 0.206 + rho_A l / 3, k = EA / l,
    c = EdA / l and the scene's 1 N on node 2 (linear along x: exact)."""
    model = load_scene("truss_1dof_x")
    m, k, c = 0.206 + 0.1413 * 0.1 / 3, 94.5 / 0.1, 0.0036494 / 0.1
    t = np.linspace(0.0, 1.0, 11)
    stroke, omega = 1e-3, 7.0
    result = inverse_dynamics(model, t, sine(0.1, stroke, omega))
    u, v = stroke * np.sin(omega * t), stroke * omega * np.cos(omega * t)
    exact = -m * omega ** 2 * u + c * v + k * u - 1.0
    np.testing.assert_allclose(result.force("F"), exact, rtol=1e-12, atol=0)
    # the same motion as a kinematic input: its effort is that force
    moved = build_model(with_motion("truss_1dof_x", "2", "x"))
    efforts = inverse_dynamics(moved, t, sine(0.1, stroke, omega), outputs=[], inputs=[])
    np.testing.assert_allclose(efforts.force("X"), exact, rtol=1e-12, atol=0)
    with pytest.raises(KeyError, match="no input 'Z'"):
        result.force("Z")


def test_inverse_dynamics_of_the_leaf_spring_stage():
    """stage_planar_1dof, 1 um: F = m a + c v + k x with the closed-form m, c, k of
    `test_state_space_of_a_stage_moved_by_its_position` (the leaves' geometric nonlinearity
    is (1e-6 / 0.1)^2 = 1e-10 of the force here)."""
    leaf = scene("stage_planar_1dof")["sections"]["leaf"]
    k = 24 * leaf["E"] * leaf["width"] * leaf["height"] ** 3 / 12 / 0.1 ** 3
    c = 24 * leaf["EdI"] / 0.1 ** 3
    m = 0.206 + 2 * 13 / 35 * leaf["rho"] * leaf["width"] * leaf["height"] * 0.1
    t = np.linspace(0.0, 1.0, 11)
    stroke, omega = 1e-6, 7.0
    result = inverse_dynamics(load_scene("stage_planar_1dof"), t, sine(0.0, stroke, omega),
                              outputs=["x"])
    u, v = stroke * np.sin(omega * t), stroke * omega * np.cos(omega * t)
    exact = -m * omega ** 2 * u + c * v + k * u
    error = np.max(np.abs(result.force("F") - exact)) / np.max(np.abs(exact))
    assert error < 1e-9


def test_inverse_dynamics_of_a_pendulum():
    """A point mass on a rigid link, theta from hanging: T = m g l sin(theta) + m l^2
    theta''; the link's tension m (g cos(theta) + l theta'^2)."""
    mass, length, g, amplitude, omega = 0.3, 0.25, 9.81, 0.8, 3.0
    t = np.linspace(0.0, 2.0, 21)
    result = inverse_dynamics(pendulum(mass, length, g), t, sine(0.0, amplitude, omega))
    theta = amplitude * np.sin(omega * t)
    rate, acceleration = amplitude * omega * np.cos(omega * t), -omega ** 2 * theta
    torque = mass * g * length * np.sin(theta) + mass * length ** 2 * acceleration
    error = np.max(np.abs(result.force("T") - torque)) / np.max(np.abs(torque))
    assert error < 1e-12
    tension = mass * (g * np.cos(theta) + length * rate ** 2)
    np.testing.assert_allclose(result.stress_resultants[:, 0], tension, rtol=1e-12)
    np.testing.assert_allclose(result.q[:, 0], theta, atol=1e-15)


def test_a_sampled_path_is_a_cubic_spline():
    """A cubic in time sampled at 6 points: the spline is the cubic, its derivatives exact."""
    model = load_scene("truss_1dof_x")
    samples = np.linspace(0.0, 1.0, 6)
    cubic = np.poly1d([2e-3, -1e-3, 5e-4, 0.1])
    path = sampled_path(samples, cubic(samples)[:, None])
    t = np.linspace(0.0, 1.0, 7)
    result = inverse_dynamics(model, t, path)
    m, k, c = 0.206 + 0.1413 * 0.1 / 3, 945.0, 0.036494
    exact = m * cubic.deriv(2)(t) + c * cubic.deriv(1)(t) + k * (cubic(t) - 0.1) - 1.0
    np.testing.assert_allclose(result.force("F"), exact, rtol=1e-10)


X = ["x"]  # the truss's own position output (the test scene adds two more)


@pytest.mark.parametrize("call, error, words", [
    (lambda m: inverse_dynamics(m, [0.0], sine(0.1, 1e-3, 1.0), outputs=["v"]), SceneError,
     "'v' is not a position output"),
    (lambda m: inverse_dynamics(m, [0.0], sine(0.1, 1e-3, 1.0), outputs=X, inputs=["G"]),
     SceneError, "unknown force input"),
    (lambda m: inverse_dynamics(m, [0.0], sine(0.1, 1e-3, 1.0)), SceneError,
     "as many force inputs as prescribed outputs"),
    (lambda m: inverse_dynamics(m, [0.0, 0.0], sine(0.1, 1e-3, 1.0), outputs=X), SceneError,
     "increasing times"),
    (lambda m: inverse_dynamics(m, [0.0], lambda t: ([0.1], [0.0]), outputs=X), SceneError,
     "must give three arrays"),
    (lambda m: inverse_dynamics(m, [0.0], lambda t: ([np.nan], [0.0], [0.0]), outputs=X),
     SceneError, "not finite"),
    (lambda m: inverse_dynamics(m, [0.0], lambda t: ("far", 1, 2), outputs=X), SceneError,
     "must give"),
    (lambda m: inverse_dynamics(m, [0.0], sine(0.1, 1e-3, 1.0), outputs=[], inputs=[]),
     ConstraintError, "fix 0 of the NDOF"),
    (lambda m: inverse_dynamics(m, [0.0], sine(0.0, 1e-3, 1.0), outputs=["ground"]),
     ConstraintError, "do not determine the DOFs"),
])
def test_inverse_dynamics_refuses_what_it_cannot_do(call, error, words):
    data = scene("truss_1dof_x")
    data["outputs"]["v"] = {"node": "2", "coordinate": "x", "quantity": "velocity"}
    data["outputs"]["ground"] = {"node": "1", "coordinate": "x"}
    with pytest.raises(error, match=words):
        call(build_model(data))


def test_inverse_dynamics_refuses_inputs_that_do_not_act():
    """A force on the fixed wall cannot move the truss: DF^T b singular."""
    data = copy.deepcopy(scene("truss_1dof_x"))
    data["inputs"] = {"G": {"node": "1", "coordinate": "x"}}
    with pytest.raises(ConstraintError, match="cannot balance the motion"):
        inverse_dynamics(build_model(data), [0.0], sine(0.1, 1e-3, 1.0))


# -- the response to prescribed motion (numpy reference) -----------------------------------

def test_the_response_of_the_chain_to_a_prescribed_move():
    """Node 1 moved by u = A (1 - cos(w t)); node 2 obeys m2 y'' + c2 (y' - u') + k2 (y - u)
    = 0, integrated here by hand (DOP853, rtol 1e-12), and the effort is
    m1 u'' + c1 u' + k1 u - c2 (y' - u') - k2 (y - u). Within 1e-6 of the largest (the
    response's own rtol is 1e-8; measured 1.3e-8 and 1.6e-8)."""
    from scipy.integrate import solve_ivp

    from flexure.core.analysis.motion_response import motion_response

    A, w = 1e-3, 30.0
    t = np.linspace(0.0, 0.2, 21)
    motion = lambda s: ([0.1 + A * (1 - np.cos(w * s))], [A * w * np.sin(w * s)],  # noqa: E731
                        [A * w * w * np.cos(w * s)])
    result = motion_response(build_model(chain()), t, motion, rtol=1e-8)
    u, ud, udd = A * (1 - np.cos(w * t)), A * w * np.sin(w * t), A * w * w * np.cos(w * t)
    reference = solve_ivp(
        lambda s, z: [z[1], (-C2 * (z[1] - A * w * np.sin(w * s))
                             - K2 * (z[0] - A * (1 - np.cos(w * s)))) / M2],
        (0.0, 0.2), [0.0, 0.0], t_eval=t, rtol=1e-12, atol=1e-16, method="DOP853")
    y, yd = reference.y
    assert np.max(np.abs(result.q[:, 1] - 0.2 - y)) < 1e-6 * np.max(np.abs(y))
    effort = M1 * udd + C1 * ud + K1 * u - C2 * (yd - ud) - K2 * (y - u)
    assert np.max(np.abs(result.efforts[:, 0] - effort)) < 1e-6 * np.max(np.abs(effort))
    np.testing.assert_allclose(result.q[:, 0], 0.1 + u, rtol=0, atol=1e-15)


def test_a_response_with_nothing_free_is_the_inverse_dynamics():
    """truss_1dof_x moved by its kinematic input: no integration, the efforts are the closed
    form F = m a + c v + k u - 1 N of `test_inverse_dynamics_of_the_truss_stage`."""
    from flexure.core.analysis.motion_response import motion_response

    t = np.linspace(0.0, 1.0, 11)
    result = motion_response(build_model(with_motion("truss_1dof_x", "2", "x")), t,
                             sine(0.1, 1e-3, 7.0))
    m, k, c = 0.206 + 0.1413 * 0.1 / 3, 945.0, 0.036494
    u, v = 1e-3 * np.sin(7.0 * t), 7e-3 * np.cos(7.0 * t)
    np.testing.assert_allclose(result.efforts[:, 0], -49 * m * u + c * v + k * u - 1.0,
                               rtol=1e-12)


@pytest.mark.parametrize("data, times, words", [
    (lambda: scene("truss_1dof_x"), [0.0, 1.0], "needs a kinematic input"),
    (lambda: with_motion("truss_1dof_x", "2", "x"), [0.0], "at least two"),
    (lambda: with_motion("truss_1dof_x", "2", "x")
     | {"actuators": {"V": {"input": "F", "force_constant": 1.0, "resistance": 1.0,
                            "inductance": 1e-3}}}, [0.0, 1.0], "actuators"),
])
def test_the_response_refuses_what_it_cannot_do(data, times, words):
    from flexure.core.analysis.motion_response import motion_response

    with pytest.raises(SceneError, match=words):
        motion_response(build_model(data()), times, sine(0.1, 1e-3, 7.0))


@pytest.mark.slow
def test_the_forward_simulation_under_the_computed_torque_follows_the_path():
    """The pendulum's torque from inverse dynamics (a cubic spline through 2001 samples), fed
    to the compiled engine's forward simulation from theta = 0, theta' = A w: theta follows
    A sin(w t) within 1e-8 rad over 1 s at rtol 1e-10 (measured 1.2e-9). Compiles the engine
    on an empty cache."""
    from scipy.interpolate import CubicSpline

    from flexure.core import simulate

    model = pendulum(0.3, 0.25, 9.81)
    amplitude, omega = 0.8, 3.0
    samples = np.linspace(0.0, 1.0, 2001)
    torque = CubicSpline(samples, inverse_dynamics(model, samples, sine(0.0, amplitude, omega))
                         .force("T"))
    result = simulate(model, 1.0, inputs={"T": lambda t: float(torque(t))}, q0=[0.0],
                      qdot0=[amplitude * omega], rtol=1e-10,
                      output_times=np.linspace(0.0, 1.0, 101))
    assert np.max(np.abs(result.q[:, 0] - amplitude * np.sin(omega * result.times))) < 1e-8


# the body turning about a fixed skew axis: principal inertia J (kg m^2), the rotation vector
# theta(t) n with theta = AMPLITUDE sin(OMEGA t) (rad)
BODY_INERTIA = np.diag([0.01, 0.02, 0.03])
SKEW_AXIS = np.array([1.0, 2.0, 2.0]) / 3.0
AMPLITUDE, OMEGA = 1.2, 2.0


def _skew_path(s):
    """The rotation vector, its rate and acceleration at time s (rad, rad/s, rad/s^2)."""
    return tuple(value * SKEW_AXIS for value in (
        AMPLITUDE * np.sin(OMEGA * s), AMPLITUDE * OMEGA * np.cos(OMEGA * s),
        -AMPLITUDE * OMEGA ** 2 * np.sin(OMEGA * s)))


def _euler_moments(s):
    """Euler's moments (N m, global frame) that turn the body along `_skew_path` at time s,
    and theta: M = J_g theta'' n + omega x (J_g omega), omega = theta' n, J_g = R J R^T with
    R = exp(theta [n x]) (Rodrigues)."""
    n = SKEW_AXIS
    cross = np.array([[0.0, -n[2], n[1]], [n[2], 0.0, -n[0]], [-n[1], n[0], 0.0]])
    theta = AMPLITUDE * np.sin(OMEGA * s)
    rate, acceleration = AMPLITUDE * OMEGA * np.cos(OMEGA * s), -OMEGA ** 2 * theta
    R = np.eye(3) + np.sin(theta) * cross + (1.0 - np.cos(theta)) * cross @ cross
    inertia = R @ BODY_INERTIA @ R.T
    return inertia @ (acceleration * n) + np.cross(rate * n, inertia @ (rate * n)), theta


def test_inverse_dynamics_of_a_body_turning_about_a_skew_axis():
    """A free body whose rotation vector follows `_skew_path` about the fixed skew axis
    n = [1, 2, 2] / 3, its angles about x, y, z prescribed, its three moments solved for:
    Euler's equations in the global frame (`_euler_moments`), to 1e-12."""
    model = build_model({
        "scene": {"name": "body", "dimension": 3},
        "nodes": {"B": {"rotation": [0.0, 0.0, 0.0],
                        "inertia": np.diag(BODY_INERTIA).tolist(), "dof": ["rx", "ry", "rz"]}},
        "inputs": {f"M{a}": {"node": "B", "coordinate": f"r{a}"} for a in "xyz"},
        "outputs": {f"a{a}": {"node": "B", "coordinate": f"r{a}"} for a in "xyz"}})
    t = np.linspace(0.0, 2.0, 11)
    result = inverse_dynamics(model, t, _skew_path)
    expected = np.array([_euler_moments(s)[0] for s in t])
    assert np.max(np.abs(result.forces - expected)) < 1e-12 * np.max(np.abs(expected))


def test_the_effort_of_a_prescribed_rotation():
    """The body of `test_inverse_dynamics_of_a_body_turning_about_a_skew_axis` with its
    rotation-vector component about z prescribed (a kinematic input) and moments about x, y:
    the effort is the generalised force on phi_z, the z row of J_l(phi)^T (M - [Mx, My, 0])
    with M Euler's moments and J_l = I + (1 - cos t)/t^2 [phi x] + (t - sin t)/t^3 [phi x]^2
    the left Jacobian (omega = J_l phi'), to 1e-12."""
    model = build_model({
        "scene": {"name": "body", "dimension": 3},
        "nodes": {"B": {"rotation": [0.0, 0.0, 0.0],
                        "inertia": np.diag(BODY_INERTIA).tolist(), "dof": ["rx", "ry"]}},
        "inputs": {"Mx": {"node": "B", "coordinate": "rx"},
                   "My": {"node": "B", "coordinate": "ry"},
                   "Z": {"kind": "motion", "node": "B", "coordinate": "rz"}},
        "outputs": {"ax": {"node": "B", "coordinate": "rx"},
                    "ay": {"node": "B", "coordinate": "ry"}}})
    t = np.linspace(0.1, 2.0, 8)
    result = inverse_dynamics(model, t, _skew_path)
    n = SKEW_AXIS
    cross = np.array([[0.0, -n[2], n[1]], [n[2], 0.0, -n[0]], [-n[1], n[0], 0.0]])
    expected = []
    for k, s in enumerate(t):
        moments, theta = _euler_moments(s)
        P = theta * cross
        left = (np.eye(3) + (1.0 - np.cos(theta)) / theta ** 2 * P
                + (theta - np.sin(theta)) / theta ** 3 * P @ P)
        applied = np.array([result.forces[k, 0], result.forces[k, 1], 0.0])
        expected.append((left.T @ (moments - applied))[2])
    expected = np.array(expected)
    assert np.max(np.abs(result.efforts[:, 0] - expected)) < 1e-12 * np.max(np.abs(expected))
