"""Inverse dynamics with free DOFs (core/analysis/inverse_dynamics_free.py): a chain of two
masses whose free mass's response is known in closed form, the method's order, the forces
between the steps, a forward simulation driven by them, the zero dynamics, and every
refusal."""

import numpy as np
import pytest
from kinematic_scenes import with_motion

from flexure.core import build_model, free_inverse_dynamics, zero_dynamics
from flexure.core.errors import ConstraintError, ConvergenceError, SceneError

K1, C1, K2, M1, M2 = 800.0, 0.3, 500.0, 0.4, 0.25
A, W = 1e-3, 30.0  # m, rad/s: the driven mass moves by A (1 - cos(W t))


def two_masses(*, force_on="1", second_force=False, truss_mass=0.0):
    """Ground -k1, c1- mass 1 -k2- mass 2 along x, a force F on `force_on`'s x (and G on
    mass 2's with `second_force`), outputs x1 and x2; with `truss_mass` the second link is a
    truss of that consistent mass (kg/m) instead of a massless spring."""
    link = ({"type": "PLTRUSS", "section": "b", "released": ["e1"]} if truss_mass
            else {"type": "PLSPRING", "section": "b", "released": ["e1"]})
    inputs = {"F": {"node": force_on, "coordinate": "x"}}
    if second_force:
        inputs["G"] = {"node": "2", "coordinate": "x"}
    return build_model({
        "scene": {"name": "two_masses"},
        "sections": {"a": {"kx": K1, "cx": C1},
                     "b": ({"EA": K2 * 0.1, "EdA": 0.0, "rho_A": truss_mass} if truss_mass
                           else {"kx": K2, "cx": 0.0})},
        "nodes": {"0": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "1": {"position": [0.1, 0.0], "mass": M1, "dof": ["x"]},
                  "2": {"position": [0.2, 0.0], "mass": M2, "dof": ["x"]}
                  | ({"fixed": ["y"]} if truss_mass else {})},
        "elements": {"a": {"type": "PLSPRING", "nodes": ["0", "1"], "section": "a",
                           "released": ["e1"]},
                     "b": {"nodes": ["1", "2"], **link}},
        "inputs": inputs,
        "outputs": {"x1": {"node": "1", "coordinate": "x"},
                    "x2": {"node": "2", "coordinate": "x"}}})


def moved(x0):
    """x0 + A (1 - cos(W t)), its rate and acceleration: starts at rest."""
    return lambda t: ([x0 + A * (1 - np.cos(W * t))], [A * W * np.sin(W * t)],
                      [A * W * W * np.cos(W * t)])


def closed_form(t):
    """(y1, y2, F): mass 2 free under y1 = A (1 - cos(W t)) from rest,
    y2'' + w2^2 y2 = w2^2 y1, so y2 = A (1 - (w2^2 cos(W t) - W^2 cos(w2 t)) / (w2^2 - W^2)),
    and F = M1 y1'' + C1 y1' + K1 y1 - K2 (y2 - y1)."""
    w2 = np.sqrt(K2 / M2)
    y1 = A * (1 - np.cos(W * t))
    y2 = A * (1 - (w2 ** 2 * np.cos(W * t) - W ** 2 * np.cos(w2 * t)) / (w2 ** 2 - W ** 2))
    force = (M1 * A * W * W * np.cos(W * t) + C1 * A * W * np.sin(W * t) + K1 * y1
             - K2 * (y2 - y1))
    return y1, y2, force


def errors(step):
    """The free mass's and the force's largest errors against the closed form over 0.2 s,
    relative to their largest values, at the steps and (the force) between them on a fine
    grid, at Radau IIA step `step` (s)."""
    t = np.arange(0.0, 0.2 + step / 2, step)
    result = free_inverse_dynamics(two_masses(), t, moved(0.1), outputs=["x1"])
    y1, y2, force = closed_form(t)
    np.testing.assert_allclose(result.q[:, 0] - 0.1, y1, rtol=0, atol=1e-15)
    fine = np.linspace(0.0, t[-1], 2001)
    between = result.force_polynomial()(fine)[:, 0] - closed_form(fine)[2]
    scale = np.max(np.abs(force))
    return (np.max(np.abs(result.q[:, 1] - 0.2 - y2)) / np.max(np.abs(y2)),
            np.max(np.abs(result.force("F") - force)) / scale,
            np.max(np.abs(between)) / scale)


def test_the_free_mass_follows_its_closed_form_at_order_five_and_four_between():
    """Mass 1 prescribed, mass 2 free (w2 = 44.7 rad/s), at h = 10, 5 and 2.5 ms: each
    halving divides mass 2's and the force's errors at the steps by 2^4.7 to 2^5.3 (order 5;
    measured 32.0 to 32.1) and the force's between the steps, the cubic through each step's
    nodes, by 2^3.8 to 2^4.4 (order 4; measured 18.3 and 16.3). At 2.5 ms mass 2 and the
    force at the steps are within 1e-8 of the closed form (measured 5.7e-9 and 7.2e-9),
    between them within 1e-7 (measured 6.9e-8)."""
    found = np.array([errors(step) for step in (10e-3, 5e-3, 2.5e-3)])
    orders = np.log2(found[:-1] / found[1:])
    assert np.all((4.7 < orders[:, :2]) & (orders[:, :2] < 5.3)), orders
    assert np.all((3.8 < orders[:, 2]) & (orders[:, 2] < 4.4)), orders
    assert np.all(found[-1] < [1e-8, 1e-8, 1e-7]), found[-1]


def test_the_force_is_the_closed_form_within_1e_9_at_a_millisecond():
    """At h = 1 ms the force at every step is the closed form within 1e-9 of its largest
    value (measured 7.4e-11), and at the inner stages within 1e-8 (measured 1.9e-9)."""
    t = np.arange(0.0, 0.2 + 5e-4, 1e-3)
    result = free_inverse_dynamics(two_masses(), t, moved(0.1), outputs=["x1"])
    scale = np.max(np.abs(closed_form(t)[2]))
    assert np.max(np.abs(result.force("F") - closed_form(t)[2])) < 1e-9 * scale
    inner = np.max(np.abs(result.node_forces[:, 0] - closed_form(result.node_times)[2]))
    assert inner < 1e-8 * scale


def test_the_force_polynomial_passes_through_the_nodes_continuously():
    """Uneven steps: the piecewise cubic is each node's force to 1e-12 of the largest, and
    equal from both sides at every step's end; the nodes are each step's start, its stages
    t_n + (4 -+ sqrt 6) / 10 h and its end."""
    t = np.array([0.0, 0.004, 0.01, 0.013, 0.02])
    result = free_inverse_dynamics(two_masses(), t, moved(0.1), outputs=["x1"])
    stages = t[:-1, None] + np.diff(t)[:, None] * (4 + np.array([-1, 1]) * np.sqrt(6)) / 10
    expected = np.sort(np.concatenate([t, stages.reshape(-1)]))
    np.testing.assert_allclose(result.node_times, expected, rtol=0, atol=1e-15)
    polynomial = result.force_polynomial()
    scale = np.max(np.abs(result.node_forces))
    np.testing.assert_allclose(polynomial(result.node_times), result.node_forces, rtol=0,
                               atol=1e-12 * scale)
    before, after = polynomial(t[1:-1] - 1e-13), polynomial(t[1:-1] + 1e-13)
    np.testing.assert_allclose(before, after, rtol=0, atol=1e-9 * scale)


def test_a_forward_simulation_with_the_forces_follows_the_path_within_its_tolerance():
    """The forces between the steps (h = 2.5 ms) drive the two masses in `simulate` (CVODE
    BDF): mass 1 follows the path A (1 - cos(W t)) within 1.5 times the run's own error at
    rtol 1e-8 (its difference from the run at rtol 1e-11; measured 1.01 times), and the run
    at 1e-11 follows it within a quarter of that error (measured 0.125): what is left is
    the integrator's, not the inverse dynamics'. BDF2's forces at this step were 1e-3 of
    the stroke off."""
    from flexure.core import simulate

    model, T = two_masses(), 0.2
    t = np.arange(0.0, T + 1.25e-3, 2.5e-3)
    polynomial = free_inverse_dynamics(model, t, moved(0.1), outputs=["x1"]).force_polynomial()
    grid = np.linspace(0.0, T, 401)
    runs = {rtol: simulate(model, T, inputs={"F": lambda s: float(polynomial(s)[0])},
                           method="cvode-bdf", rtol=rtol, output_times=grid).outputs["x1"]
            for rtol in (1e-8, 1e-11)}
    path = 0.1 + A * (1 - np.cos(W * grid))
    own = np.max(np.abs(runs[1e-8] - runs[1e-11]))
    assert np.max(np.abs(runs[1e-8] - path)) < 1.5 * own
    assert np.max(np.abs(runs[1e-11] - path)) < 0.25 * own


def test_outputs_may_be_coordinates_that_no_output_names():
    """"1.x" prescribed is the output x1 prescribed: the same forces, bit for bit."""
    t = np.linspace(0.0, 0.05, 11)
    by_output = free_inverse_dynamics(two_masses(), t, moved(0.1), outputs=["x1"])
    by_coordinate = free_inverse_dynamics(two_masses(), t, moved(0.1), outputs=["1.x"])
    np.testing.assert_array_equal(by_output.forces, by_coordinate.forces)


def test_the_zero_dynamics_of_the_chain():
    """x1 held: mass 2 on k2 alone, so the zeros are +-i sqrt(k2 / m2) (to 1e-12)."""
    w2 = np.sqrt(K2 / M2)
    values = zero_dynamics(np.array([[-w2 ** 2]]), np.zeros((1, 1)))
    np.testing.assert_allclose(np.sort(values.imag), [-w2, w2], rtol=1e-12)
    np.testing.assert_allclose(values.real, 0.0, atol=1e-12)


def test_a_non_minimum_phase_output_is_refused_where_the_step_cannot_damp_it():
    """The force on mass 1, the output on mass 2 through a truss of consistent mass m12 =
    rho_A l / 6: a real zero at sqrt(k2 / m12) = 548 1/s. At h = 10 ms (h lambda = 5.5,
    where Radau IIA's |R| = 8.9) it is refused, naming the zero; at h = 40 ms (h lambda =
    21.9, |R| = 0.29) the step damps it, and the output follows the path."""
    from flexure.core.analysis.inverse_dynamics_free import amplification

    model = two_masses(truss_mass=0.1)
    lam = np.sqrt(K2 / (0.1 * 0.1 / 6))
    assert amplification(0.01 * lam)[0] > 1.0 > amplification(0.04 * lam)[0]
    with pytest.raises(ConstraintError, match=r"unstable mode at 547\.7"):
        free_inverse_dynamics(model, np.linspace(0.0, 0.1, 11), moved(0.2), outputs=["x2"])
    t = np.linspace(0.0, 0.2, 6)
    result = free_inverse_dynamics(model, t, moved(0.2), outputs=["x2"])
    np.testing.assert_allclose(result.q[:, 1] - 0.2, A * (1 - np.cos(W * t)), atol=1e-15)
    assert np.all(np.isfinite(result.forces))


def test_the_amplification_is_radau_iias():
    """|R(z)| against the closed form (1 + 2z/5 + z^2/20) / (1 - 3z/5 + 3z^2/20 - z^3/60)
    to 1e-12, 1 at 11.8424 on the real axis, 3 / z for large z."""
    from flexure.core.analysis.inverse_dynamics_free import amplification

    z = np.array([0.3, -2.0, 5.0, 1 + 4j, -30 + 2j])
    closed = np.abs((1 + 2 * z / 5 + z ** 2 / 20)
                    / (1 - 3 * z / 5 + 3 * z ** 2 / 20 - z ** 3 / 60))
    np.testing.assert_allclose(amplification(z), closed, rtol=1e-12)
    np.testing.assert_allclose(amplification([11.8423556133]), 1.0, rtol=1e-9)
    np.testing.assert_allclose(amplification([1e6]) * 1e6, 3.0, rtol=1e-4)


@pytest.mark.parametrize("call, error, words", [
    (lambda: free_inverse_dynamics(two_masses(), [0.0, 0.01], moved(0.2), outputs=["x2"]),
     ConstraintError, "do not reach the accelerations"),
    (lambda: free_inverse_dynamics(two_masses(second_force=True), [0.0, 0.01],
                                   lambda t: ([0.2, 0.2], [0, 0], [0, 0]),
                                   outputs=["x2", "2.x"]),
     ConstraintError, "do not move independently"),
    (lambda: free_inverse_dynamics(two_masses(), [0.0, 0.01, 0.01], moved(0.1),
                                   outputs=["x1"]),
     SceneError, "increasing times"),
    (lambda: free_inverse_dynamics(two_masses(), [0.0], moved(0.1), outputs=["x1"]),
     SceneError, "at least two"),
    (lambda: free_inverse_dynamics(two_masses(), [0.0, 0.01], moved(0.2), outputs=["x1"]),
     SceneError, "output 'x1' is 0.1 there"),
    (lambda: free_inverse_dynamics(two_masses(), [0.0, 0.01], moved(0.1), outputs=["9.x"]),
     SceneError, "'9.x' is neither a position output"),
    (lambda: free_inverse_dynamics(two_masses(), [0.0, 0.01], moved(0.1), outputs=["x1"],
                                   inputs=["H"]),
     SceneError, "unknown force input"),
    (lambda: free_inverse_dynamics(two_masses(), [0.0, 0.01], moved(0.1),
                                   outputs=["x1", "x2"]),
     SceneError, "as many force inputs as prescribed outputs"),
    (lambda: free_inverse_dynamics(build_model(with_motion("truss_1dof_x", "2", "x")),
                                   [0.0, 0.01], moved(0.1), outputs=[], inputs=[]),
     SceneError, "kinematic inputs"),
    (lambda: free_inverse_dynamics(two_masses(), [0.0, 0.01, 0.02], moved(0.1),
                                   outputs=["x1"], max_iterations=1),
     ConvergenceError, "did not converge"),
])
def test_free_inverse_dynamics_refuses_what_it_cannot_do(call, error, words):
    with pytest.raises(error, match=words):
        call()


def test_with_nothing_free_it_is_the_inverse_dynamics():
    """truss_1dof_x, its one DOF prescribed: the forces of `inverse_dynamics` to 1e-14 N."""
    from flexure.core import inverse_dynamics, load_scene, static_equilibrium

    model = load_scene("truss_1dof_x")
    x0 = static_equilibrium(model).x[model.coordinate_index("2.x")]
    path = lambda t: ([x0 + 1e-3 * np.sin(7 * t)], [7e-3 * np.cos(7 * t)],  # noqa: E731
                      [-49e-3 * np.sin(7 * t)])
    t = np.linspace(0.0, 1.0, 11)
    free = free_inverse_dynamics(model, t, path)
    np.testing.assert_allclose(free.forces, inverse_dynamics(model, t, path).forces,
                               rtol=0, atol=1e-14)


def test_a_renewed_newton_matrix_gives_the_same_motion(monkeypatch):
    """Every step renewing its Newton matrix by forward differences at once (as a long
    stroke's stalled steps do) converges to the same solution: the forces within 1e-9 of the
    largest (both Newtons stop at 1e-12 of the DOFs' unit)."""
    from flexure.core.analysis import inverse_dynamics_free

    t = np.linspace(0.0, 0.05, 51)
    plain = free_inverse_dynamics(two_masses(), t, moved(0.1), outputs=["x1"])
    monkeypatch.setattr(inverse_dynamics_free, "RENEW_AFTER", 0)
    renewed = free_inverse_dynamics(two_masses(), t, moved(0.1), outputs=["x1"])
    scale = np.max(np.abs(plain.forces))
    np.testing.assert_allclose(renewed.forces, plain.forces, rtol=0, atol=1e-9 * scale)


def test_node_values_of_the_wrong_count_are_refused():
    """Two steps have seven nodes: six values are refused, naming both counts."""
    from flexure.core.analysis.inverse_dynamics_free import node_polynomial

    with pytest.raises(ValueError, match="expected 7 node values for 2 steps, got 6"):
        node_polynomial([0.0, 1.0, 2.0], np.zeros(6))
