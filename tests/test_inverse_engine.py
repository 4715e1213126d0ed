"""Inverse dynamics through the compiled engine against the numpy reference: the same
algorithm on the two paths' evaluations (core/analysis/inverse_evaluation.py), so the forces,
the kinematic inputs' efforts, the motion and every stress resultant agree to round-off.

Round-off here is that of the balance, not of the answer: a stress resultant is S e, and e
of a stiff deformation carries the round-off of the coordinates, eps L, times S. So the
tolerances are relative to the largest value, with the floor FLOOR * eps * S_max * L (S_max
the largest constitutive stiffness, N/m; L the model's length scale, m), where that is the
larger (the stiff leaves of stage_planar_3dof: measured 1.25 of eps S_max L)."""

import numpy as np
import pytest
from kinematic_scenes import pendulum, scene, sine, with_motion

from flexure.core import build_model, load_scene, static_equilibrium
from flexure.core.analysis import inverse_evaluation
from flexure.core.analysis.inverse_dynamics import inverse_dynamics
from flexure.core.analysis.inverse_dynamics_free import free_inverse_dynamics
from flexure.core.errors import ConstraintError, ConvergenceError, SceneError
from flexure.core.mechanics.mechanics import Mechanics
from flexure.core.mechanics.scales import length_scale

FLOOR = 100.0  # round-off units eps S_max L of the stiffest deformation


def wave(start, amplitude, omega):
    """A sine path per prescribed entry: values, rates, accelerations (m or rad, per s)."""
    start, amplitude = np.asarray(start, float), np.asarray(amplitude, float)
    return lambda t: (start + amplitude * np.sin(omega * t),
                      amplitude * omega * np.cos(omega * t),
                      -amplitude * omega ** 2 * np.sin(omega * t))


def both(run, model, *args, **keys):
    """(numpy, engine): `run` on the numpy path and on the engine's."""
    return (run(model, *args, compiled=False, **keys),
            run(model, *args, compiled=True, **keys))


def floor(model):
    """eps S_max L, N: the round-off of a stress resultant from that of the coordinates."""
    S = Mechanics(model).S
    return np.finfo(float).eps * np.abs(S).max(initial=0.0) * length_scale(model)


def assert_agree(numpy_result, engine_result, rtol):
    """Forces, efforts and stress resultants within rtol of their largest (or the floor),
    q and x within 1e-14 of the length scale, no NaN on the engine's side."""
    model = numpy_result.model
    absolute = FLOOR * floor(model)
    for name in ("forces", "efforts", "stress_resultants"):
        a, b = getattr(numpy_result, name), getattr(engine_result, name)
        assert not np.any(np.isnan(b)), name
        scale = np.abs(a).max(initial=0.0)
        assert np.abs(a - b).max(initial=0.0) <= max(rtol * scale, absolute), name
    L = length_scale(model)
    for name in ("q", "x", "e"):
        a, b = getattr(numpy_result, name), getattr(engine_result, name)
        assert np.abs(a - b).max(initial=0.0) <= 1e-14 * max(L, 1.0), name


def _stage_3dof(kinematic):
    """stage_planar_3dof with a force on 3.y and a moment on 4.phi, phi an output; x a
    force input (kinematic=False) or a kinematic input X."""
    data = with_motion("stage_planar_3dof", "3", "x") if kinematic else scene(
        "stage_planar_3dof")
    if kinematic:
        del data["inputs"]["F"]
    data["inputs"]["Fy"] = {"node": "3", "coordinate": "y"}
    data["inputs"]["M"] = {"node": "4", "coordinate": "phi"}
    data["outputs"]["phi"] = {"node": "4", "coordinate": "phi"}
    return build_model(data)


def test_a_planar_stage_moved_by_three_forces():
    """stage_planar_3dof, x by 1 mm, y by 2 um and phi by 0.1 mrad at 20 rad/s: forces up to
    491 N and the leaves' resultants to 1e-10 of the largest (measured 1.1e-12 and 1.5e-12:
    1.25 round-off units)."""
    t = np.linspace(0.0, 0.2, 11)
    assert_agree(*both(inverse_dynamics, _stage_3dof(False), t,
                       wave([0.0, 0.1, 0.0], [1e-3, 2e-6, 1e-4], 20.0)), rtol=1e-10)


def test_a_planar_stage_with_its_x_a_kinematic_input():
    """The same motion with 3.x prescribed: the effort on X, the two forces and every
    resultant (the prescribed deformation's row too) to 1e-10 of the largest."""
    t = np.linspace(0.0, 0.2, 11)
    numpy_result, engine_result = both(inverse_dynamics, _stage_3dof(True), t,
                                       wave([0.1, 0.0, 0.0], [2e-6, 1e-4, 1e-3], 20.0),
                                       outputs=["y", "phi"])
    assert numpy_result.efforts.shape == (t.size, 1)
    assert_agree(numpy_result, engine_result, rtol=1e-10)


def test_a_pendulums_link_tension_is_a_rigid_reaction():
    """A point mass on a rigid link: the torque and the link's reaction (a rigid
    deformation's multiplier) to 1e-13 of the largest (measured 8e-16 and 5e-16)."""
    t = np.linspace(0.0, 2.0, 21)
    assert_agree(*both(inverse_dynamics, pendulum(0.3, 0.25, 9.81), t, sine(0.0, 0.8, 3.0)),
                 rtol=1e-13)


def test_a_spatial_tripod_moved_by_its_forces_and_moment():
    """wire_tripod (BEAM wires), P moved 1 mm in x, 0.5 mm in y and turned 10 mrad about z
    (an angle about a global axis of a 3-D rotational node): to 1e-12 (measured 4.2e-14)."""
    t = np.linspace(0.0, 0.2, 11)
    assert_agree(*both(inverse_dynamics, load_scene("wire_tripod"), t,
                       wave([0.0, 0.0, 0.0], [1e-3, 5e-4, 1e-2], 20.0),
                       outputs=["x", "y", "rz"]), rtol=1e-12)


def test_a_spatial_tripod_with_a_kinematic_input():
    """wire_tripod with P.x prescribed (its effort) and y, rz by force and moment: to 1e-12
    (measured 4.2e-14)."""
    data = with_motion("wire_tripod", "P", "x")
    del data["inputs"]["F"]
    t = np.linspace(0.0, 0.2, 11)
    assert_agree(*both(inverse_dynamics, build_model(data), t,
                       wave([0.0, 0.0, 0.0], [5e-4, 1e-2, 1e-3], 20.0),
                       outputs=["y", "rz"]), rtol=1e-12)


def _rest_output(model, name):
    """The output `name` at the static equilibrium, m."""
    from flexure.core import output_value

    port = next(port for port in model.outputs if port.name == name)
    return output_value(model, port, static_equilibrium(model).x)


@pytest.mark.parametrize("name, stroke, rtol", [
    ("stage_planar_3dof", 1e-4, 1e-8),  # measured: forces 2.9e-10, resultants 1.25 units
    ("wire_tripod", 1e-4, 1e-12),  # measured 2e-16 and 3e-16
    ("stage_spatial_19dof", 1e-5, 1e-9),  # measured 7.8e-12 (numpy dense/sparse: 6.2e-11)
])
def test_the_free_dofs_integrated_on_both_paths(name, stroke, rtol):
    """`free_inverse_dynamics` with x prescribed and F solved for, the other DOFs free (2,
    2 and 18): the forces at the steps and at the inner stages, the resultants and the
    motion. The free DOFs are integrated, so the round-off of each step's Newton is carried
    to the next: the stiff y and phi of stage_planar_3dof (2.1 and 3.6 kHz) keep the forces
    to 2.9e-10 of their largest."""
    model = load_scene(name)
    t = np.linspace(0.0, 0.02, 9)
    path = wave([_rest_output(model, "x")], [stroke], 50.0)
    inputs = ["F"]
    numpy_result, engine_result = both(free_inverse_dynamics, model, t, path, outputs=["x"],
                                       inputs=inputs)
    assert_agree(numpy_result, engine_result, rtol=rtol)
    scale = np.abs(numpy_result.node_forces).max()
    assert np.abs(numpy_result.node_forces - engine_result.node_forces).max() <= rtol * scale


# -- the errors keep their messages on the engine's path ----------------------------------

def _truss(**outputs):
    data = scene("truss_1dof_x")
    data["outputs"].update(outputs)
    return data


@pytest.mark.parametrize("compiled", [False, True])
@pytest.mark.parametrize("call, error, words", [
    (lambda m, c: inverse_dynamics(m, [0.0], sine(0.0, 1e-3, 1.0), outputs=["ground"],
                                   inputs=["F"], compiled=c),
     ConstraintError, "do not determine the DOFs"),
    (lambda m, c: inverse_dynamics(m, [0.0], sine(0.1, 1e-3, 1.0), outputs=["x"],
                                   inputs=["G"], compiled=c),
     ConstraintError, "cannot balance the motion"),
])
def test_a_singular_balance_is_refused_on_both_paths(compiled, call, error, words):
    """truss_1dof_x with the wall's x as the output ([C; E_k^T] singular), or a force on the
    wall as the input (DF^T b singular)."""
    data = _truss(ground={"node": "1", "coordinate": "x"})
    data["inputs"]["G"] = {"node": "1", "coordinate": "x"}
    with pytest.raises(error, match=words):
        call(build_model(data), compiled)


@pytest.mark.parametrize("compiled", [False, True])
def test_a_path_beyond_the_reach_is_refused_on_both_paths(compiled):
    """stage_planar_1dof, its x asked to reach 0.3 m on leaves of 0.1 m: ConvergenceError
    (the kinematics' own, naming the mechanism's reach)."""
    with pytest.raises(ConvergenceError, match="reach"):
        inverse_dynamics(load_scene("stage_planar_1dof"), [0.0], lambda t: ([0.3], [0.0], [0.0]),
                         outputs=["x"], compiled=compiled)


@pytest.mark.parametrize("compiled", [False, True])
def test_outputs_the_forces_do_not_reach_are_refused_on_both_paths(compiled):
    """Two masses on springs, the force on mass 1, the output mass 2 behind a massless
    spring: the free balance is singular (relative degree above two)."""
    from test_inverse_dynamics_free import moved, two_masses

    with pytest.raises(ConstraintError, match="do not reach the accelerations"):
        free_inverse_dynamics(two_masses(), [0.0, 0.01], moved(0.2), outputs=["x2"],
                              compiled=compiled)


# -- which path -------------------------------------------------------------------------

def test_the_engine_is_preferred_from_the_stated_work_on():
    """The rule: evaluations x (free coordinates + OVERHEAD_COORDINATES) >= ENGINE_MIN_WORK,
    a tie taking the engine; integers only, so the choice is the same on every CPU."""
    minimum, overhead = inverse_evaluation.ENGINE_MIN_WORK, inverse_evaluation.OVERHEAD_COORDINATES
    for name in ("truss_1dof_x", "stage_planar_3dof", "wire_tripod", "stage_spatial_19dof"):
        model = load_scene(name)
        per = model.free_coordinates.size + overhead
        at = -(-minimum // per)  # the fewest evaluations that reach it
        assert inverse_evaluation.preferred(model, at), name
        assert not inverse_evaluation.preferred(model, at - 1), name
    # truss_1dof_x: 1 + 4 free coordinates' worth, so 200 evaluations are the tie itself
    assert (load_scene("truss_1dof_x").free_coordinates.size + overhead) * 200 == minimum
    assert inverse_evaluation.preferred(load_scene("truss_1dof_x"), 200)


def test_the_free_variant_takes_the_rules_path(monkeypatch):
    """`free_inverse_dynamics` counts EVALUATIONS_PER_STEP evaluations a step: on
    wire_tripod (28 free coordinates) 8 steps are a work of 2560, the engine's; 2 steps, 640,
    numpy's; compiled=False keeps numpy whatever the work."""
    from flexure.core.analysis import inverse_dynamics_free, inverse_engine

    per_step = inverse_dynamics_free.EVALUATIONS_PER_STEP
    model = load_scene("wire_tripod")
    assert inverse_evaluation.preferred(model, 8 * per_step)
    assert not inverse_evaluation.preferred(model, 2 * per_step)
    taken = []
    engine_motion = inverse_engine.engine_motion
    monkeypatch.setattr(inverse_engine, "engine_motion",
                        lambda model: taken.append(model.name) or engine_motion(model))
    path = wave([0.0], [1e-4], 50.0)
    for steps, keys, engine in ((8, {}, True), (2, {}, False),
                                (8, {"compiled": False}, False)):
        taken.clear()
        result = free_inverse_dynamics(model, np.linspace(0.0, 0.0025 * steps, steps + 1),
                                       path, outputs=["x"], inputs=["F"], **keys)
        assert result.forces.shape == (steps + 1, 1)
        assert bool(taken) == engine, (steps, keys)


def test_compiled_is_refused_where_the_engine_does_not_take_the_model():
    """A model with actuators: SceneError naming the numpy path; the default takes it."""
    model = load_scene("manipulator_control_vcm")
    assert not inverse_evaluation.preferred(model, 10 ** 9)
    with pytest.raises(SceneError, match="compiled=False"):
        inverse_evaluation.motion_evaluator(model, Mechanics(model), True, 1)


@pytest.mark.slow
def test_the_manipulators_free_inverse_dynamics_on_both_paths(monkeypatch):
    """manipulator_control's end effector moved 6 mm in xy (the move's first 15 ms at 5 ms
    steps; 69 of its 75 DOFs free, 784 free coordinates): the engine's forces (up to 1.9 mN)
    and stress resultants against the numpy path's (its default, sparse `Mechanics`). Here
    round-off is the numpy path's own spread, its dense against its sparse `Mechanics`
    (the same equations summed in another order): the zero dynamics' fast modes (up to
    3e5 1/s) carry the coordinates' round-off into the free DOFs' accelerations, 3e-7 of
    3e-3 m/s^2, and the forces, 1.2e-7 N. The engine within 4 times that spread (measured
    0.66 for the forces at the steps, 0.78 at the inner stages, 0.66 for the resultants),
    the motion within 1e-14 m (measured 1.1e-16 and 1.3e-15)."""
    import flexure.core
    from examples.manipulator_loop import targets
    from flexure.controllers.dynamic_feedforward import move_inverse_dynamics

    model = load_scene("manipulator_control")
    stroke = 6e-3 / np.sqrt(2)
    runs = {}
    for name, keys in (("sparse", {"compiled": False, "mechanics": Mechanics(model)}),
                       ("dense", {"compiled": False,
                                  "mechanics": Mechanics(model, sparse=False)}),
                       ("engine", {"compiled": True})):
        monkeypatch.setattr(flexure.core, "free_inverse_dynamics",
                            lambda *args, keys=keys, **more: free_inverse_dynamics(
                                *args, **keys, **more))
        runs[name] = move_inverse_dynamics(model, targets(stroke, stroke), duration=1.0,
                                           end=0.015, step=5e-3)
    sparse, dense, engine = runs["sparse"], runs["dense"], runs["engine"]
    for name in ("forces", "node_forces", "stress_resultants"):
        spread = np.abs(getattr(dense, name) - getattr(sparse, name)).max()
        assert 0 < spread < 1e-3 * np.abs(getattr(sparse, name)).max(), name
        assert np.abs(getattr(engine, name) - getattr(sparse, name)).max() <= 4 * spread, name
    for name in ("q", "x"):
        assert np.abs(getattr(engine, name) - getattr(sparse, name)).max() <= 1e-14, name
