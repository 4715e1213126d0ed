"""Voice-coil actuators against independent results: the exact solution of the linear 3-state
ODE (scipy.linalg.expm), the back-EMF damping ratio and the coil's pole of the state space,
the electrical energy balance, the saturated and current-driven steady states, the analytic
Jacobian against finite differences, the compiled sampled loop against a Python loop.

The plant: truss_1dof_x, a mass on a spring along its axis (linear in x: e1 = x - l0), so the
nonlinear model is the linear ODE m x'' + c x' + k x = Km i, L i' = a(u) - R i - Km x'.
"""

import re
import tomllib

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
from test_esdirk import check_newton_solve

from flexure.core import (
    SceneError,
    SimulationError,
    Simulator,
    build_model,
    linearize,
    natural_frequencies,
    run_sampled_loop,
    scene_path,
    simulate,
    state_space,
    static_equilibrium,
)
from flexure.core.mechanics.energy import mechanical_energy

M = 0.206 + 0.1413 * 0.1 / 3.0  # kg: the bar plus a third of the spring (consistent mass)
K, C = 94.5 / 0.1, 0.0036494 / 0.1  # N/m, N s/m
KM, R, L = 2.0, 2.0, 0.01  # N/A, ohm, H: an electrical time constant of 5 ms


def truss(damped=True, **actuator):
    """truss_1dof_x without its 1 N load, its input F driven by the actuator VCM1 (voltage
    drive, KM, R, L unless `actuator` says otherwise)."""
    data = tomllib.loads(scene_path("truss_1dof_x").read_text())
    data["nodes"]["2"].pop("force")
    if not damped:
        data["sections"]["springs"].pop("EdA")
    keys = {"input": "F", "force_constant": KM, "resistance": R, "inductance": L}
    data["actuators"] = {"VCM1": {**keys, **actuator}}
    return data


def exact_response(u, times, *, c=C, km=KM, r=R, inductance=L, gain=1.0):
    """[x - x0, v, i] of the linear ODE after a drive step u (V) at t = 0, from rest: the
    matrix exponential of the system augmented with the held input."""
    A = np.array([[0.0, 1.0, 0.0], [-K / M, -c / M, km / M],
                  [0.0, -km / inductance, -r / inductance]])
    augmented = np.zeros((4, 4))
    augmented[:3, :3] = A
    augmented[2, 3] = gain * u / inductance
    start = np.array([0.0, 0.0, 0.0, 1.0])
    return np.array([scipy.linalg.expm(augmented * t) @ start for t in times])[:, :3]


# -- the scene -----------------------------------------------------------------------------------
def test_the_drive_signal_replaces_the_force_and_the_coil_current_is_a_state():
    model = build_model(truss(), source="vcm")
    (port,), (actuator,) = model.inputs, model.actuators
    assert (port.quantity, port.unit) == ("drive", "V")
    assert (actuator.force_constant, actuator.resistance, actuator.inductance) == (KM, R, L)
    assert actuator.saturation == np.inf and actuator.amplifier_gain == 1.0
    sim = Simulator(model)
    assert sim.nstate == 3 and sim.state.size == 3 and sim.currents.size == 1
    assert sim.atol.size == 3 and np.all(sim.atol > 0)
    current = Simulator(build_model(truss(drive="current")))
    assert current.nstate == 2 and current.currents.size == 0


@pytest.mark.parametrize("key, value, message", [
    ("input", "G", "actuators.VCM1.input: unknown input 'G'; the scene's inputs: F"),
    ("drive", "pwm", "actuators.VCM1.drive: expected one of voltage, current, got 'pwm'"),
    ("force_constant", 0.0, "actuators.VCM1.force_constant: expected a value > 0, got 0.0"),
    ("resistance", -1.0, "actuators.VCM1.resistance: expected a value > 0, got -1.0"),
    ("inductance", "1 mH", "actuators.VCM1.inductance: expected a number, got '1 mH'"),
    ("saturation", 0.0, "actuators.VCM1.saturation: expected a value > 0, got 0.0"),
    ("amplifier_gain", float("nan"), "actuators.VCM1.amplifier_gain: expected a finite"),
    ("colour", "red", "actuators.VCM1.colour: unknown key; expected one of amplifier_gain"),
])
def test_a_wrong_actuator_key_is_named(key, value, message):
    data = truss()
    data["actuators"]["VCM1"][key] = value
    with pytest.raises(SceneError, match="^" + re.escape(f"vcm: {message}")):
        build_model(data, source="vcm")


@pytest.mark.parametrize("change, message", [
    (lambda a: a.pop("input"), "actuators.VCM1: missing 'input'"),
    (lambda a: a.pop("force_constant"), "actuators.VCM1: missing 'force_constant'"),
    (lambda a: a.pop("inductance"), "actuators.VCM1: missing 'inductance': a voltage-driven"),
    (lambda a: a.pop("resistance"), "actuators.VCM1: missing 'resistance'"),
])
def test_a_missing_actuator_key_is_named(change, message):
    data = truss()
    change(data["actuators"]["VCM1"])
    with pytest.raises(SceneError, match=f"^vcm: {message}"):
        build_model(data, source="vcm")


def test_a_current_drive_needs_no_coil_and_two_actuators_cannot_share_an_input():
    data = truss(drive="current")
    del data["actuators"]["VCM1"]["resistance"], data["actuators"]["VCM1"]["inductance"]
    assert build_model(data).actuators[0].drive == "current"
    data["actuators"]["VCM2"] = dict(data["actuators"]["VCM1"])
    data["actuators"]["bad name"] = {"input": "F", "force_constant": 1.0}
    with pytest.raises(SceneError) as error:
        build_model(data, source="vcm")
    assert str(error.value) == (
        "vcm: 2 mistakes:\n  actuators.VCM2.input: input 'F' is driven by actuators.VCM1 "
        "already; one actuator per input\n  actuators.bad name: an actuator name must be an "
        "identifier (letters, digits, _)")
    with pytest.raises(SceneError, match="^vcm: actuators: expected a table, got list"):
        build_model({**truss(), "actuators": []}, source="vcm")


def test_overrides_set_an_actuators_key_and_name_a_wrong_one():
    model = build_model(truss(), overrides={"actuators.VCM1.resistance": 4.0})
    assert model.actuators[0].resistance == 4.0
    with pytest.raises(SceneError, match=r"^vcm: --set actuators.VCM1.inductance: expected "
                                         r"a value > 0, got -1.0"):
        build_model(truss(), overrides={"actuators.VCM1.inductance": -1.0}, source="vcm")
    with pytest.raises(SceneError, match="unknown actuator 'VCM9'; the scene's actuators: VCM1"):
        build_model(truss(), overrides={"actuators.VCM9.resistance": 1.0})


def test_the_scene_writes_back_with_its_actuators():
    from flexure.core import Scene, to_toml

    s = Scene("coil", dimension=2)
    s.section("springs", EA=94.5, rho_A=0.1413)
    s.node("1", position=[0.0, 0.0], fixed=["x", "y"])
    s.node("2", position=[0.1, 0.0], fixed=["y"], mass=0.206)
    s.element("spring", "PLTRUSS", ["1", "2"], section="springs", released=["e1"])
    s.input("F", node="2", coordinate="x").output("x", node="2", coordinate="x")
    s.actuator("VCM1", input="F", force_constant=KM, resistance=R, inductance=L,
               saturation=24.0)
    model = s.build()
    assert model.actuators[0].saturation == 24.0
    text = to_toml(model)
    assert "[actuators.VCM1]" in text and "saturation = 24.0" in text
    assert tomllib.loads(text)["actuators"] == s.data["actuators"]
    assert build_model(tomllib.loads(text)).actuators == model.actuators


# -- the time response ---------------------------------------------------------------------------
@pytest.mark.parametrize("method, rtol", [("cvode-bdf", 1e-9), ("ida", 1e-9),
                                         ("esdirk", 1e-8)])
def test_a_voltage_step_follows_the_exact_solution_of_the_3_state_ode(method, rtol):
    """Over two mechanical periods after a 1 V step: x, v and i within 100 rtol (the
    integrators' global error: measured 3-33 rtol) of their peaks."""
    bound = 100 * rtol
    model = build_model(truss())
    times = np.linspace(0.0, 0.2, 81)
    result = simulate(model, 0.2, inputs={"F": 1.0}, method=method, rtol=rtol,
                      output_times=times)
    exact = exact_response(1.0, times)
    x = result.outputs["x"] - 0.1
    assert np.max(np.abs(x - exact[:, 0])) <= bound * np.max(np.abs(exact[:, 0]))
    assert np.max(np.abs(result.qdot[:, 0] - exact[:, 1])) <= bound * np.max(
        np.abs(exact[:, 1]))
    assert np.max(np.abs(result.currents[:, 0] - exact[:, 2])) <= bound * np.max(
        np.abs(exact[:, 2]))
    assert np.max(exact[:, 2]) > 0.4  # the coil current rises to near u / R = 0.5 A


def test_the_electrical_energy_balance_holds_over_a_run():
    """int u i dt = int R i^2 dt + L i(T)^2 / 2 + E_mech(T) - E_mech(0) for an undamped
    spring: the back-EMF power F v is the work on the mechanism (`mechanical_energy`, the
    numpy reference). Simpson's rule on 0.1 ms samples."""
    model = build_model(truss(damped=False))
    times = np.linspace(0.0, 0.2, 2001)
    u = 1.5
    result = simulate(model, 0.2, inputs={"F": u}, rtol=1e-10, output_times=times)
    i = result.currents[:, 0]
    supplied = scipy.integrate.simpson(u * i, x=times)
    lost = scipy.integrate.simpson(R * i ** 2, x=times)
    energy = [mechanical_energy(model, result.q[k], result.qdot[k]) for k in (0, -1)]
    stored = L * i[-1] ** 2 / 2 + energy[1] - energy[0]
    assert supplied > 0.1  # joules: a run that moves
    assert abs(supplied - lost - stored) <= 1e-8 * supplied  # measured 1.7e-10
    assert energy[1] - energy[0] > 1e-4 * supplied  # the mechanism takes a share


def test_a_saturated_amplifier_settles_at_km_sat_over_r():
    """G u = 3 V clipped at 1.5 V: the steady current 0.75 A and force Km 1.5 / R, in the
    simulation (heavily damped by the back-EMF: Km^2 / R = 50 N s/m), the static
    equilibrium with the input held, and the analytic x = Km sat / (R k)."""
    model = build_model(truss(force_constant=10.0, amplifier_gain=2.0, saturation=1.5))
    force = 10.0 * 1.5 / R
    result = simulate(model, 1.5, inputs={"F": 1.5}, rtol=1e-10)
    assert abs(result.currents[-1, 0] - 1.5 / R) <= 1e-6 * 1.5 / R
    assert abs(result.outputs["x"][-1] - 0.1 - force / K) <= 1e-6 * force / K
    static = static_equilibrium(model, inputs={"F": 1.5})
    assert abs(static.q[0] - 0.1 - force / K) <= 1e-12 * force / K
    A, B, _ = linearize(model, static).state_matrices()
    assert np.all(B == 0.0)  # saturated: the drive signal no longer acts
    assert abs(static_equilibrium(model, inputs=[0.5]).q[0] - 0.1
               - 10.0 * 1.0 / R / K) <= 1e-12 * 10.0 / R / K


def test_a_current_drive_is_the_force_km_g_u_exactly():
    """The same run as an ideal force Km (G u): bit for bit, with and without saturation."""
    plain = tomllib.loads(scene_path("truss_1dof_x").read_text())
    plain["nodes"]["2"].pop("force")
    force_model = build_model(plain)
    for saturation, u in ((np.inf, 0.8), (0.3, 0.8)):
        keys = {"drive": "current", "amplifier_gain": 0.5}
        if np.isfinite(saturation):
            keys["saturation"] = saturation
        model = build_model(truss(**keys))
        force = KM * min(max(0.5 * u, -saturation), saturation)
        times = np.linspace(0.0, 0.1, 11)
        a = simulate(model, 0.1, inputs={"F": u}, output_times=times)
        b = simulate(force_model, 0.1, inputs={"F": force}, output_times=times)
        assert np.array_equal(a.q, b.q) and np.array_equal(a.qdot, b.qdot)
        assert a.currents.shape == (11, 0)
        static = static_equilibrium(model, inputs={"F": u})
        assert abs(static.q[0] - 0.1 - force / K) <= 1e-12


# -- the linear analyses -------------------------------------------------------------------------
def test_the_state_space_shows_the_back_emf_damping_and_the_coil_pole():
    """L small against R / omega: the mechanical pole's damping ratio is (c + Km^2 / R) /
    (2 sqrt(k m)) to O(omega L / R) = 3e-4, the coil's pole -R / L to O(Km^2 / (m R) L / R);
    the natural frequency stays the open-coil one."""
    model = build_model(truss(inductance=1e-5))
    lin = linearize(model)
    assert abs(lin.M0[0, 0] - M) <= 1e-12 * M and abs(lin.K[0, 0] - K) <= 1e-9 * K
    system = state_space(model)
    assert system.nstates == 3 and system.state_labels[-1] == "VCM1.current"
    poles = np.linalg.eigvals(np.asarray(system.A))
    mechanical = poles[np.argmax(poles.imag)]
    zeta = -mechanical.real / abs(mechanical)
    expected = (C + KM ** 2 / R) / (2 * np.sqrt(K * M))
    assert abs(zeta - expected) <= 2e-4 * expected  # measured 2.4e-5
    electrical = poles[np.argmin(poles.real)]
    assert electrical.imag == 0.0 and abs(electrical.real + R / 1e-5) <= 5e-4 * R / 1e-5
    dc = np.asarray(system.dcgain()).item()  # m/V: Km / (R k)
    assert abs(dc - KM / (R * K)) <= 1e-9 * KM / (R * K)
    hz = natural_frequencies(model).frequencies_hz[0]
    assert abs(hz - np.sqrt(K / M) / (2 * np.pi)) <= 1e-9 * hz


def test_the_state_matrices_of_a_moving_state_match_the_engine_and_finite_differences():
    """On the planar stage (its input on 3.x, a DOF coordinate) the engine's Jacobian with a
    coil: against central differences of the engine's derivative in motion, and at rest
    against the linearisation's A."""
    data = tomllib.loads(scene_path("stage_planar_1dof").read_text())
    data["actuators"] = {"VCM": {"input": "F", "force_constant": 5.0, "resistance": 3.0,
                                 "inductance": 2e-3, "amplifier_gain": 2.0}}
    model = build_model(data)
    sim = Simulator(model)
    sim.set_inputs([0.7])
    A, _, _ = linearize(model).state_matrices()
    assert np.allclose(sim.jacobian_matrix(0.0, np.zeros(3)), A, rtol=1e-8, atol=1e-8)
    y = np.array([2e-4, 0.03, 0.2])
    analytic = sim.jacobian_matrix(0.0, y)
    numeric = np.zeros_like(analytic)
    for j, h in enumerate((1e-8, 1e-5, 1e-6)):
        up, down = y.copy(), y.copy()
        up[j] += h
        down[j] -= h
        numeric[:, j] = (sim.derivative(0.0, up) - sim.derivative(0.0, down)) / (2 * h)
    scale = np.max(np.abs(numeric), axis=1, keepdims=True)
    assert np.all(np.abs(analytic - numeric) <= 1e-3 * scale)  # the tests' bound in motion
    assert abs(analytic[1, 2] - numeric[1, 2]) <= 1e-7 * abs(numeric[1, 2])  # Km / M_bar
    # the coil's row, exact: v = qdot on the DOF coordinate 3.x
    assert analytic[2, 0] == 0.0 and analytic[2, 1] == -5.0 / 2e-3
    assert analytic[2, 2] == -3.0 / 2e-3


def test_an_actuator_on_a_dependent_coordinate_converges_in_every_integrator():
    """The stage's input moved to node 5 (x dependent): d idot / dq is left out of the Newton
    matrix there; CVODE, IDA and esdirk still agree to 1e-6 of the motion."""
    data = tomllib.loads(scene_path("stage_planar_1dof").read_text())
    data["inputs"]["F"]["node"] = "5"
    data["actuators"] = {"VCM": {"input": "F", "force_constant": 5.0, "resistance": 3.0,
                                 "inductance": 2e-3}}
    model = build_model(data)
    times = np.linspace(0.0, 0.05, 6)
    runs = [simulate(model, 0.05, inputs={"F": 2.0}, method=method, rtol=1e-9,
                     output_times=times) for method in ("cvode-bdf", "ida", "esdirk")]
    motion = np.ptp(runs[0].outputs["x"])
    assert motion > 1e-5
    for run in runs[1:]:
        assert np.max(np.abs(run.outputs["x"] - runs[0].outputs["x"])) <= 1e-6 * motion
        assert np.max(np.abs(run.currents - runs[0].currents)) <= 1e-6 * np.max(
            np.abs(runs[0].currents))


# -- the stepping simulator and the sampled loop ---------------------------------------------------
def test_a_restored_state_with_a_coil_continues_bit_for_bit():
    model = build_model(truss())
    sim = Simulator(model, method="esdirk", rtol=1e-7)
    sim.set_inputs([1.0])
    sim.advance_to(0.02)
    state = sim.get_state()
    assert state["y"].size == 3 and state["y"][2] > 0.1
    sim.advance_to(0.05)
    other = Simulator(model, method="esdirk", rtol=1e-7)
    other.set_state(state)
    other.advance_to(0.05)
    assert np.array_equal(other.state, sim.state) and np.array_equal(other.currents,
                                                                    sim.currents)
    plain = Simulator(build_model(truss(drive="current")))
    with pytest.raises(SimulationError, match="with 3 states; expected 'truss_1dof_x' with 2"):
        plain.set_state(state)
    with pytest.raises(SimulationError, match=r"i0: expected 1 finite values"):
        sim.reset(i0=[1.0, 2.0])
    with pytest.raises(SimulationError, match="atol: expected a positive number or 3"):
        Simulator(model, atol=[1e-9, 1e-9])
    sim.reset(i0=[0.25])
    assert sim.currents[0] == 0.25 and sim.derivative(0.0, sim.state)[2] == (
        (1.0 - R * 0.25) / L)


def test_a_velocity_output_reads_the_velocity_beside_the_coil_current():
    data = truss()
    data["outputs"]["v"] = {"node": "2", "coordinate": "x", "quantity": "velocity"}
    sim = Simulator(build_model(data), rtol=1e-9)
    sim.set_inputs([1.0])
    sim.advance_to(0.01)
    x, v = sim.outputs()
    assert v == sim.qdot[0] and v > 0.0 and sim.currents[0] > 0.0
    assert x == sim.q[0]  # x is the DOF itself


def test_the_compiled_loop_holds_the_drive_signal_as_a_python_loop_does():
    """A proportional loop on the coil's drive signal: the compiled sampled loop and the same
    loop of set_inputs and advance give the same numbers, bit for bit."""
    model = build_model(truss())
    fs, samples, gain = 2000.0, 200, 2000.0  # V/m
    reference = np.full((1, 1), 1e-3)
    zero = np.zeros((1, 1))
    sim = Simulator(model, method="esdirk2", rtol=1e-6)
    t, position, drive = run_sampled_loop(
        sim, fs=fs, samples=samples, reference=reference, feedforward=zero,
        controller=(zero, zero, zero, np.full((1, 1), gain)), loop_inputs=[0],
        loop_outputs=[0])
    other = Simulator(model, method="esdirk2", rtol=1e-6)
    u = 0.0
    for k in range(samples):
        y = other.outputs()[0]
        assert y == position[k, 0]
        other.set_inputs([u])
        assert u == drive[k, 0]
        u = gain * (reference[0, 0] - y)
        other.advance_to((k + 1) / fs)
    assert np.array_equal(other.state, sim.state) and other.time == t[-1]
    assert np.ptp(position) > 3e-4 and np.max(np.abs(sim.currents)) > 0


def test_the_steady_slopes_are_the_derivatives_of_the_steady_port_values():
    """d (steady port value) / d u against central differences (exact: piecewise linear),
    inside and beyond the saturation, for a voltage and a current drive; and the DC gain of
    the state space is the force's static compliance times that slope."""
    from flexure.core import steady_port_values, steady_slopes

    for drive, expected in (("voltage", 10.0 * 2.0 / R), ("current", 10.0 * 2.0)):
        model = build_model(truss(drive=drive, force_constant=10.0, amplifier_gain=2.0,
                                  saturation=1.5))
        for u, slope in ((0.3, expected), (-0.5, expected), (1.0, 0.0), (-2.0, 0.0)):
            h = 1e-3
            numeric = (steady_port_values(model, [u + h]) - steady_port_values(model, [u - h]))
            assert steady_slopes(model, [u]).tolist() == [slope]
            assert abs(numeric[0] / (2 * h) - slope) <= 1e-12 * expected
    plain = build_model(truss(drive="current", force_constant=10.0))
    assert np.asarray(state_space(plain).dcgain()).item() == pytest.approx(
        steady_slopes(plain, [0.0])[0] / K, rel=1e-9)


@pytest.mark.parametrize("coils", [1, 2])
def test_a_large_model_with_coils_takes_the_full_newton_matrix_in_esdirk(coils):
    """From newton_matrix.SCHUR_FROM DOFs on ESDIRK solves I - hg J through a Schur complement of
    J = [[0, I], [A, B]]; J = [[0, I, 0], [A, B, E], [0, F, G]] with coil currents is not of
    that form (with one coil its first rows look so when split at n // 2): the full matrix,
    and numpy's solution to the round-off of either."""
    from flexure.core.simulation import newton_matrix

    m = newton_matrix.SCHUR_FROM
    n = 2 * m + coils
    rng = np.random.default_rng(7)
    J = np.zeros((n, n))
    J[:m, m: 2 * m] = np.eye(m)
    J[m: 2 * m, :m] = -rng.uniform(0.0, 1e6, (m, m)) / m
    J[m: 2 * m, m: 2 * m] = -rng.uniform(0.0, 10.0, (m, m)) / m
    J[m: 2 * m, 2 * m:] = rng.uniform(0.0, 10.0, (m, coils))  # M^-1 DF^T b Km
    J[2 * m:, m: 2 * m] = -rng.uniform(0.0, 1e3, (coils, m))  # -Km / L b^T DF
    J[2 * m:, 2 * m:] = -2e3 * np.eye(coils)  # -R / L
    check_newton_solve(J, 2e-4, rng, reduced=False)


def test_a_static_equilibrium_refuses_an_unknown_input():
    model = build_model(truss(), source="vcm")
    with pytest.raises(SceneError, match="^vcm: unknown input 'G'; the model 'truss_1dof_x' "
                                         "has inputs: F"):
        static_equilibrium(model, inputs={"G": 1.0})
    with pytest.raises(SceneError, match="expected 1 inputs"):
        static_equilibrium(model, inputs=[1.0, 2.0])
    with pytest.raises(SceneError, match="the inputs must be finite"):
        static_equilibrium(model, inputs=[np.nan])
