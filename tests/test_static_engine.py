"""The statics through the compiled engine (core/analysis/static_engine.py) against the numpy
reference (`Mechanics`), which `static_equilibrium(..., compiled=False)` runs.

Every built-in scene (ports, actuators, rigid bodies, spatial and planar), scenes with
gravity on element masses and lumped masses, moments about global axes, a kinematic input
and a massless model are solved both ways under loads and held inputs.

Tolerances:
- the equilibria: every DOF and coordinate within 1e-10 of its unit (m through the length
  scale, rad through 1); both Newtons stop at 1e-11 of a unit and converge quadratically,
  so they meet far closer (measured 1e-15 and below);
- the stress resultants of the stressed deformations: within 1e-10 of the largest plus what
  a deformation error of 1e-12 of the length scale makes through the element's stiffness
  (a stiff element's resultant, S e, carries the coordinates' round-off times S); those of
  the rigid deformations, the multipliers J^-T r, within 1e-8 of the largest (J^-T carries
  the round-off of r, in which the stiff elements' forces cancel: measured 1.1e-10 on
  manipulator_control, 2.7e-9 on manipulator_reduced);
- the balance away from equilibrium: K within 1e-10 of its largest entry (the engine's
  own tangent test, tests/test_engine.py), Q within 1e-9 of the largest |DF^T f| and
  |DF^T De^T sigma_c| term it sums (the same round-off: its terms cancel).
"""

import tomllib

import numpy as np
import pytest
from kinematic_scenes import chain
from test_engine import scene_with_gravity
from test_static_tangent import away_from_equilibrium, cantilever_with_gravity, coil_and_moment

from flexure.core import ConvergenceError, build_model, builtin_scenes, load_scene, scene_path
from flexure.core.analysis import static_engine
from flexure.core.analysis.statics import static_equilibrium
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.mechanics.mechanics import Mechanics
from flexure.core.mechanics.scales import coordinate_units, dof_tolerances, length_scale

# In the slow tier: hundreds of DOFs, whose numpy statics take seconds each; and two variants
# of manipulator_control (its voice-coil drive, the MEMS scaling: 1.4 to 1.7 s a test each),
# which the default tier checks as manipulator_control itself.
LARGE = {"manipulator", "manipulator_e1", "manipulator_reduced", "manipulator_control_vcm",
         "manipulator_mems"}
# a part of the manipulator, refused by design on its own (tests/test_manipulator.py)
PARTS = {"manipulator_guidance"}


def builtin(name):
    """A built-in scene with 1 N (1e-5 N on the micro-scale one) on every input."""
    model = load_scene(name)
    size = 1e-5 if name == "manipulator_mems" else 1.0
    return model, (np.full(len(model.inputs), size) if model.inputs else None)


def massless_truss():
    """truss_1dof_x without its mass or the springs' (its 1 N load held by the spring)."""
    data = tomllib.loads(scene_path("truss_1dof_x").read_text())
    data["scene"]["name"] = "massless_truss"
    del data["nodes"]["2"]["mass"]
    del data["sections"]["springs"]["rho_A"]
    data["scene"].pop("tunable", None)
    return build_model(data), None


def long_cantilever(n):
    """The benchmarks' spatial BEAM cantilever of n elements (6 n DOFs), 1 N at its tip: at
    156 DOFs (n = 26) the engine's tangent takes its product through OP_ROW_PRODUCTS (from
    ROW_GROUPS_FROM DOFs)."""
    from examples.benchmarks.spatial import spatial_cantilever

    return spatial_cantilever(n), None


def stage_under_gravity():
    """The planar stage with gravity on its element masses, 1 N on its input."""
    model = scene_with_gravity("stage_planar_3dof", [0.0, -9.81])
    return model, np.ones(len(model.inputs))


SCENES = {name: (lambda name=name: builtin(name)) for name in builtin_scenes()
          if name not in PARTS}
SCENES |= {
    "planar stage, gravity": stage_under_gravity,
    "spatial beam, moments about global axes, gravity": lambda: cantilever_with_gravity()[:2],
    "spatial beam, actuator and moment about z": lambda: coil_and_moment()[:2],
    "massless truss": massless_truss,
    "spatial cantilever, 26 BEAMs": lambda: long_cantilever(26),
}


def stress_bound(model, mech, largest):
    """Per deformation, N (module docstring): a stressed one's 1e-10 of the largest
    resultant plus that of a deformation error of 1e-12 L through its stiffness, a rigid
    one's 1e-8 of the largest."""
    bound = np.full(len(model.deformation_names), 1e-8 * largest)
    bound[mech.stressed] = (1e-10 * largest
                            + np.abs(mech.S).sum(axis=1) * 1e-12 * length_scale(model))
    return bound


@pytest.mark.parametrize("name", [
    pytest.param(name, marks=pytest.mark.slow) if name in LARGE else name for name in SCENES])
def test_engine_equilibria_match_the_numpy_reference(name):
    model, inputs = SCENES[name]()
    engine_path = static_equilibrium(model, inputs=inputs, compiled=True)
    reference = static_equilibrium(model, inputs=inputs, compiled=False)
    units = dof_tolerances(model, 1.0)
    error = np.max(np.abs(engine_path.q - reference.q) / units, initial=0.0)
    assert error <= 1e-10, f"{name}: DOFs differ by {error:.2e} of their units"
    x_units = coordinate_units(model)[0]
    error = np.max(np.abs(engine_path.x - reference.x) / x_units)
    assert error <= 1e-10, f"{name}: coordinates differ by {error:.2e} of their units"
    mech = Mechanics(model)
    sigma = reference.stress_resultants
    bound = stress_bound(model, mech, np.max(np.abs(sigma)))
    assert np.all(np.abs(engine_path.stress_resultants - sigma) <= bound), name
    if inputs is not None:  # the held inputs' values were on the ports
        assert np.max(np.abs(sigma)) > 0.0


def test_the_engine_takes_a_massless_model():
    """The massless truss: its evaluation finds M_bar singular (SINGULAR_MASS), and the
    statics through the engine still solves it, as the spring's elongation under its 1 N
    load: x = l0 + F / (EA / l0)."""
    model, _ = massless_truss()
    data = EngineData(model, augmented=False)  # the statics' form
    q = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    assert engine.call(data, engine.OP_EVALUATE, q, np.zeros(q.size)) == ed.SINGULAR_MASS
    balance = static_engine.EngineBalance(model)
    balance.set_load(1.0)
    Q, K = balance.residual_and_tangent(
        static_engine.EnginePoint(q, model.initial_coordinates.copy()))
    assert abs(Q[0] - 1.0) <= 1e-15 and abs(K[0, 0] - 945.0) <= 1e-12  # N, N/m
    solution = static_equilibrium(model, compiled=True)
    assert abs(solution.x[model.coordinate_index("2.x")] - (0.1 + 1.0 / 945.0)) <= 1e-14


def test_kinematic_inputs_and_their_efforts_match():
    """The spring-mass chain with its first node prescribed: the DOF and the force that holds
    the input, through the engine and the reference, and against the springs in series
    (node 2 unloaded: it stays a spring length from node 1; the effort is the first
    spring's force k1 u)."""
    model = build_model(chain())
    moved = 2e-3  # m, from node 1's 0.1 m
    solutions = [static_equilibrium(model, motions={"u": 0.1 + moved}, compiled=compiled)
                 for compiled in (True, False)]
    for solution in solutions:
        assert abs(solution.x[model.coordinate_index("2.x")] - (0.2 + moved)) <= 1e-15
        assert abs(solution.efforts()["u"] - 800.0 * moved) <= 1e-12
    assert abs(solutions[0].efforts()["u"] - solutions[1].efforts()["u"]) <= 1e-12


def test_a_path_of_loads_matches():
    """A pose stepped from its half-load pose (`path`), both ways."""
    model, inputs = builtin("stage_spatial_19dof")
    loads = 20.0 * model.loads
    results = []
    for compiled in (True, False):
        half = static_equilibrium(model, loads=0.5 * loads, compiled=compiled)
        results.append(static_equilibrium(model, loads=loads, path=[(0.5, half)],
                                          compiled=compiled, load_steps=2))
    units = dof_tolerances(model, 1.0)
    assert np.max(np.abs(results[0].q - results[1].q) / units) <= 1e-10
    assert np.max(np.abs(results[0].q - static_equilibrium(model, loads=loads).q)
                  / units) <= 1e-10


BALANCE_SCENES = ["planar stage, gravity", "spatial beam, moments about global axes, gravity",
                  "spatial beam, actuator and moment about z", "stage_spatial_19dof",
                  "wire_tripod", "manipulator_control", "truss_1dof_x",
                  "spatial cantilever, 26 BEAMs"]


@pytest.mark.parametrize("name", BALANCE_SCENES)
def test_balance_and_tangent_match_away_from_equilibrium(name):
    """Q and K of the engine's balance at 0.6 of the scene's loads and inputs, at a
    configuration 1e-2 units (1e-3 on the manipulator) from the scene's, against
    `Mechanics.static_balance` and `tangent_stiffness`."""
    model, values = SCENES[name]()
    if values is not None and model.actuators:  # the port values at rest
        from flexure.core.mechanics.actuators import steady_port_values

        values = steady_port_values(model, values)
    mech = Mechanics(model)
    size = 1e-3 if name.startswith("manipulator") else 1e-2
    config, _ = away_from_equilibrium(model, mech, 5, size)
    loads = model.loads + 0.5
    balance = static_engine.EngineBalance(model)
    balance.set_load(0.6, loads, values)
    Q, K = balance.residual_and_tangent(config)
    Q_ref, _, sigma = mech.static_balance(config, 0.6, loads, values)
    K_ref = mech.tangent_stiffness(config, sigma, 0.6, inputs=values)
    # gravity's load stiffness on element masses that hang on rotations included
    # (`gravity_stiffness`: 5e-9 of the largest entry on the cantilever)
    assert np.max(np.abs(K - K_ref)) <= 1e-10 * np.max(np.abs(K_ref))
    f = mech.external_force(config.x, 0.6, loads, values)
    terms = max(np.max(np.abs(config.DF.T @ f)),
                np.max(np.abs(config.DF.T @ (config.De.T @ mech.constitutive_stress(config)))))
    assert np.max(np.abs(Q - Q_ref)) <= 1e-9 * terms
    assert np.max(np.abs(Q_ref)) > 1e-3 * terms  # out of equilibrium


def test_which_path_and_what_the_engine_refuses():
    """The default path: the engine from ENGINE_MIN_FREE free coordinates up; a model with
    kinematic inputs and actuators (which the engine's packing refuses) takes the numpy
    path, also when the engine is asked for, with the same answer."""
    assert static_engine.preferred(load_scene("manipulator_control"))  # 75 DOFs, 784 free
    assert static_engine.preferred(load_scene("manipulator_reduced"))  # 507 DOFs: no bound
    assert not static_engine.preferred(load_scene("stage_spatial_19dof"))  # 35 free
    data = chain()
    data["inputs"]["F"] = {"node": "2", "coordinate": "x"}
    data["actuators"] = {"VCM": {"input": "F", "force_constant": 2.0, "drive": "current"}}
    model = build_model(data)
    assert not static_engine.supports(model)
    asked = static_equilibrium(model, inputs={"F": 0.5}, compiled=True)
    reference = static_equilibrium(model, inputs={"F": 0.5}, compiled=False)
    assert np.array_equal(asked.q, reference.q)  # the same numpy computation
    # node 2 under the actuator's force at rest, Km G u = 2 x 0.5 N, on the 500 N/m spring
    assert abs(asked.x[model.coordinate_index("2.x")] - (0.2 + 1.0 / 500.0)) <= 1e-12


def test_an_unreachable_configuration_is_a_convergence_error():
    """The engine's balance at DOFs beyond the tripod's reach (its platform 10 m away, its
    wires 0.1 m long): ConvergenceError naming the model and the engine's reason."""
    model = load_scene("wire_tripod")
    balance = static_engine.EngineBalance(model)
    balance.set_load(1.0)
    start = Mechanics(model).initial_configuration()
    with pytest.raises(ConvergenceError, match=r"static balance of 'wire_tripod' at q = .*: "
                                               r"(the constraints could not be solved|a "
                                               r"singular configuration)"):
        balance.residual_and_tangent(static_engine.EnginePoint(start.q + 10.0, start.x))


@pytest.mark.parametrize("density", [0.02, 0.5])
def test_tangent_step_sparse_and_dense(density):
    """Newton's step K dq = rhs (`statics.tangent_step`): by the sparse LU at 2 % of entries
    (at most SPARSE_TANGENT), by the dense one at 50 %, both to the backward error of an LU
    against numpy.linalg.solve; a singular K is a ConvergenceError either way."""
    from flexure.core.analysis.statics import SPARSE_TANGENT, tangent_step

    rng = np.random.default_rng(7)
    n = 200
    K = np.where(rng.random((n, n)) < density / 2, rng.standard_normal((n, n)), 0.0)
    K = K + K.T + np.diag(rng.uniform(5.0, 10.0, n))  # symmetric, diagonally dominant
    assert (np.count_nonzero(K) <= SPARSE_TANGENT * K.size) == (density < SPARSE_TANGENT)
    rhs = rng.standard_normal(n)
    expected = np.linalg.solve(K, rhs)
    bound = 1e3 * n * np.finfo(float).eps * np.linalg.cond(K) * np.max(np.abs(expected))
    assert np.max(np.abs(tangent_step(K, rhs) - expected)) <= bound
    K[:, 3] = 0.0  # a zero column: singular
    with pytest.raises(ConvergenceError):
        tangent_step(K, rhs)
