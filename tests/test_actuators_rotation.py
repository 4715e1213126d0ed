"""Voice-coil actuators on the ports of 3-D scenes: beside moment inputs and angle outputs,
and on a moment port (a rotary voice coil). Checked against:

- the same scene without the actuator, its input held at the coil's steady force: the static
  equilibrium bit for bit, the state space's DC gain times Km / R, and the textbook
  cantilever (tip deflection and angle under a force and a moment);
- the linear state space (matrix exponential), for a small step of the drive and the moment;
- the exact solution of the 3-state ODE of a rigid body on a torsion beam turned by a rotary
  coil, J theta'' + k theta = Km i, L i' = u - R i - Km theta', and its poles;
- central differences of the engine's derivative (the load stiffness of the coil's moment
  Km i), and the linearisation's A at a rotated equilibrium;
- the FMU under fmpy against the in-process Simulator, bit for bit.
"""


import control
import numpy as np
import pytest
import scipy.linalg
from test_rotation_ports import EIZ, L, cantilever

from flexure.core import (
    Simulator,
    build_model,
    linearize,
    output_value,
    scene_toml,
    simulate,
    state_space,
    static_equilibrium,
)
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.scene.building import scene_key

KM, R, INDUCTANCE = 2.0, 2.0, 0.01  # N/A, ohm, H


def force_coil_scene(actuated=True):
    """The cantilever of test_rotation_ports (a spatial BEAM of length L, its tip nodes 3 and
    4) with the force F on 3.y driven by the coil VCM1 (voltage drive), the moment Mz about
    the global z axis on node 4, and the outputs y (3.y) and rz (the angle about z); without
    the coil when not `actuated`."""
    coil = {"VCM1": {"input": "F", "force_constant": KM, "resistance": R,
                     "inductance": INDUCTANCE}}
    return cantilever(inputs={"F": {"node": "3", "coordinate": "y"},
                              "Mz": {"node": "4", "coordinate": "rz"}},
                      outputs={"y": {"node": "3", "coordinate": "y"},
                               "rz": {"node": "4", "coordinate": "rz"}},
                      actuators=coil if actuated else {})


def step_response(system, u, times):
    """The states and outputs of a linear state space after a step u at t = 0 from zero: the
    matrix exponential of the system augmented with the held input."""
    A, B, C = (np.asarray(m) for m in (system.A, system.B, system.C))
    N = A.shape[0]
    augmented = np.zeros((N + 1, N + 1))
    augmented[:N, :N], augmented[:N, N] = A, B @ u
    start = np.zeros(N + 1)
    start[N] = 1.0
    states = np.array([scipy.linalg.expm(augmented * t) @ start for t in times])[:, :N]
    return states, states @ C.T


# -- a coil on a force port beside a moment input and an angle output -----------------------------
def test_a_coil_on_a_force_beside_a_moment_and_an_angle():
    model, plain = build_model(force_coil_scene()), build_model(force_coil_scene(False))
    assert [(p.quantity, p.unit) for p in model.inputs] == [("drive", "V"), ("moment", "N.m")]
    assert [p.unit for p in model.outputs] == ["m", "rad"]
    # statics: the drive u holds the coil's steady force Km u / R on 3.y
    u, moment = 0.01, 1e-4  # V, N m
    force = KM * (u / R)
    solution = static_equilibrium(model, inputs={"F": u, "Mz": moment})
    reference = static_equilibrium(plain, inputs={"F": force, "Mz": moment})
    assert np.array_equal(solution.x, reference.x)
    assert solution.inputs.tolist() == [u, moment]
    assert solution.port_values.tolist() == [force, moment]
    y = solution.x[model.coordinate_index("3.y")]
    textbook = [force * L**3 / (3 * EIZ) + moment * L**2 / (2 * EIZ),
                force * L**2 / (2 * EIZ) + moment * L / EIZ]  # m, rad
    rz = output_value(model, model.outputs[1], solution.x)
    np.testing.assert_allclose([y, rz], textbook, rtol=1e-7)  # measured 1.5e-9
    # the state space: the coil's state, and the DC gain of the drive Km / R times the force's
    system, forces = state_space(model), state_space(plain)
    assert system.nstates == forces.nstates + 1 and system.state_labels[-1] == "VCM1.current"
    gain, plain_gain = control.dcgain(system), control.dcgain(forces)
    np.testing.assert_allclose(plain_gain, [[L**3 / (3 * EIZ), L**2 / (2 * EIZ)],
                                            [L**2 / (2 * EIZ), L / EIZ]], rtol=1e-9)
    np.testing.assert_allclose(gain[:, 0], KM / R * plain_gain[:, 0], rtol=1e-9)
    np.testing.assert_allclose(gain[:, 1], plain_gain[:, 1], rtol=1e-9)
    # the motion after a step of both against the linear model (the tip deflects by 5e-4 L:
    # the geometric nonlinearity and the integrator's error are far below 1e-5)
    times = np.linspace(0.0, 0.02, 21)
    result = simulate(model, 0.02, inputs={"F": 5 * u, "Mz": 5 * moment}, rtol=1e-9,
                      output_times=times)
    states, outputs = step_response(system, np.array([5 * u, 5 * moment]), times)
    motion = result.output_array - result.output_array[0]
    for j in range(2):
        peak = np.abs(outputs[:, j]).max()
        assert np.abs(motion[:, j] - outputs[:, j]).max() <= 1e-5 * peak  # measured 1.1e-7
    current = states[:, -1]
    assert np.abs(result.currents[:, 0] - current).max() <= 1e-5 * np.abs(current).max()
    assert np.abs(current).max() > 0.1 * 5 * u / R  # the coil carries current


# -- a rotary voice coil: the coil on a moment port ---------------------------------------------
TORSION_L, TORSION_GIT, BODY_J = 0.1, 2.0, 1e-3  # m, N m^2, kg m^2
ROTARY_KM, ROTARY_R, ROTARY_L = 0.3, 2.0, 1e-3  # N m/A, ohm, H


def torsion_body(**coil):
    """A massless BEAM of length 0.1 m along x, rigid but in torsion, carrying a body of
    inertia J = 1e-3 kg m^2 about x that starts turned by 0.3 rad about x: one DOF,
    k = GIt / l = 20 N m/rad. The moment M about x is driven by the rotary coil VCM; the
    outputs are the angle theta about x and the angular velocity omega about x."""
    keys = {"input": "M", "force_constant": ROTARY_KM, "resistance": ROTARY_R,
            "inductance": ROTARY_L, **coil}
    return {
        "scene": {"name": "rotary_coil", "dimension": 3},
        "sections": {"s": {"EA": 1e7, "GIt": TORSION_GIT, "EIy": 1e3, "EIz": 1e3}},
        "nodes": {"1": {"position": [0.0, 0.0, 0.0], "fixed": ["x", "y", "z"]},
                  "2": {"rotation": [0.0, 0.0, 0.0], "fixed": True},
                  "3": {"position": [TORSION_L, 0.0, 0.0]},
                  "4": {"rotation": [0.3, 0.0, 0.0],
                        "inertia": [BODY_J, 2 * BODY_J, 2 * BODY_J]}},
        "elements": {"b": {"type": "BEAM", "nodes": ["1", "2", "3", "4"], "section": "s",
                           "y_axis": [0.0, 1.0, 0.0], "released": ["e2"]}},
        "inputs": {"M": {"node": "4", "coordinate": "rx"}},
        "outputs": {"theta": {"node": "4", "coordinate": "rx"},
                    "omega": {"node": "4", "coordinate": "rx", "quantity": "velocity"}},
        "actuators": {"VCM": keys},
    }


def rotary_matrix():
    """A of the exact ODE in [theta - theta0, omega, i]."""
    k = TORSION_GIT / TORSION_L
    return np.array([[0.0, 1.0, 0.0], [-k / BODY_J, 0.0, ROTARY_KM / BODY_J],
                     [0.0, -ROTARY_KM / ROTARY_L, -ROTARY_R / ROTARY_L]])


@pytest.mark.parametrize("method", ["cvode-bdf", "ida", "esdirk"])
def test_a_rotary_coil_follows_the_exact_solution_of_the_3_state_ode(method):
    """A 0.01 V step for two mechanical periods (rtol 1e-9): theta, omega and i within
    1e3 rtol of their peaks (the integrators' global error on this lightly damped
    oscillation, measured 31-441 rtol; below it the model's own floor, 1.3e-8 at rtol
    1e-11). The back-EMF is Km times the angular velocity about the axis: a factor off there
    or in the moment's generalised force would be an error of order one."""
    rtol = 1e-9
    model = build_model(torsion_body())
    A = rotary_matrix()
    augmented = np.zeros((4, 4))
    augmented[:3, :3] = A
    augmented[2, 3] = 0.01 / ROTARY_L
    period = 2 * np.pi / np.sqrt(TORSION_GIT / (TORSION_L * BODY_J))
    times = np.linspace(0.0, 2 * period, 81)
    exact = np.array([scipy.linalg.expm(augmented * t) @ [0, 0, 0, 1.0] for t in times])
    result = simulate(model, 2 * period, inputs={"M": 0.01}, method=method, rtol=rtol,
                      output_times=times)
    measured = np.column_stack([result.outputs["theta"] - 0.3, result.outputs["omega"],
                                result.currents[:, 0]])
    for j in range(3):
        peak = np.abs(exact[:, j]).max()
        assert np.abs(measured[:, j] - exact[:, j]).max() <= 1e3 * rtol * peak
    assert np.abs(exact[:, 2]).max() > 0.8 * 0.01 / ROTARY_R  # the current rises to u / R


def test_a_rotary_coils_statics_poles_and_units():
    """At rest the coil's moment Km u / R turns the body by Km u / (R k); the state space's
    poles are those of the exact ODE and its DC gain Km / (R k); Km's unit is N m/A."""
    model = build_model(torsion_body())
    k = TORSION_GIT / TORSION_L
    u = 0.05
    solution = static_equilibrium(model, inputs={"M": u})
    turn = ROTARY_KM * u / (ROTARY_R * k)
    assert solution.port_values.tolist() == [ROTARY_KM * (u / ROTARY_R)]
    assert output_value(model, model.outputs[0], solution.x) - 0.3 == pytest.approx(turn, rel=1e-6)
    system = state_space(model)
    assert system.state_labels[-1] == "VCM.current"
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(np.asarray(system.A))),
                               np.sort_complex(np.linalg.eigvals(rotary_matrix())),
                               rtol=1e-9)
    assert control.dcgain(system)[0, 0] == pytest.approx(ROTARY_KM / (ROTARY_R * k),
                                                         rel=1e-9)
    assert scene_key("actuators.VCM.force_constant", model).unit == "N.m/A"
    assert scene_key("actuators.VCM.force_constant").unit == "N/A"
    current = build_model(torsion_body(drive="current"))
    assert [scene_key(f"actuators.VCM.{key}", current).unit
            for key in ("amplifier_gain", "saturation", "resistance", "inductance")] == [
        "A/V", "A", "Ohm", "H"]
    assert scene_key("actuators.VCM.amplifier_gain", model).unit == "1"
    assert scene_key("actuators.VCM9.resistance", model) is None


def test_the_engine_takes_the_load_stiffness_of_a_coils_moment():
    """The cantilever turned about a skew axis, its moment Mz driven by a rotary coil (0.7 V
    held, i = 0.35 A, so Km i = 0.175 N m) and Mx a plain 0.2 N m: the engine's
    d ydot / d y against central differences of its derivative. At the equilibrium under the
    held inputs all of it to 1e-8 (measured 4e-10; the coil's moment Km i has the load
    stiffness 2 Km i P_z: taking the drive signal 0.7 instead changes the mechanical rows by
    1.8e-2), and it equals the linearisation's A (numpy: b from the ports, G0 with the port
    values). In motion the coil's blocks to 1e-8 (measured 2e-11), the mechanical rows to
    the Newton matrix's own 1e-3 (measured 1.1e-4), d idot / dq left out (approximated); the
    engine's augmented form (of large models) as its reduced one."""
    coil = {"VCM": {"input": "Mz", "force_constant": 0.5, "resistance": 2.0,
                    "inductance": 1e-3}}
    model = build_model(cantilever(
        rotation=(0.3, -0.2, 0.4), actuators=coil,
        inputs={"Mx": {"node": "4", "coordinate": "rx"},
                "Mz": {"node": "4", "coordinate": "rz"}},
        outputs={a: {"node": "4", "coordinate": a} for a in ("rx", "ry", "rz")}))
    n = model.declared_dof_count
    solution = static_equilibrium(model, inputs=[0.2, 0.7])
    assert solution.port_values.tolist() == [0.2, 0.5 * (0.7 / 2.0)]
    sim = Simulator(model)
    sim.set_inputs([0.2, 0.7])
    sim.reset(q0=solution.q, i0=[0.7 / 2.0])
    steps = np.concatenate([np.full(n, 1e-7), np.full(n, 1e-5), [1e-6]])

    def compare(y):
        numeric = np.zeros((y.size, y.size))
        for j, h in enumerate(steps):
            up, down = y.copy(), y.copy()
            up[j] += h
            down[j] -= h
            numeric[:, j] = (sim.derivative(0.0, up) - sim.derivative(0.0, down)) / (2 * h)
        analytic = sim.jacobian_matrix(0.0, y)
        return analytic, np.abs(analytic - numeric) / np.abs(numeric).max(axis=1,
                                                                            keepdims=True)

    analytic, error = compare(sim.state)
    assert error.max() <= 1e-8
    A, _, _ = linearize(model, solution).state_matrices()
    np.testing.assert_allclose(analytic, A, rtol=0, atol=1e-12 * np.abs(A).max())
    moving = sim.state + np.concatenate([np.zeros(n), np.full(n, 0.01), [0.05]])
    _, error = compare(moving)
    coil = 2 * n
    assert error[:, coil].max() <= 1e-8 and error[coil, n:].max() <= 1e-8
    assert error[n: 2 * n].max() <= 1e-3
    # the engine's two forms of the accelerations (reduced; augmented, of large models) agree
    forms = []
    for augmented in (False, True):
        data = EngineData(model, augmented=augmented)
        data.float_array("inputs")[:] = [0.2, 0.7]
        data.float_array("q_ref")[:] = sim.q_ref
        ydot, J = np.zeros(coil + 1), np.zeros((coil + 1) ** 2)
        assert engine.call(data, engine.OP_RHS, moving, ydot) == ed.OK
        assert engine.call(data, engine.OP_JACOBIAN, moving, J, s=0.0) == ed.OK
        forms.append((ydot, J))
    for reduced, augmented in zip(*forms, strict=True):
        np.testing.assert_allclose(augmented, reduced, rtol=0,
                                   atol=1e-13 * np.abs(reduced).max())  # measured 1.9e-16


# -- the FMU ---------------------------------------------------------------------------------------
def test_the_fmu_has_the_rotational_ports_and_the_coil_and_steps_as_the_simulator(tmp_path):
    """Variables: the drive F (V), the moment Mz (N.m), the angle rz (rad), the coil current
    (A) and the actuator's tunable keys with their units; stepped at 2 ms under fmpy, the angle
    and the current equal the in-process Simulator's bit for bit."""
    from fmpy import read_model_description
    from fmpy_slave import Slave

    from flexure.fmu import build_scene_fmu
    from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS

    data = force_coil_scene()
    data["actuators"]["VCM1"]["amplifier_gain"] = 1.0
    path = tmp_path / "cantilever.toml"
    path.write_text(scene_toml(data))
    fmu = build_scene_fmu(path, tmp_path / "cantilever.fmu",
                          tunable=["actuators.VCM1.force_constant",
                                   "actuators.VCM1.amplifier_gain"])
    md = read_model_description(str(fmu))
    variables = {v.name: v for v in md.modelVariables}
    assert (variables["F"].unit, variables["Mz"].unit, variables["rz"].unit) == (
        "V", "N.m", "rad")
    assert variables["F"].description == ("drive signal of actuator VCM1 (voltage amplifier) "
                                          "of the force on coordinate 3.y")
    assert variables["Mz"].description == "moment about the global z axis on node 4"
    assert (variables["VCM1.current"].causality, variables["VCM1.current"].unit) == (
        "output", "A")
    assert variables["actuators.VCM1.force_constant"].unit == "N/A"
    assert variables["actuators.VCM1.amplifier_gain"].unit == "1"
    refs = [variables[name].valueReference for name in ("rz", "VCM1.current")]
    inputs = [variables[name].valueReference for name in ("F", "Mz")]
    slave = Slave(fmu)
    try:
        sim = Simulator(build_model(data), method=METHODS[0], rtol=DEFAULT_RTOL)
        h = 2e-3
        signals = [(0.05, 1e-3), (0.05, 1e-3), (-0.02, 0.0), (0.0, -5e-4), (0.03, 5e-4)] * 2
        measured, expected = [], []
        for k, u in enumerate(signals):
            slave.fmu.setReal(inputs, list(u))
            slave.fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
            measured.append(slave.fmu.getReal(refs))
            sim.set_inputs(list(u))
            sim.advance_to(k * h + h)
            expected.append([sim.outputs()[1], sim.currents[0]])
        assert np.array_equal(np.array(measured), np.array(expected))
        assert np.abs(np.array(measured)[:, 0]).max() > 1e-5  # rad: it turns
    finally:
        slave.close()
