"""Kinematic inputs ([inputs.NAME] kind = "motion") and outputs on elements: the scene, the
count, statics at prescribed values against the force-driven scene, the state space from
positions against closed-form transfer functions and the force-driven one; inverse dynamics
and the response to motion: test_inverse_dynamics.py."""

import copy

import numpy as np
import pytest
from kinematic_scenes import C1, C2, K1, K2, M1, M2, chain, pendulum, scene, sine, with_motion

from flexure.core import build_model, linearize, load_scene, natural_frequencies, static_equilibrium
from flexure.core.analysis.inverse_dynamics import inverse_dynamics
from flexure.core.analysis.motion_statespace import motion_state_space
from flexure.core.errors import ConstraintError, SceneError, SimulationError
from flexure.core.mechanics.motions import motion_values

# -- the scene and the count ---------------------------------------------------------------

def test_a_kinematic_input_takes_a_dof_from_the_count():
    model = build_model(with_motion("truss_1dof_x", "2", "x", value=0.101))
    assert model.dof_count() == {"nx": 4, "nxo": 3, "neo": 0, "nki": 1, "ndof": 0}
    assert model.free_dof_names == [] and model.dof_names == ["2.x"]
    assert [p.name for p in model.kinematic_inputs] == ["X"]
    assert [p.name for p in model.inputs] == ["F"]  # the force input stays a force input
    assert model.kinematic_inputs[0].unit == "m"
    np.testing.assert_array_equal(model.motion_values, [0.101])
    # the value defaults to the scene's coordinate
    assert build_model(with_motion("truss_1dof_x", "2", "x")).motion_values[0] == 0.1


def test_dofs_are_chosen_around_the_kinematic_inputs():
    """stage_planar_3dof without DOF lists, 3.x prescribed: flexure chooses two DOFs among the
    others (never 3.x again), and the model is exactly constrained."""
    data = with_motion("stage_planar_3dof", "3", "x")
    for node in data["nodes"].values():
        node.pop("dof", None)
    model = build_model(data)
    assert model.dof_count()["ndof"] == 2 and model.dof_count()["nki"] == 1
    assert "3.x" not in model.chosen_dofs and len(model.chosen_dofs) == 2
    assert model.dof_names.count("3.x") == 1


def _pushing_truss(k, delta):
    """A truss (EA 1e6 N) whose elongation is prescribed (delta, m) pushes a spring k (N/m)
    against a wall."""
    return {"sections": {"act": {"EA": 1e6}, "wall": {"kx": k}},
            "nodes": {"0": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                      "1": {"position": [0.1, 0.0]},
                      "2": {"position": [0.2, 0.0], "fixed": ["x", "y"]}},
            "elements": {"act": {"type": "PLTRUSS", "nodes": ["0", "1"], "section": "act"},
                         "wall": {"type": "PLSPRING", "nodes": ["1", "2"], "section": "wall",
                                  "released": ["e1"]}},
            "inputs": {"L": {"kind": "motion", "element": "act", "deformation": "e1",
                             "value": delta}}}


def test_a_deformation_input_and_its_effort():
    """A truss whose elongation is prescribed (delta) pushes a spring k against a wall: the
    effort is k delta, the truss's stress resultant -k delta (it pushes)."""
    k, delta = 2000.0, 1e-3
    data = _pushing_truss(k, delta)
    model = build_model(data)
    assert model.dof_count() == {"nx": 6, "nxo": 4, "neo": 1, "nki": 1, "ndof": 0}
    solution = static_equilibrium(model)
    assert solution.efforts()["L"] == pytest.approx(k * delta, rel=1e-12)
    assert solution.stresses()["act.e1"] == pytest.approx(-k * delta, rel=1e-12)
    assert solution.coordinates()["1.x"] == pytest.approx(0.1 + delta, rel=1e-14)


@pytest.mark.parametrize("change, key, words", [
    (lambda d: d["inputs"]["X"].update(kind="speed"), "inputs.X.kind", "expected one of"),
    (lambda d: d["inputs"]["X"].update(coordinate="y"), "inputs.X.coordinate", "is fixed"),
    (lambda d: d["inputs"]["X"].update(gain=2.0), "inputs.X", "gain"),
    (lambda d: d["inputs"]["X"].update(value="far"), "inputs.X.value", "number"),
    (lambda d: d["nodes"]["2"].update(dof=["x"]), "inputs.X.coordinate", "remove it from"),
])
def test_a_wrong_kinematic_input_is_named(change, key, words):
    data = with_motion("truss_1dof_x", "2", "x")
    change(data)
    with pytest.raises(SceneError, match=key) as error:
        build_model(data)
    assert words in str(error.value)


@pytest.mark.parametrize("port, key, words", [
    ({"element": "spring", "deformation": "e1"}, "inputs.X.deformation", "released"),
    ({"element": "spring", "deformation": "e7"}, "inputs.X.deformation", "no deformation"),
    ({"element": "nothing", "deformation": "e1"}, "inputs.X.deformation", "no deformation"),
])
def test_a_wrong_deformation_input_is_named(port, key, words):
    data = scene("truss_1dof_x")
    data["inputs"]["X"] = {"kind": "motion", **port}
    with pytest.raises(SceneError, match=key) as error:
        build_model(data)
    assert words in str(error.value)


def body(**inputs):
    """A free body B (principal inertia 0.01, 0.02, 0.03 kg m^2) whose rotations about x and y
    are DOFs, moments Mx, My on them, their angles as outputs, and `inputs` besides."""
    return {"scene": {"name": "body", "dimension": 3},
            "nodes": {"B": {"rotation": [0.0, 0.0, 0.0], "inertia": [0.01, 0.02, 0.03],
                            "dof": ["rx", "ry"]},
                      "G": {"rotation": [0.0, 0.0, 0.0], "fixed": True}},
            "inputs": {"Mx": {"node": "B", "coordinate": "rx"},
                       "My": {"node": "B", "coordinate": "ry"}} | inputs,
            "outputs": {"ax": {"node": "B", "coordinate": "rx"},
                        "ay": {"node": "B", "coordinate": "ry"}}}


def test_a_rotation_about_a_global_axis_as_a_kinematic_input():
    """B's rotation about z prescribed: its ROTATION angle, rad, counted as NKI."""
    model = build_model(body(Z={"kind": "motion", "node": "B", "coordinate": "rz",
                                "value": 0.1}))
    assert model.dof_count() == {"nx": 6, "nxo": 3, "neo": 0, "nki": 1, "ndof": 2}
    assert model.kinematic_inputs[0].unit == "rad"
    assert model.free_dof_names == ["B.rx", "B.ry"]
    np.testing.assert_array_equal(model.motion_values, [0.1])


@pytest.mark.parametrize("port, key, words", [
    ({"node": "G", "coordinate": "rz"}, "inputs.Z.node", "is fixed"),
    ({"node": "B", "coordinate": "lambda1"}, "inputs.Z.coordinate", "expected one of rx"),
    ({"node": "B", "coordinate": "rx"}, "inputs.Z.coordinate", "is a DOF"),
    ({"node": "B", "coordinate": "rz", "gain": 1}, "inputs.Z", "gain"),
])
def test_a_wrong_rotation_input_is_named(port, key, words):
    with pytest.raises(SceneError, match=key) as error:
        build_model(body(Z={"kind": "motion"} | port))
    assert words in str(error.value)


def test_the_count_names_the_kinematic_inputs():
    """3.x prescribed while the scene lists 5.x as a DOF: one DOF too many."""
    data = with_motion("stage_planar_1dof", "3", "x")
    data["nodes"]["5"]["dof"] = ["x"]
    with pytest.raises(ConstraintError, match=r"NDOF = NX - NXO - NEO - NKI = 12 - 6 - 5 - 1 "
                                              r"= 0, but the scene declares 1 DOF\(s\): 5.x"):
        build_model(data)


def test_motion_values_are_checked():
    model = build_model(with_motion("truss_1dof_x", "2", "x"))
    np.testing.assert_array_equal(motion_values(model, {"X": 0.2}), [0.2])
    with pytest.raises(SceneError, match="unknown kinematic input 'Y'.*: X"):
        motion_values(model, {"Y": 0.2})
    with pytest.raises(SceneError, match="expected 1 kinematic inputs"):
        motion_values(model, [0.1, 0.2])
    with pytest.raises(SceneError, match="must be finite"):
        motion_values(model, [np.nan])


def test_a_simulation_with_prescribed_motion_needs_the_moves_duration():
    """Without it (what the loop's plant and the FMU make) the Simulator refuses the model
    before compiling; with it, test_prescribed_motion.py."""
    from flexure.core.simulation.simulator import Simulator

    model = build_model(with_motion("truss_1dof_x", "2", "x"))
    with pytest.raises(SimulationError, match=r"kinematic inputs \(X\): a time simulation "
                                              r"needs the duration of their move"):
        Simulator(model)


# -- statics ------------------------------------------------------------------------------

def test_statics_at_a_prescribed_position_equal_the_force_driven_scene():
    """stage_planar_3dof under gravity with 3.x prescribed 5 mm: the pose and every stress
    resultant equal those of the force-driven scene loaded by the computed effort, and its
    3.x is the prescribed 5 mm."""
    driven = with_motion("stage_planar_3dof", "3", "x", value=0.005)
    driven["scene"]["gravity"] = [0.0, -9.81]
    moved = static_equilibrium(build_model(driven))
    forced_data = scene("stage_planar_3dof")
    forced_data["scene"]["gravity"] = [0.0, -9.81]
    forced_model = build_model(forced_data)
    forced = static_equilibrium(forced_model, inputs={"F": moved.efforts()["X"]})
    assert np.max(np.abs(moved.x - forced.x)) < 1e-13  # m and rad, on a 0.1 m stage
    assert forced.coordinates()["3.x"] == pytest.approx(0.005, abs=1e-13)
    scale = np.max(np.abs(forced.stress_resultants))
    assert np.max(np.abs(moved.stress_resultants - forced.stress_resultants)) < 1e-9 * scale
    # the value given to static_equilibrium replaces the scene's
    again = static_equilibrium(build_model(driven), motions={"X": 0.0})
    assert again.coordinates()["3.x"] == pytest.approx(0.0, abs=1e-16)


def test_held_inputs_give_the_modes_of_the_rest():
    """The chain with node 1 held: node 2 on spring b alone, f = sqrt(k2 / m2) / (2 pi)."""
    model = build_model(chain())
    found = natural_frequencies(model).frequencies_hz
    assert found == pytest.approx([np.sqrt(K2 / M2) / (2 * np.pi)], rel=1e-12)
    assert linearize(model).DF.shape == (model.nx, 1)


# -- the state space from positions -------------------------------------------------------

@pytest.mark.parametrize("rho_A", [0.0, 0.6])
def test_state_space_from_positions_against_the_closed_form(rho_A):
    """y2 / u = (k2 + c2 s - m12 s^2) / ((m2 + m22) s^2 + c2 s + k2) and the effort
    F / u = (m1 + m11) s^2 + (c1 + c2) s + k1 + k2 - (c2 s + k2 - m12 s^2) y2 / u, with the
    truss's consistent mass rho_A l / 6 [[2, 1], [1, 2]] (zero for the spring)."""
    space = motion_state_space(build_model(chain(rho_A=rho_A)))
    assert space.inputs == ["u"] and space.outputs == ["x2", "v2", "u.effort"]
    m11 = m22 = rho_A * 0.1 / 3
    m12 = rho_A * 0.1 / 6
    for omega in (0.5, 30.0, 44.7, 300.0):
        s = 1j * omega
        y = (K2 + C2 * s - m12 * s * s) / ((M2 + m22) * s * s + C2 * s + K2)
        force = ((M1 + m11) * s * s + (C1 + C2) * s + K1 + K2
                 - (C2 * s + K2 - m12 * s * s) * y)
        H = space.frequency_response(s)[:, 0]
        np.testing.assert_allclose(H, [y, s * y, force], rtol=1e-12)
    # with mass coupling the velocity needs u' (the feed-through of the input's rate)
    assert space.needs_rates() == (["v2", "u.effort"] if rho_A else ["u.effort"])
    plant = space.system()
    assert plant.output_labels == ["x2"] + ([] if rho_A else ["v2"])
    with pytest.raises(SceneError, match="u.effort.*frequency_response"):
        space.system(["u.effort"])
    with pytest.raises(SceneError, match="no output 'w'"):
        space.system(["w"])


def test_state_space_of_a_stage_moved_by_its_position():
    """stage_planar_1dof with 3.x prescribed: nothing left to move, the effort is
    m s^2 + c s + k with the leaves' 24 EI / L^3, 24 EdI / L^3 and the bar's mass plus
    13/35 of each leaf's."""
    data = with_motion("stage_planar_1dof", "3", "x")
    leaf = data["sections"]["leaf"]
    EI = leaf["E"] * leaf["width"] * leaf["height"] ** 3 / 12
    m = 0.206 + 2 * 13 / 35 * leaf["rho"] * leaf["width"] * leaf["height"] * 0.1
    space = motion_state_space(build_model(data))
    assert space.A.shape == (0, 0)
    effort = space.outputs.index("X.effort")
    assert space.D[effort, 0] == pytest.approx(24 * EI / 0.1 ** 3, rel=1e-12)
    assert space.D1[effort, 0] == pytest.approx(24 * leaf["EdI"] / 0.1 ** 3, rel=1e-12)
    assert space.D2[effort, 0] == pytest.approx(m, rel=1e-12)


def test_a_state_space_from_positions_needs_a_kinematic_input():
    with pytest.raises(SceneError, match="needs a kinematic input"):
        motion_state_space(load_scene("truss_1dof_x"))


# -- where the other analyses meet them ----------------------------------------------------

def test_analyze_prints_the_count_and_the_efforts():
    """`flexure analyze`: the count with NKI, the held value and its effort (equal to the
    statics'), the modes of the DOFs left with the input held."""
    from flexure.core.cli.analyze import analyze, render

    model = build_model(with_motion("stage_planar_3dof", "3", "x", value=0.002))
    result = analyze(model, static=True, modes=2)
    assert result["dofs"] == ["3.y", "4.phi"] and result["kinematic_inputs"] == ["X"]
    effort = static_equilibrium(model).efforts()["X"]
    assert result["static"]["kinematic_inputs"]["X"] == {"value": 0.002, "start": 0.0,
                                                         "effort": effort}
    assert len(result["modes"]["frequencies_hz"]) == 2
    text = render(result)
    assert "NDOF = NX - NXO - NEO - NKI = 12 - 6 - 3 - 1 = 2" in text
    assert "kinematic inputs: X" in text


def test_sensitivities_refuse_kinematic_inputs():
    from flexure.core import sensitivities

    model = build_model(with_motion("stage_planar_3dof", "3", "x"))
    with pytest.raises(SceneError, match=r"kinematic inputs \(X\) are not supported"):
        sensitivities(model, ["sections.leaf.E"])


def dc_gain(A, B, C, D):
    """C (-A^-1) B + D: the static gain of a state space (A regular)."""
    return C @ np.linalg.solve(-A, B) + D if A.size else D


def test_state_space_from_positions_inverts_the_force_driven_one_at_dc():
    """stage_planar_3dof at rest: with 3.x prescribed, the effort per metre is 1 / (x per N)
    of the force-driven state space, and y per metre of 3.x is (y per N) / (x per N)."""
    from flexure.core.analysis.statespace import state_space_matrices

    forced = load_scene("stage_planar_3dof")
    A, B, C, D = state_space_matrices(forced)[:4]
    per_newton = dc_gain(A, B, C, D)[:, 0]  # outputs x (3.x), y (3.y) per N of F
    space = motion_state_space(build_model(with_motion("stage_planar_3dof", "3", "x")))
    per_metre = dc_gain(space.A, space.B, space.C, space.D)[:, 0]
    assert space.outputs == ["x", "y", "X.effort"]
    assert per_metre[0] == pytest.approx(1.0, rel=1e-12)
    assert per_metre[1] == pytest.approx(per_newton[1] / per_newton[0], rel=1e-8, abs=1e-14)
    assert per_metre[2] == pytest.approx(1.0 / per_newton[0], rel=1e-9)


@pytest.mark.slow
def test_the_manipulator_moved_by_its_six_carriages():
    """The chapter's Fig. 3.4 model driven as the chapter drives it: the six carriage
    positions prescribed (moved 0 to 0.2 mm), the pose and the six efforts out; the
    force-driven scene under those six forces reaches the same pose (to the statics'
    tolerance, 1e-11 of the 0.3 m size) and puts each carriage where it was prescribed.
    About a minute: two loaded equilibria of 816 DOFs."""
    base = scene("manipulator")
    data = copy.deepcopy(base)
    moves = {"F1": 2e-4, "F2": -1e-4, "F3": 1.5e-4, "F4": 0.0, "F5": -2e-4, "F6": 1e-4}
    for name, port in base["inputs"].items():
        axis = "xyz".index(port["coordinate"])
        start = base["nodes"][port["node"]]["position"][axis]
        data["inputs"][name] = {"kind": "motion", "node": port["node"],
                                "coordinate": port["coordinate"], "value": start + moves[name]}
    moved_model = build_model(data)
    assert moved_model.dof_count()["nki"] == 6
    assert moved_model.dof_count()["ndof"] == load_scene("manipulator").ndof - 6
    moved = static_equilibrium(moved_model)
    forced_model = build_model(base)
    forced = static_equilibrium(forced_model, inputs=moved.input_efforts)
    assert np.max(np.abs(moved.x - forced.x)) < 3e-11  # m, rad, Euler parameters
    for name, port in base["inputs"].items():
        i = forced_model.coordinate_index(f"{port['node']}.{port['coordinate']}")
        assert forced.x[i] - forced_model.initial_coordinates[i] == pytest.approx(
            moves[name], abs=3e-11)


def test_the_scene_api_and_an_fmu_build(tmp_path):
    """Scene.input(kind="motion") builds a kinematic input; an FMU of a scene with one takes
    its position (m) and gives its effort (N): truss_1dof_x's node 2 moved to 0.101 m in the
    first 1 ms step and held there, its effort after 5 steps is k (1 mm) - 1 N (the scene's
    force; nothing left free, at rest once the last four positions set are equal) to 1e-12
    (docs/fmu.md; tests/test_fmu_motion.py has the rest)."""
    from fmpy_slave import Slave

    from flexure.core import Scene, scene_toml
    from flexure.fmu.builder import build_scene_fmu

    s = Scene("pusher", dimension=2)
    s.section("act", EA=1e6).section("wall", kx=2000.0)
    s.node("0", position=[0.0, 0.0], fixed=["x", "y"]).node("1", position=[0.1, 0.0])
    s.node("2", position=[0.2, 0.0], fixed=["x", "y"])
    s.element("act", "PLTRUSS", ["0", "1"], section="act")
    s.element("wall", "PLSPRING", ["1", "2"], section="wall").release("wall", "e1")
    s.input("L", kind="motion", element="act", deformation="e1", value=1e-3)
    model = s.build()
    assert [p.name for p in model.kinematic_inputs] == ["L"]
    assert static_equilibrium(model).efforts()["L"] == pytest.approx(2.0, rel=1e-12)
    path = tmp_path / "moved.toml"
    path.write_text(scene_toml(with_motion("truss_1dof_x", "2", "x"), "a test"))
    slave = Slave(build_scene_fmu(path, tmp_path / "moved.fmu"))
    try:
        assert slave.inputs[-1] == "X" and slave.outputs[-1] == "X.effort"
        units = {v.name: v.unit for v in slave.md.modelVariables}
        assert (units["X"], units["X.effort"]) == ("m", "N")
        for k in range(5):
            slave.fmu.setReal([slave.vr["X"]], [0.101])
            effort = slave.step(k * 1e-3, 1e-3)[-1]
    finally:
        slave.close()
    assert effort == pytest.approx(945.0 * 0.001 - 1.0, rel=1e-12)


# -- outputs on elements (SPACAR's OUTE, OUTF) --------------------------------------------

def with_element_outputs(data):
    data["outputs"] |= {"eb": {"element": "b", "deformation": "e1"},
                        "fb": {"element": "b", "deformation": "e1", "quantity": "stress"},
                        "fa": {"element": "a", "deformation": "e1", "quantity": "stress"}}
    return data


def test_element_outputs_in_the_state_space_from_positions():
    """The chain: spring b's elongation y2 - u, its force (k2 + c2 s)(y2 - u); spring a's
    force (k1 + c1 s) u; both forces need the input's rate through their dampers."""
    model = build_model(with_element_outputs(chain()))
    assert [p.name for p in model.element_outputs] == ["eb", "fb", "fa"]
    assert [p.name for p in model.outputs] == ["x2", "v2"]  # what the engine reads
    space = motion_state_space(model)
    assert space.outputs == ["x2", "v2", "eb", "fb", "fa", "u.effort"]
    for omega in (0.5, 44.7, 300.0):
        s = 1j * omega
        y = (C2 * s + K2) / (M2 * s * s + C2 * s + K2)
        H = space.frequency_response(s)[2:5, 0]
        expected = [y - 1.0, (K2 + C2 * s) * (y - 1.0), K1 + C1 * s]
        np.testing.assert_allclose(H, expected, rtol=1e-12)
    assert space.needs_rates() == ["fb", "fa", "u.effort"]  # the dampers see u'


def test_element_outputs_of_a_static_solution_and_a_path():
    """The pushing truss: its force is the reaction -k delta, the wall's elongation -delta;
    the pendulum's link tension m (g cos(theta) + l theta'^2) along its path."""
    k, delta = 2000.0, 1e-3
    data = {**_pushing_truss(k, delta),
            "outputs": {"push": {"element": "act", "deformation": "e1", "quantity": "stress"},
                        "squeeze": {"element": "wall", "deformation": "e1"}}}
    model = build_model(data)
    found = static_equilibrium(model).element_outputs()
    assert found["push"] == pytest.approx(-k * delta, rel=1e-12)
    assert found["squeeze"] == pytest.approx(-delta, rel=1e-12)
    with pytest.raises(SceneError, match="outputs.push: the stress resultant of act.e1 is a "
                                         "reaction"):
        motion_state_space(model)
    mass, length, g, amplitude, omega = 0.3, 0.25, 9.81, 0.8, 3.0
    swinging = pendulum(mass, length, g)
    t = np.linspace(0.0, 2.0, 5)
    result = inverse_dynamics(swinging, t, sine(0.0, amplitude, omega))
    theta, rate = amplitude * np.sin(omega * t), amplitude * omega * np.cos(omega * t)
    np.testing.assert_allclose(result.element_output("tension"),
                               mass * (g * np.cos(theta) + length * rate ** 2), rtol=1e-12)
    with pytest.raises(KeyError, match="no output 'pull' on an element; the model has tension"):
        result.element_output("pull")


@pytest.mark.parametrize("port, key, words", [
    ({"element": "spring", "deformation": "e1", "quantity": "torque"}, "outputs.s.quantity",
     "deformation, stress"),
    ({"element": "spring", "deformation": "e4"}, "outputs.s.deformation", "no deformation"),
    ({"element": "spring", "deformation": "e1", "node": "2"}, "outputs.s", "node"),
])
def test_a_wrong_element_output_is_named(port, key, words):
    data = scene("truss_1dof_x")
    data["outputs"]["s"] = port
    with pytest.raises(SceneError, match=key) as error:
        build_model(data)
    assert words in str(error.value)


@pytest.mark.slow
def test_the_manipulator_state_space_from_its_six_carriage_positions():
    """At DC the efforts per metre of the six carriages are the inverse of the force-driven
    state space's carriage displacement per newton, within 1e-5 (measured 1.4e-6: the efforts
    carry M_kf y'', zero at DC but summed from terms of K's size through M_ff, whose condition
    is 4e7); the Schur complement of K gives the same inverse to 1e-9. About 15 s."""
    from flexure.core import Mechanics, state_space_matrices

    base = scene("manipulator")
    data = copy.deepcopy(base)
    for name, port in base["inputs"].items():
        data["inputs"][name] = {"kind": "motion", "node": port["node"],
                                "coordinate": port["coordinate"]}
    moved = build_model(data)
    space = motion_state_space(moved)
    per_metre = dc_gain(space.A, space.B, space.C, space.D)[-6:]
    A, B, C, D = state_space_matrices(load_scene("manipulator"))[:4]
    per_newton = dc_gain(A, B, C, D)  # outputs x1..x6 are the carriages' coordinates
    assert np.max(np.abs(per_metre @ per_newton - np.eye(6))) < 1e-5
    mech = Mechanics(moved)
    solution = static_equilibrium(moved, mechanics=mech)
    K = mech.structural_stiffness(solution.config) + mech.geometric_stiffness(
        solution.config, solution.stress_resultants)
    f, k = moved.free_dofs, moved.prescribed_dofs
    schur = K[np.ix_(k, k)] - K[np.ix_(k, f)] @ np.linalg.solve(K[np.ix_(f, f)], K[np.ix_(f, k)])
    assert np.max(np.abs(schur @ per_newton - np.eye(6))) < 1e-9


def test_analyze_gives_the_state_space_from_positions():
    """`flexure analyze --state-space` on stage_planar_3dof with 3.x prescribed: the state
    space from its position (the text names it), beside the force-driven one of the force
    input F, which acts on the held coordinate only (B = 0)."""
    from flexure.core.cli.analyze import analyze, render

    model = build_model(with_motion("stage_planar_3dof", "3", "x"))
    result = analyze(model, with_state_space=True)
    space = result["state_space_from_positions"]
    assert space["inputs"] == ["X"] and space["outputs"] == ["x", "y", "X.effort"]
    expected = motion_state_space(model)
    np.testing.assert_array_equal(space["D2"], expected.D2)
    assert not np.any(result["state_space"]["B"])
    assert "state space from the kinematic inputs' positions" in render(result)


def test_a_kinematic_input_the_constraints_hold_is_named():
    """stage_planar_1dof with 3.y prescribed instead of 3.x a DOF: the count is right (0), but
    the leaves hold 3.y to first order; the message names the input and what can move."""
    data = with_motion("stage_planar_1dof", "3", "y")
    data["nodes"]["3"]["dof"] = []
    with pytest.raises(ConstraintError, match=r"the DOFs? .*3\.y \(kinematic input X\).* cannot "
                                              r"move without changing .*leaf_left\.e1.*3\.x"):
        build_model(data)
