"""Moments, angles and rotation DOFs of 3-D rotational nodes.

A moment input about a global axis has the generalised force 2 E(lambda)^T M on the Euler
parameters; an angle output is the rotation-vector component about a global axis; a rotation
listed as a DOF is a ROTATION pseudo-element whose deformation is that angle
(flexure.core.mechanics.ports, flexure.core.elements.rotation). Checked against:

- the maths (tests/test_rotations.py): the rotation vector's derivatives, the angular
  velocity and the moment's power;
- a spatial cantilever BEAM: torsion M L / GIt and bending M L / EI from the moment input read
  by the angle output, statically and as the state space's DC gain; on a tip that starts
  rotated about a skew axis (where d phi / d lambda is not 2 E) the DC gain against central
  differences of the static solution;
- the engine: accelerations and tangent (with the moment's load stiffness) against the numpy
  path and finite differences;
- a rigid body on a torsion beam: its angle under a moment step against the undamped
  single-DOF response, with the torsion deformation or the node's rotation as the DOF;
- the closed loop and the FMU on a body on a round rod, the loop a moment and an angle.
"""

import copy
import json

import control
import numpy as np
import pytest

from flexure.core import (
    FlexureError,
    Mechanics,
    SceneError,
    Simulator,
    build_model,
    linearize,
    natural_frequencies,
    output_value,
    scene_toml,
    simulate,
    state_space,
    static_equilibrium,
)
from flexure.core.cli import main
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.mechanics.energy import mechanical_energy
from flexure.core.mechanics.ports import input_forces, input_stiffness
from flexure.core.numerics.rotations import normalized

L, EA, GIT, EIY, EIZ = 0.2, 1e6, 3.0, 5.0, 2.0  # m, N, N m^2


# -- scenes ------------------------------------------------------------------------------------

def cantilever(*, rotation=(0.0, 0.0, 0.0), dof=None, **extra):
    """A clamped spatial BEAM of length L along x, every deformation released; the tip's
    translational node 3 and rotational node 4 (which starts at `rotation`, a rotation
    vector); moment inputs and angle outputs about x, y, z on node 4."""
    tip = {"rotation": list(rotation), "inertia": [1e-4, 1e-4, 1e-4]}
    if dof:
        tip["dof"] = dof
    data = {
        "scene": {"name": "cantilever", "dimension": 3},
        "sections": {"s": {"EA": EA, "GIt": GIT, "EIy": EIY, "EIz": EIZ, "rho_A": 0.1}},
        "nodes": {"1": {"position": [0.0, 0.0, 0.0], "fixed": ["x", "y", "z"]},
                  "2": {"rotation": [0.0, 0.0, 0.0], "fixed": True},
                  "3": {"position": [L, 0.0, 0.0], "mass": 0.01}, "4": tip},
        "elements": {"b": {"type": "BEAM", "nodes": ["1", "2", "3", "4"], "section": "s",
                           "y_axis": [0.0, 1.0, 0.0],
                           "released": ["e1", "e2", "e3", "e4", "e5", "e6"]}},
        "inputs": {f"M{a}": {"node": "4", "coordinate": f"r{a}"} for a in "xyz"},
        "outputs": {f"r{a}": {"node": "4", "coordinate": f"r{a}"} for a in "xyz"},
    }
    data.update(extra)
    return data


def angles(model, x):
    return np.array([output_value(model, port, x) for port in model.outputs])


def test_ports_about_global_axes_are_built_with_their_units():
    model = build_model(cantilever())
    assert [p.unit for p in model.inputs] == ["N.m"] * 3
    assert [p.quantity for p in model.inputs] == ["moment"] * 3
    assert [(p.axis, p.unit) for p in model.outputs] == [("rx", "rad"), ("ry", "rad"),
                                                         ("rz", "rad")]
    euler = tuple(model.coordinate_index(f"4.lambda{k}") for k in range(4))
    assert all(p.euler == euler and p.coordinate is None for p in model.inputs)
    velocity = build_model(cantilever(outputs={"w": {"node": "4", "coordinate": "rz",
                                                     "quantity": "velocity"}}))
    assert velocity.outputs[0].unit == "rad/s"
    # the scene's rotation vector read back by the angle outputs
    rotated = build_model(cantilever(rotation=(0.1, -0.2, 0.3)))
    np.testing.assert_allclose(angles(rotated, rotated.initial_coordinates), [0.1, -0.2, 0.3],
                               rtol=1e-15)


@pytest.mark.parametrize("change, key, message", [
    ({"inputs": {"M": {"node": "4", "coordinate": "lambda1"}}}, "inputs.M.coordinate",
     "3-D rotational node: expected one of rx, ry, rz.*its Euler parameters are not ports"),
    ({"outputs": {"a": {"node": "4", "coordinate": "phi"}}}, "outputs.a.coordinate",
     "expected one of rx, ry, rz, the rotation about the global x, y or z axis, got 'phi'"),
    ({"outputs": {"a": {"node": "2", "coordinate": "rz"}}}, "outputs.a.node",
     "node '2' is fixed: a moment on it or its angle would do nothing"),
    ({"inputs": {"M": {"node": "4", "coordinate": "rz", "quantity": "position"}}},
     "inputs.M.quantity", "unknown key; expected one of coordinate, kind, node"),
    ({"outputs": {"a": {"node": "4", "coordinate": "rz", "quantity": "force"}}},
     "outputs.a.quantity", "expected one of position, velocity"),
])
def test_wrong_rotation_ports_are_named(change, key, message):
    data = cantilever(inputs={}, outputs={})
    data.update(change)
    with pytest.raises(SceneError, match=f"{key}: .*{message}"):
        build_model(data)


@pytest.mark.parametrize("node, message", [
    ({"rotation": [0.0, 0.0, 0.0], "dof": ["rw"]}, "nodes.4.dof: unknown name 'rw'; "
                                                   "expected one of rx, ry, rz"),
    ({"rotation": [0.0, 0.0, 0.0], "dof": ["rx", "rx"]}, "'rx' is listed 2 times"),
    ({"rotation": [0.0, 0.0, 0.0], "dof": ["rx"], "fixed": True},
     "nodes.4.dof: node '4' is fixed: its rotations cannot be DOFs"),
    ({"rotation": [0.0, 0.0, 0.0], "moment": [1.0, 0.0, 0.0]}, "nodes.4.moment: unknown key"),
])
def test_wrong_rotation_dofs_are_named(node, message):
    data = cantilever()
    data["nodes"]["4"] = node
    with pytest.raises(SceneError, match=message):
        build_model(data)


# -- statics and the state space: a cantilever's tip moments ----------------------------------

def test_cantilever_tip_moments_turn_it_by_the_textbook_angles():
    """Torsion M L / GIt and bending M L / EI (about y: EIy, about z: EIz), from the moment
    inputs read by the angle outputs: statically under 1e-4 N m (the beam's geometric
    nonlinearity is 1e-8 of that) and as the DC gain of the state space to 1e-10; the DC gain
    is diagonal, as the tip turns about the axis of the moment."""
    model = build_model(cantilever())
    compliance = np.diag([L / GIT, L / EIY, L / EIZ])  # rad/(N m)
    moment = 1e-4
    for k, name in enumerate(("Mx", "My", "Mz")):
        solution = static_equilibrium(model, inputs={name: moment})
        np.testing.assert_allclose(angles(model, solution.x), moment * compliance[k],
                                   rtol=1e-7, atol=1e-15)
    gain = control.dcgain(state_space(model))
    np.testing.assert_allclose(gain, compliance, rtol=1e-10, atol=1e-12 * L / EIZ)


def test_dc_gain_on_a_rotated_tip_equals_finite_differences_of_the_statics():
    """The tip starts rotated by 0.5 rad about a skew axis, so d phi / d lambda differs from
    the moment's 2 E: the state space's DC gain (B from 2 E^T, C from d phi / d lambda at the
    equilibrium) against central differences of static solutions under +-1e-5 N m, each
    pair of moment and angle, to 1e-6 (the differences' own error is (1e-5 / 1)^2)."""
    axis = normalized(np.array([1.0, 2.0, -0.5]))
    model = build_model(cantilever(rotation=tuple(0.5 * axis)))
    gain = control.dcgain(state_space(model))
    h = 1e-5
    numeric = np.zeros((3, 3))
    for k, name in enumerate(("Mx", "My", "Mz")):
        plus = angles(model, static_equilibrium(model, inputs={name: h}).x)
        minus = angles(model, static_equilibrium(model, inputs={name: -h}).x)
        numeric[:, k] = (plus - minus) / (2 * h)
    np.testing.assert_allclose(gain, numeric, rtol=1e-6, atol=1e-6 * np.abs(numeric).max())
    # not the gain of the small rotations 2 E lambda_dot: the Jacobian matters here
    assert np.abs(gain - np.diag([L / GIT, L / EIY, L / EIZ])).max() > 1e-3 * L / EIZ


def test_static_inputs_are_checked():
    model = build_model(cantilever())
    with pytest.raises(SceneError, match="unknown input 'F'; the model 'cantilever' has "
                                         "inputs: Mx, My, Mz"):
        static_equilibrium(model, inputs={"F": 1.0})
    with pytest.raises(SceneError, match="expected 3 inputs \\(Mx, My, Mz\\), got 2"):
        static_equilibrium(model, inputs=[1.0, 2.0])
    with pytest.raises(SceneError, match="the inputs must be finite"):
        static_equilibrium(model, inputs={"Mx": np.nan})


def test_a_moment_has_no_work_potential():
    model = build_model(cantilever())
    q = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    assert mechanical_energy(model, q, 0 * q, [0.0, 0.0, 0.0]) == pytest.approx(0.0, abs=1e-15)
    with pytest.raises(FlexureError, match="the moment input 'My' \\(0.5 N m\\) has no work "
                                           "potential"):
        mechanical_energy(model, q, 0 * q, [0.0, 0.5, 0.0])


# -- the engine ----------------------------------------------------------------------------------

def test_engine_with_moments_matches_the_numpy_path_and_finite_differences():
    """On the rotated cantilever under moments of 0.3 N m: the engine's qddot against
    M_bar^-1 DF^T r of the numpy path (r with `input_forces`), its tangent against Mechanics'
    K0 + G0 with the load stiffness of the moments, and against central differences of qddot
    (the load stiffness is not symmetric: a moment about a fixed axis is not conservative)."""
    model = build_model(cantilever(rotation=(0.3, -0.2, 0.4)))
    mech = Mechanics(model)
    u = np.array([0.3, -0.2, 0.25])
    solution = static_equilibrium(model, inputs=u)
    q = solution.q
    n = q.size
    for form in (False, True):
        data = EngineData(model, augmented=form)
        data.float_array("inputs")[:] = u

        def qddot(q, data=data):
            assert engine.call(data, engine.OP_EVALUATE, np.array(q), np.zeros(n)) == ed.OK
            return data.float_array("qddot").copy()

        qq = q + 1e-3 * np.arange(1, n + 1) / n  # off the equilibrium: a net force
        acc = qddot(qq)
        config = mech.kinematics.solve(qq, solution.x.copy())
        r = (input_forces(model, config.x, u)
             - config.De.T @ mech.constitutive_stress(config))
        mass = mech.mass_matrix(config)
        np.testing.assert_allclose(mass @ acc, config.DF.T @ r, rtol=1e-10,
                                   atol=1e-12 * np.abs(config.DF.T @ r).max())
        # the tangent at the equilibrium (at rest, qddot = 0) against the statics' stiffness
        acc = qddot(q)
        assert engine.call(data, engine.OP_TANGENT, acc) == ed.OK
        K = data.float_array("stiffness").reshape(n, n).copy()
        lin = linearize(model, solution)
        np.testing.assert_allclose(K, lin.K, rtol=1e-9, atol=1e-9 * np.abs(lin.K).max())
        # the moments' load stiffness -DF^T (2 u P_k) DF is all of K's skew part (P_k is
        # skew, K0 and G0 symmetric)
        load = -lin.DF.T @ input_stiffness(model, solution.x, u) @ lin.DF
        assert np.abs(load).max() > 1e-3
        np.testing.assert_allclose(0.5 * (K - K.T), load, rtol=0,
                                   atol=1e-9 * np.abs(K).max())
        h = 1e-7
        numeric = np.column_stack([(qddot(q + h * e) - qddot(q - h * e)) / (2 * h)
                                   for e in np.eye(n)])
        np.testing.assert_allclose(-lin.M0 @ numeric, K, rtol=1e-5,
                                   atol=1e-5 * np.abs(K).max())


# -- dynamics: a rigid body on a torsion beam -------------------------------------------------

TORSION_L, TORSION_GIT, BODY_J = 0.1, 2.0, 1e-3  # m, N m^2, kg m^2


def torsion_body(*, rotation=(0.0, 0.0, 0.0), dof=None):
    """A massless BEAM of length 0.1 m along x, rigid but in torsion, carrying a rigid body of
    inertia J = 1e-3 kg m^2 about x: one DOF, omega = sqrt(GIt / (l J)); the moment M and
    the angle theta (and its rate omega) about x on the body."""
    body = {"rotation": list(rotation), "inertia": [BODY_J, 2 * BODY_J, 2 * BODY_J]}
    if dof:
        body["dof"] = dof
    return {
        "scene": {"name": "torsion_body", "dimension": 3},
        "sections": {"s": {"EA": 1e7, "GIt": TORSION_GIT, "EIy": 1e3, "EIz": 1e3}},
        "nodes": {"1": {"position": [0.0, 0.0, 0.0], "fixed": ["x", "y", "z"]},
                  "2": {"rotation": [0.0, 0.0, 0.0], "fixed": True},
                  "3": {"position": [TORSION_L, 0.0, 0.0]}, "4": body},
        "elements": {"b": {"type": "BEAM", "nodes": ["1", "2", "3", "4"], "section": "s",
                           "y_axis": [0.0, 1.0, 0.0], "released": ["e2"]}},
        "inputs": {"M": {"node": "4", "coordinate": "rx"}},
        "outputs": {"theta": {"node": "4", "coordinate": "rx"},
                    "omega": {"node": "4", "coordinate": "rx", "quantity": "velocity"}},
    }


@pytest.mark.parametrize("dof", [None, ["rx"]], ids=["torsion-dof", "rotation-dof"])
def test_rigid_body_on_a_torsion_beam_follows_the_single_dof_response(dof):
    """A 1e-3 N m step for two periods: theta = 0.3 + (M l / GIt)(1 - cos w t) and its rate
    M l w / GIt sin w t, w = sqrt(GIt / (l J)), to 1e-6 of the amplitude (the torsion
    deformation's nonlinearity is theta^2 = 1e-8 of it); the body starts turned by 0.3 rad
    about x, the DOF chosen by flexure (the torsion deformation) or the node's rotation."""
    model = build_model(torsion_body(rotation=(0.3, 0.0, 0.0), dof=dof))
    assert model.dof_names == (["4.rx"] if dof else ["b.e2"])
    w = np.sqrt(TORSION_GIT / (TORSION_L * BODY_J))
    assert natural_frequencies(model).frequencies_hz[0] == pytest.approx(w / (2 * np.pi),
                                                                         rel=1e-10)
    moment = 1e-3
    amplitude = moment * TORSION_L / TORSION_GIT
    result = simulate(model, 4 * np.pi / w, inputs={"M": moment}, rtol=1e-10,
                      method="cvode-adams")
    t = result.times
    np.testing.assert_allclose(result.outputs["theta"], 0.3 + amplitude * (1 - np.cos(w * t)),
                               rtol=0, atol=1e-6 * amplitude)
    np.testing.assert_allclose(result.outputs["omega"], amplitude * w * np.sin(w * t),
                               rtol=0, atol=1e-6 * amplitude * w)
    if dof:  # the DOF is the angle itself
        np.testing.assert_allclose(result.q[:, 0], result.outputs["theta"], rtol=0, atol=1e-15)


def test_rotation_dof_and_torsion_dof_give_the_same_linear_model():
    chosen = build_model(torsion_body(rotation=(0.2, 0.1, 0.0)))
    listed = build_model(torsion_body(rotation=(0.2, 0.1, 0.0), dof=["rx"]))
    np.testing.assert_allclose(control.dcgain(state_space(listed)),
                               control.dcgain(state_space(chosen)), rtol=1e-12)
    np.testing.assert_allclose(natural_frequencies(listed).frequencies_hz,
                               natural_frequencies(chosen).frequencies_hz, rtol=1e-12)


def test_three_rotation_dofs_describe_the_mechanism_of_the_chosen_ones():
    """The rotated cantilever with the tip's x, y, z and rx, ry, rz as its six DOFs against
    the same scene with the DOFs flexure chooses (translations and deformations): the same
    frequencies and DC gains (1e-9), the same motion under moments (1e-7 of it, the
    integrators' tolerance); the engine's tangent with the angles' second derivatives against
    central differences of its accelerations."""
    rotation = (0.3, -0.2, 0.4)
    listed_data = cantilever(rotation=rotation, dof=["rx", "ry", "rz"])
    listed_data["nodes"]["3"]["dof"] = ["x", "y", "z"]
    listed, chosen = build_model(listed_data), build_model(cantilever(rotation=rotation))
    assert listed.dof_names == ["3.x", "3.y", "3.z", "4.rx", "4.ry", "4.rz"]
    np.testing.assert_allclose(natural_frequencies(listed).frequencies_hz,
                               natural_frequencies(chosen).frequencies_hz, rtol=1e-9)
    np.testing.assert_allclose(control.dcgain(state_space(listed)),
                               control.dcgain(state_space(chosen)), rtol=1e-9,
                               atol=1e-9 * L / EIZ)
    u = {"Mx": 0.02, "My": -0.01, "Mz": 0.015}
    runs = [simulate(m, 0.005, inputs=u, rtol=1e-10, method="cvode-adams",
                     output_times=np.linspace(0, 0.005, 11)) for m in (listed, chosen)]
    for name in ("rx", "ry", "rz"):
        motion = runs[1].outputs[name] - runs[1].outputs[name][0]
        np.testing.assert_allclose(runs[0].outputs[name], runs[1].outputs[name], rtol=0,
                                   atol=1e-7 * np.abs(motion).max())
    data = EngineData(listed)
    data.float_array("inputs")[:] = list(u.values())
    q = runs[0].q[-1]
    n = q.size

    def qddot(q):
        assert engine.call(data, engine.OP_EVALUATE, np.array(q), np.zeros(n)) == ed.OK
        return data.float_array("qddot").copy()

    assert engine.call(data, engine.OP_TANGENT, qddot(q)) == ed.OK
    K = data.float_array("stiffness").reshape(n, n).copy()
    mass = data.float_array("mass").reshape(n, n).copy()  # M_bar, formed by the tangent
    h = 1e-7
    numeric = np.column_stack([(qddot(q + h * e) - qddot(q - h * e)) / (2 * h)
                               for e in np.eye(n)])
    np.testing.assert_allclose(-mass @ numeric, K, rtol=0, atol=1e-5 * np.abs(K).max())


def test_simulator_outputs_are_the_ports_of_the_state():
    """Simulator.outputs (angles from the engine's positions, rates from DF qdot) equal the
    numpy ports at the same state."""
    model = build_model(cantilever(rotation=(0.3, -0.2, 0.4), outputs={
        "rz": {"node": "4", "coordinate": "rz"},
        "wy": {"node": "4", "coordinate": "ry", "quantity": "velocity"},
        "x": {"node": "3", "coordinate": "x"}}))
    sim = Simulator(model, method="esdirk", rtol=1e-8)
    sim.set_inputs([0.01, 0.02, -0.03])
    sim.advance_to(0.002)
    measured = sim.outputs()
    config = Mechanics(model).kinematics.solve(sim.q, model.initial_coordinates.copy())
    xdot = config.DF @ sim.qdot
    expected = [output_value(model, p, config.x, xdot) for p in model.outputs]
    np.testing.assert_allclose(measured, expected, rtol=1e-12, atol=1e-15)
    assert measured[1] != 0.0


# -- the closed loop and the FMU: a body on a round rod ------------------------------------------

def rod_body():
    """A disk-like body (0.02 kg; 1e-4 kg m^2 about the rod, 2e-5 across) on a steel rod of
    2 mm diameter and 50 mm length along x, every deformation released (6 DOFs, chosen by
    flexure: the body starts turned by 0.2 rad about x). Torsion is the lowest mode (25 Hz,
    the next 49 Hz); the loop is the moment M and the angle theta about x."""
    return {
        "scene": {"name": "rod_body", "dimension": 3},
        "sections": {"rod": {"E": 2.1e11, "G": 8.0e10, "diameter": 0.002, "rho": 7850.0,
                             "beta": 1e-4}},
        "nodes": {"1": {"position": [0.0, 0.0, 0.0], "fixed": ["x", "y", "z"]},
                  "2": {"rotation": [0.0, 0.0, 0.0], "fixed": True},
                  "3": {"position": [0.05, 0.0, 0.0], "mass": 0.02},
                  "4": {"rotation": [0.2, 0.0, 0.0], "inertia": [1e-4, 2e-5, 2e-5]}},
        "elements": {"rod": {"type": "BEAM", "nodes": ["1", "2", "3", "4"], "section": "rod",
                             "y_axis": [0.0, 1.0, 0.0],
                             "released": ["e1", "e2", "e3", "e4", "e5", "e6"]}},
        "inputs": {"M": {"node": "4", "coordinate": "rx"}},
        "outputs": {"theta": {"node": "4", "coordinate": "rx"},
                    "omega": {"node": "4", "coordinate": "rx", "quantity": "velocity"}},
    }


def test_closed_loop_on_a_moment_and_an_angle_tracks_1_mrad(tmp_path, capsys):
    """`flexure loop` on the rod scene: 1 mrad in 0.5 s within 0.1 % of the stroke, the
    summary in rad and N m."""
    path = tmp_path / "rod_body.toml"
    path.write_text(scene_toml(rod_body()))
    assert main(["loop", str(path), "--stroke", "1e-3", "--duration", "0.5", "--settle", "0.1",
                 "--no-plot", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["units"] == {"position": "rad", "force": "N m"}
    assert summary["loops"] == ["M -> theta"]
    assert summary["passed"] and summary["error_ratio"] < 1e-3
    assert main(["loop", str(path), "--stroke", "1e-3", "--duration", "0.5", "--settle", "0.1",
                 "--no-plot"]) == 0
    out = capsys.readouterr().out
    assert "stroke (rad)" in out and "max |error| (rad)" in out and "PASSED" in out


def test_fmu_with_a_moment_input_and_angle_outputs_equals_the_simulator(tmp_path):
    """The FMU of the rod scene under fmpy: the variables M (N.m), theta (rad) and omega
    (rad/s); a 1e-3 N m step stepped at 1 ms for 20 ms equals the in-process simulator on the
    same grid (the same code, bundled) to 1e-12 of the motion."""
    from fmpy import read_model_description, simulate_fmu

    from flexure.fmu import build_scene_fmu
    from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS

    path = tmp_path / "rod_body.toml"
    path.write_text(scene_toml(rod_body()))
    fmu = build_scene_fmu(path, tmp_path / "rod_body.fmu")
    variables = {v.name: v for v in read_model_description(str(fmu)).modelVariables}
    assert (variables["M"].causality, variables["M"].unit) == ("input", "N.m")
    assert (variables["theta"].unit, variables["omega"].unit) == ("rad", "rad/s")
    assert "rotation about the global x axis of node 4" in variables["theta"].description
    moment, h, steps = 1e-3, 1e-3, 20
    signal = np.array([(0.0, moment), (steps * h, moment)],
                      dtype=[("time", float), ("M", float)])
    run = simulate_fmu(str(fmu), stop_time=steps * h, step_size=h, output_interval=h,
                       input=signal, output=["theta", "omega"])
    sim = Simulator(build_model(rod_body()), method=METHODS[0], rtol=DEFAULT_RTOL)
    expected = [sim.outputs()]
    sim.set_inputs([moment])
    for k in range(steps):
        sim.advance_to((k + 1) * h)
        expected.append(sim.outputs())
    expected = np.array(expected)
    motion = np.abs(expected[:, 0] - expected[0, 0]).max()
    assert motion > 1e-6  # it turns
    np.testing.assert_allclose(run["theta"], expected[:, 0], rtol=0, atol=1e-12 * motion)
    np.testing.assert_allclose(run["omega"], expected[:, 1], rtol=0,
                               atol=1e-12 * np.abs(expected[:, 1]).max())


def test_loop_refuses_a_moment_without_its_angle():
    """A moment input with only an angle about another axis: no colocated loop, named."""
    from flexure.controllers import ControlDesignError, run_loop

    data = rod_body()
    data["outputs"] = {"phi_y": {"node": "4", "coordinate": "ry"}}
    with pytest.raises(ControlDesignError, match="input 'M' has no position output on the "
                                                 "same coordinate \\(moment about the global "
                                                 "x axis on node 4\\)"):
        run_loop(build_model(copy.deepcopy(data)), stroke=1e-3, duration=0.05)


# -- the other consumers of ports: stresses along a trajectory, sweeps -------------------------

def test_stresses_along_take_a_moment_by_its_orientation():
    """The rod with its torsion prescribed rigid, so that the moment about it is a reaction
    (the multiplier of e2): at rest under the moment, the trajectory path's von Mises
    stresses (the moment input given) equal the static ones and the torsion's sqrt(3) tau,
    tau = 16 M / (pi d^3); without the input there is no torsion, and no stress."""
    from flexure.core import beam_stresses, stresses_along

    data = rod_body()
    data["elements"]["rod"]["released"] = ["e1", "e3", "e4", "e5", "e6"]
    model = build_model(data)
    moment = 0.05  # N m: tau = 32 MPa
    solution = static_equilibrium(model, inputs={"M": moment})
    state = np.concatenate([solution.q, np.zeros(solution.q.size)])[None]
    _, along = stresses_along(model, state, inputs=[[moment]])
    static = beam_stresses(model, solution.x, solution.stress_resultants).von_mises
    np.testing.assert_allclose(along[0], static, rtol=1e-9)
    np.testing.assert_allclose(static, np.sqrt(3.0) * 16 * moment / (np.pi * 0.002**3),
                               rtol=1e-9)
    _, unloaded = stresses_along(model, state)
    assert np.abs(unloaded).max() < 1e-9 * static.max()


def test_sweep_column_of_an_angle_is_its_change():
    """A static sweep's column of an angle output (rad): the angle's change from the scene's
    orientation, here the tip's turn under gravity (1 m/s^2 on a 0.5 kg tip and the beam's
    0.1 kg/m: (m L^2 / 2 + rho_A L^3 / 6) g / EIy about y); the tip starts turned by 0.1 rad
    about z, so the rotation vector's y component changes by that turn times
    1 - 0.1^2 / 12 (dphi / dtheta = I + [phi x] / 2 + [phi x]^2 / 12 + ...)."""
    from flexure.core.sweep.grid import columns, evaluate_point

    data = cantilever(rotation=(0.0, 0.0, 0.1))
    data["scene"]["gravity"] = [0.0, 0.0, -1.0]
    data["nodes"]["3"]["mass"] = 0.5
    model = build_model(data)
    assert columns(model, ("static",)) == ["static.rx [rad]", "static.ry [rad]",
                                           "static.rz [rad]"]
    row = evaluate_point(data, {}, analyses=("static",))
    assert row["status"] == "ok"
    solution = static_equilibrium(model)
    change = angles(model, solution.x) - angles(model, model.initial_coordinates)
    assert [row[c] for c in columns(model, ("static",))] == pytest.approx(change, abs=1e-15)
    turn = (0.5 * L**2 / 2 + 0.1 * L**3 / 6) * 1.0 / EIY
    assert row["static.ry [rad]"] == pytest.approx(turn * (1 - 0.1**2 / 12), rel=1e-4)
