"""The compiled engine (flexure.core.engine.engine) against independent plain-numpy computations.

Every quantity the integrators get from the engine is recomputed here from the reference path
the static analyses use (Kinematics, assembly.Inertia, Mechanics), written out in this file:

    x = F(q), DF                                        Kinematics.solve
    M_bar qddot = DF^T r,  M_bar = DF^T M DF
    r = f + B u + gravity - De^T sigma_c - M (D2F qdot) qdot - g_conv
    K = K0 + G0 (stress resultants of the dynamic balance r - M DF qddot),  C = C0

on every built-in scene, on two with gravity (element masses under gravity) and on two with
shear-deformable leaves (Timoshenko bending stiffness and damping), at random
states near the initial configuration; the tangent also against finite differences of qddot,
and the CVODE Jacobian against finite differences of Simulator.derivative. Then the
forms' choice, the method names and the compiled sampled loop against a Python loop of
Simulator calls (bit for bit). The status codes: tests/test_engine_status.py; the cache of
compiled code: tests/test_engine_cache.py.
"""

import json
import sys
import textwrap
import tomllib
from pathlib import Path

import children
import numpy as np
import pytest

from flexure.core import (
    Mechanics,
    Simulator,
    build_model,
    builtin_scenes,
    load_scene,
    scene_path,
    static_equilibrium,
)
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.engine.status import status_message
from flexure.core.mechanics.ports import input_forces, input_stiffness
from flexure.core.simulation.sundials import METHODS
from tests.compiled_loops import run_compiled_loop

CORE = Path(__file__).resolve().parents[1] / "core"


def scene_with_gravity(name, gravity):
    data = tomllib.loads(scene_path(name).read_text())
    data["scene"].update(name=f"{name}_gravity", gravity=gravity)
    return build_model(data, source=f"{name} with gravity")


def scene_with_shear(name, shear):
    """The scene with shear stiffnesses (N) on its leaf section, soft enough that the shear
    ratio Phi = 12 EI / (G As l0^2) of the leaves is of order 1 (tests/test_shear.py)."""
    data = tomllib.loads(scene_path(name).read_text())
    data["scene"]["name"] = f"{name}_shear"
    data["sections"]["leaf"].update(shear)
    return build_model(data, source=f"{name} with shear")


# the manipulator's scenes (hundreds of DOFs, one refused by design): tests/test_manipulator.py
MODELS = {name: (lambda name=name: load_scene(name)) for name in builtin_scenes()
          if not name.startswith("manipulator")}
MODELS["stage_planar_3dof_gravity"] = lambda: scene_with_gravity("stage_planar_3dof",
                                                                 [0.0, -9.81])
MODELS["stage_spatial_1dof_gravity"] = lambda: scene_with_gravity("stage_spatial_1dof",
                                                                  [0.0, 0.0, -9.81])
MODELS["stage_planar_3dof_shear"] = lambda: scene_with_shear("stage_planar_3dof",
                                                             {"GAs": 50.0})
MODELS["stage_spatial_19dof_shear"] = lambda: scene_with_shear(
    "stage_spatial_19dof", {"GAs_y": 200.0, "GAs_z": 2.0e5})


@pytest.fixture(scope="module", params=[(name, form) for name in sorted(MODELS)
                                        for form in ("reduced", "augmented")],
                ids=lambda param: f"{param[0]}-{param[1]}")
def case(request):
    """(model, Mechanics, EngineData, q0) of one scene, the engine solving for the
    accelerations in the reduced or in the augmented form (both are checked against the same
    plain formulas)."""
    name, form = request.param
    model = MODELS[name]()
    mechanics = Mechanics(model)
    data = EngineData(model, augmented=form == "augmented")
    return model, mechanics, data, mechanics.kinematics.dofs_of(model.initial_coordinates)


def random_states(model, q0, seed, count=2):
    """(q, qdot, u): DOFs 1e-4 (m or rad) from the scene's, velocities of 0.05 m/s (rad/s),
    inputs of 1 N."""
    rng = np.random.default_rng(seed)
    n = q0.size
    return [(q0 + 1e-4 * rng.standard_normal(n), 0.05 * rng.standard_normal(n),
             rng.standard_normal(len(model.inputs))) for _ in range(count)]


# -- the plain computation -------------------------------------------------------------------
def plain_dynamics(model, mechanics, q, qdot, u):
    """The reduced equations of motion by the numpy reference path: a dict of config,
    qddot, M (NX, NX), M_bar, r (the force balance without M DF qddot) and sigma_c."""
    kinematics, inertia = mechanics.kinematics, mechanics.inertia
    config = kinematics.solve(q, model.initial_coordinates.copy())
    x, DF, De = config.x, config.DF, config.De
    xdot = DF @ qdot
    sigma_c = mechanics.constitutive_stress(config, De @ xdot)  # S e_s + D edot_s
    # the inputs' forces: on their coordinates, or a moment 2 u E_k^T on Euler parameters
    f = model.loads + inertia.gravity_force(x) + input_forces(model, x, u)
    M = inertia.mass_matrix(x)
    conv = [M @ kinematics.convective_acceleration(config, qdot),
            inertia.convective_force(x, xdot)]
    r = f - De.T @ sigma_c - conv[0] - conv[1]
    mass = DF.T @ M @ DF
    # the size of the force terms, for the round-off: the stress resultants with those of a
    # deformation error of the length scale (e = l - l0 and the like lose the digits of the
    # coordinates: eps L, times the stiffness S)
    rounding = np.zeros(sigma_c.size)
    rounding[mechanics.stressed] = np.abs(mechanics.S).sum(axis=1) * kinematics.length_scale
    size = np.abs(DF.T) @ (np.abs(f) + np.abs(De.T) @ (np.abs(sigma_c) + rounding)
                           + np.abs(conv[0]) + np.abs(conv[1]))
    return {"config": config, "qddot": np.linalg.solve(mass, DF.T @ r), "M": M,
            "mass": mass, "r": r, "sigma_c": sigma_c, "size": size, "u": u}


def plain_tangent(mechanics, plain, qddot):
    """(K, C): K0 + G0 with the stress resultants of the balance r - M DF qddot, and C0."""
    config = plain["config"]
    r_full = plain["r"] - plain["M"] @ (config.DF @ qddot)
    sigma = mechanics.stress_resultants(config, r_full, plain["sigma_c"])
    # a moment about a global axis turns its generalised force with the node: its load
    # stiffness -DF^T (df/dx) DF (zero for forces on coordinates)
    load = config.DF.T @ input_stiffness(mechanics.model, config.x, plain["u"]) @ config.DF
    K = (mechanics.structural_stiffness(config)
         + mechanics.geometric_stiffness(config, sigma, 1.0) - load)
    return K, mechanics.damping_matrix(config)


def evaluate(data, q, qdot, u):
    """The engine's qddot (a copy) at (q, qdot) with inputs u."""
    data.float_array("inputs")[:] = u
    status = engine.call(data, engine.OP_EVALUATE, np.array(q, float), np.array(qdot, float))
    assert status == ed.OK, status_message(status)
    return data.float_array("qddot").copy()


def close(actual, expected, rtol, scale=None):
    """max |actual - expected| <= rtol * scale (default: max |expected|)."""
    scale = np.max(np.abs(expected)) if scale is None else scale
    error = np.max(np.abs(actual - expected), initial=0.0)
    assert error <= rtol * scale, f"error {error:.3e} > {rtol:g} x {scale:.3e}"


# -- kinematics, equations of motion, tangent ---------------------------------------------------
def test_kinematics_match_newton_on_the_plain_constraints(case):
    """x and DF from full Newton (first call) and from the warm-started chord iterations (the
    calls after it, each from the previous solution) against Kinematics.solve."""
    model, mechanics, data, q0 = case
    n, L = q0.size, mechanics.kinematics.length_scale
    data.int_array("dims")[ed.WARM] = 0
    data.float_array("x_start")[:] = model.initial_coordinates
    for q, _, _ in random_states(model, q0, seed=1, count=3):
        assert engine.call(data, engine.OP_KINEMATICS, q) == ed.OK
        expected = mechanics.kinematics.solve(q, model.initial_coordinates.copy())
        close(data.float_array("x"), expected.x, 1e-14, scale=max(L, np.max(np.abs(expected.x))))
        close(data.float_array("DF").reshape(model.nx, n), expected.DF, 1e-13)
    assert engine.call(data, engine.OP_DEFORMATIONS, expected.x, s=0) == ed.OK
    close(data.float_array("e"), expected.e, 1e-14, scale=max(L, np.max(np.abs(expected.e))))


def test_accelerations_match_the_plain_equations_of_motion(case):
    """qddot: the backward error M_bar qddot - DF^T r to 1e-14 of the size of the force terms
    (`plain_dynamics`: the stiff elements' forces cancel in r, and their deformations carry
    the round-off of the coordinates); the forward error to that over M_bar's smallest
    eigenvalue; M_bar to 1e-12; the velocity terms (convective, damping: qddot(q, qdot) -
    qddot(q, 0)) on their own to the same absolute bound."""
    model, mechanics, data, q0 = case
    for q, qdot, u in random_states(model, q0, seed=2):
        qddot = evaluate(data, q, qdot, u)
        plain = plain_dynamics(model, mechanics, q, qdot, u)
        DF, mass = plain["config"].DF, plain["mass"]
        size = np.max(plain["size"])
        close(mass @ qddot, DF.T @ plain["r"], 1e-14, scale=size)
        bound = 1e-14 * size / np.linalg.eigvalsh(mass)[0]  # m/s^2, rad/s^2
        close(qddot, plain["qddot"], 1.0, scale=bound)
        close(data.float_array("mass").reshape(q0.size, q0.size), mass, 1e-12)
        at_rest = plain_dynamics(model, mechanics, q, 0 * qdot, u)["qddot"]
        close(qddot - evaluate(data, q, 0 * qdot, u), plain["qddot"] - at_rest, 2.0,
              scale=bound)


def test_tangent_matches_the_plain_stiffness_and_damping(case):
    """K0 + G0 and C0 of OP_TANGENT, at the evaluation's own qddot and at another one (IDA's
    iterate), against Mechanics' structural and geometric stiffness and damping."""
    model, mechanics, data, q0 = case
    n = q0.size
    for q, qdot, u in random_states(model, q0, seed=3):
        qddot = evaluate(data, q, qdot, u)
        plain = plain_dynamics(model, mechanics, q, qdot, u)
        for acc in (qddot, 0.5 * qddot + 1.0):
            assert engine.call(data, engine.OP_TANGENT, np.array(acc)) == ed.OK
            K, C = plain_tangent(mechanics, plain, acc)
            close(data.float_array("stiffness").reshape(n, n), K, 1e-10)
            close(data.float_array("damping").reshape(n, n), C, 1e-12,
                  scale=max(np.max(np.abs(C)), 1e-300))


def test_tangent_matches_finite_differences_at_the_static_equilibrium(case):
    """At the static equilibrium under the scene's loads, at rest: -M_bar d qddot / dq = K and
    -M_bar d qddot / d qdot = C (central differences), and the CVODE Jacobian of Simulator
    against central differences of Simulator.derivative."""
    model, mechanics, data, _ = case
    q = static_equilibrium(model).q
    n = q.size
    u = np.zeros(len(model.inputs))
    evaluate(data, q, np.zeros(n), u)
    mass = data.float_array("mass").reshape(n, n).copy()
    assert engine.call(data, engine.OP_TANGENT, data.float_array("qddot").copy()) == ed.OK
    K = data.float_array("stiffness").reshape(n, n).copy()
    C = data.float_array("damping").reshape(n, n).copy()
    h = 1e-7
    dq, dv = np.zeros((n, n)), np.zeros((n, n))
    for j in range(n):
        step = h * np.eye(n)[j]
        dq[:, j] = (evaluate(data, q + step, np.zeros(n), u)
                    - evaluate(data, q - step, np.zeros(n), u)) / (2 * h)
        dv[:, j] = (evaluate(data, q, step, u) - evaluate(data, q, -step, u)) / (2 * h)
    close(-mass @ dq, K, 1e-5)
    close(-mass @ dv, C, 1e-6, scale=max(np.max(np.abs(C)), 1e-300))

    sim = Simulator(model)
    y = np.concatenate([q - sim.q_ref, np.zeros(n)])
    J = sim.jacobian_matrix(0.0, y)
    numeric = np.zeros_like(J)
    for j in range(2 * n):
        step = h * np.eye(2 * n)[j]
        numeric[:, j] = (sim.derivative(0.0, y + step) - sim.derivative(0.0, y - step)) / (2 * h)
    for rows, columns in ((slice(n, None), slice(None, n)), (slice(n, None), slice(n, None))):
        close(J[rows, columns], numeric[rows, columns], 1e-5,
              scale=max(np.max(np.abs(numeric[rows, columns])), 1e-300))
    assert np.array_equal(J[:n], np.hstack([np.zeros((n, n)), np.eye(n)]))


def test_first_order_and_implicit_forms(case):
    """OP_RHS and Simulator.derivative: [qdot, qddot]; OP_JACOBIAN (row- and column-major) and
    Simulator.jacobian_matrix: [[0, I], [-M_bar^-1 K, -M_bar^-1 C]] of the plain tangent;
    OP_RESIDUAL, OP_RESIDUAL_JACOBIAN: IDA's [yp_q - qdot, M_bar (yp_v - qddot)] and
    [[cj I, -I], [K, C + cj M_bar]] with the tangent at qddot = yp_v."""
    model, mechanics, data, q0 = case
    n = q0.size
    sim = Simulator(model)
    for q, qdot, u in random_states(model, q0, seed=4, count=1):
        plain = plain_dynamics(model, mechanics, q, qdot, u)
        mass = plain["mass"]
        y = np.concatenate([q - sim.q_ref, qdot])
        sim.set_inputs(u)
        ydot = sim.derivative(0.0, y)
        assert np.array_equal(ydot[:n], qdot)
        close(ydot[n:], plain["qddot"], 1e-14, scale=np.max(plain["size"])
              / np.linalg.eigvalsh(mass)[0])
        J = sim.jacobian_matrix(0.0, y)
        K, C = plain_tangent(mechanics, plain, ydot[n:])
        assert np.array_equal(J[:n], np.hstack([np.zeros((n, n)), np.eye(n)]))
        close(mass @ J[n:, :n], -K, 1e-10)
        close(mass @ J[n:, n:], -C, 1e-10, scale=max(np.max(np.abs(C)), 1e-300))
        # the packed data of the simulator, as SUNDIALS' callbacks see it
        column_major = np.empty(4 * n * n)
        assert engine.call(sim.data, engine.OP_JACOBIAN, y, column_major, s=1.0) == ed.OK
        assert np.array_equal(column_major.reshape(2 * n, 2 * n).T, J)
        yp = np.concatenate([qdot + 1e-3, ydot[n:] * 0.9 + 0.1])
        res = np.empty(2 * n)
        assert engine.call(sim.data, engine.OP_RESIDUAL, y, yp, res) == ed.OK
        close(res[:n], yp[:n] - qdot, 1e-15, scale=1.0)
        # M_bar (yp - qddot) to the backward error of qddot (1e-14 of the size of the force
        # terms, as in test_accelerations_match_the_plain_equations_of_motion)
        expected = mass @ (yp[n:] - plain["qddot"])
        close(res[n:], expected, 1.0,
              scale=1e-10 * np.max(np.abs(expected)) + 1e-14 * np.max(plain["size"]))
        cj = 123.0
        JR = np.empty(4 * n * n)
        assert engine.call(sim.data, engine.OP_RESIDUAL_JACOBIAN, y, yp, JR, s=cj) == ed.OK
        JR = JR.reshape(2 * n, 2 * n).T  # column-major
        K, C = plain_tangent(mechanics, plain, yp[n:])
        expected = np.block([[cj * np.eye(n), -np.eye(n)], [K, C + cj * mass]])
        close(JR[:n], expected[:n], 0.0, scale=1.0)
        close(JR[n:, :n], K, 1e-10)
        close(JR[n:, n:], C + cj * mass, 1e-10)


# -- the forms ------------------------------------------------------------------------------------
def test_the_cheaper_form_is_chosen_per_model():
    """The 1-DOF stage (M_bar 1 x 1) takes the reduced form, the 93-DOF refined stage (M_bar
    costs NDOF^2 per element) the augmented one."""
    from flexure.core.engine.data import evaluation_cost

    assert EngineData(load_scene("stage_planar_1dof")).int_array("dims")[ed.AUGMENTED] == 0
    small = evaluation_cost(11, 10, 1, [(3, 6, 8)])
    large = evaluation_cost(99, 6, 93, [(33, 6, 8)])
    assert small["reduced"] < small["augmented"] and large["augmented"] < large["reduced"]


def test_method_names_of_the_command_line_are_the_solvers():
    from flexure.core.cli.simulate import METHODS as COMMAND_METHODS
    from flexure.core.simulation.simulator import METHODS as ALL_METHODS
    from flexure.fmu.scene_slave import METHODS as FMU_METHODS

    assert COMMAND_METHODS == ALL_METHODS == METHODS + ("esdirk", "esdirk3", "esdirk2", "sdirk2")
    assert sorted(FMU_METHODS) == sorted(ALL_METHODS)


# -- the compiled sampled loop ------------------------------------------------------------------
def test_compiled_sampled_loop_equals_a_python_loop_of_simulator_calls_bit_for_bit():
    check_compiled_loop_against_python_loop("cvode-bdf")


def check_compiled_loop_against_python_loop(method):
    """flexure.core.run_sampled_loop against controllers.runner.simulate_loop around an
    InProcessPlant (a Simulator stepped from Python), both on `method` at rtol 1e-7, for a
    1 mm move of stage_planar_3dof sampled at 4 kHz: the same times, positions and forces."""
    from flexure.controllers import build_loop
    from flexure.controllers.plants import InProcessPlant
    from flexure.controllers.runner import simulate_loop

    model = load_scene("stage_planar_3dof")
    controller, design = build_loop(model, stroke=1e-3, duration=0.02, settle=0.005,
                                    fs=4000.0)
    t, _, position, force = simulate_loop(InProcessPlant(model, method=method, rtol=1e-7),
                                          controller, design)
    sim = Simulator(model, method=method, rtol=1e-7)
    t_c, position_c, force_c = run_compiled_loop(sim, controller, design)
    assert position.shape == (101, 1) and np.ptp(position) > 5e-4  # it moved
    assert np.array_equal(t_c, t)
    assert np.array_equal(position_c, position)
    assert np.array_equal(force_c, force)
    assert sim.time == t[-1]


def test_positions_operation_matches_the_full_kinematics(case):
    """OP_POSITIONS (Newton from x_start until the residual is within the tolerance, used to
    measure outputs) against OP_KINEMATICS' x, to the kinematic tolerance."""
    model, mechanics, data, q0 = case
    L = mechanics.kinematics.length_scale
    for q, _, _ in random_states(model, q0, seed=5, count=2):
        data.int_array("dims")[ed.WARM] = 0
        data.float_array("x_start")[:] = model.initial_coordinates
        assert engine.call(data, engine.OP_KINEMATICS, q) == ed.OK
        expected = data.float_array("x").copy()
        data.float_array("x_start")[:] = model.initial_coordinates
        assert engine.call(data, engine.OP_POSITIONS, q) == ed.OK
        close(data.float_array("x"), expected, 1e-13, scale=max(L, np.max(np.abs(expected))))
        assert data.int_array("dims")[ed.WARM] == 0


def test_connect_compiles_only_the_operations_a_model_uses():
    """`connect` compiles the entries of the operations its caller names and of those they
    call, nothing else: CVODE's form on a banded model without rigid clusters leaves the
    implicit form, the positions, the sparse LU and the rigid clusters' kernels uncompiled;
    a model packed sparse adds the sparse LU's two operations. In a fresh process (the table
    of entries is the process's), loading what this process put into the cache."""
    engine.connect(EngineData(load_scene("truss_1dof_x")), engine.OP_RHS, engine.OP_JACOBIAN)
    engine.connect(EngineData(load_scene("truss_1dof_x"), sparse=True), engine.OP_POSITIONS)
    probe = textwrap.dedent("""
        from flexure.core import load_scene
        from flexure.core.engine import engine
        from flexure.core.engine.data import EngineData
        def compiled():
            print(sorted(op for op, entry in enumerate(engine.ENTRIES) if entry.is_compiled))
        engine.connect(EngineData(load_scene("truss_1dof_x")), engine.OP_RHS,
                       engine.OP_JACOBIAN)
        compiled()
        # a model of its own: packed once banded, a model keeps its orders (`data._ORDERS`)
        engine.connect(EngineData(load_scene("truss_1dof_x"), sparse=True),
                       engine.OP_POSITIONS)
        compiled()
        """)
    done = children.run([sys.executable, "-c", probe], capture_output=True, text=True,
                        check=True)
    first, second = (json.loads(line) for line in done.stdout.split("\n")[:2])
    forms = {engine.OP_RHS, engine.OP_JACOBIAN, engine.OP_ACCELERATIONS,
             engine.OP_CONFIGURATION, engine.OP_TANGENT, engine.OP_MASS, engine.OP_DF,
             engine.OP_MASS_OF}
    assert set(first) == forms
    assert set(second) == forms | {engine.OP_POSITIONS, engine.OP_SPARSE_FACTOR,
                                   engine.OP_SPARSE_SOLVE}
