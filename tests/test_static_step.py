"""The engine's statics step on the sparse saddle-point system (core/engine/static_step.py,
`static_engine.EngineBalance.free_step`) against the dense step of the same engine
(K dq = Q from OP_ACCELERATIONS and OP_TANGENT on the reduced form, `statics.tangent_step`)
and against the numpy reference's sparse augmented step (`static_augmented`), and the
equilibria it reaches against the numpy path's.

Models: BEAM cantilevers below SPARSE_STEP_FROM (96 DOFs, the sparse step forced) and at
and above it (240, 384 DOFs: the default), manipulator_control (rigid clusters, on the
reduced coordinates z; forced) and, in the slow tier, manipulator_reduced (507 DOFs) and
manipulator (816 DOFs). Kinematic inputs have no sparse Newton matrix, so their statics
keep the dense step (checked here; their equilibria in tests/test_static_engine.py).

Tolerances:
- one step at a configuration 1e-2 units (1e-3 on the manipulator) from the scene's, away
  from equilibrium: every DOF's step within 1e-9 of the largest, both in the DOFs' units
  (one linear system in three arrangements, whose round-off grows with the spread of the
  elements' stiffnesses, EA / l against EI / l^3: measured, sparse against dense, 1.2e-12
  on 16 BEAMs, 8.7e-11 on 40, 1.3e-10 on 64, 2.1e-13 on manipulator_control, 9.5e-12 on
  manipulator_reduced; numpy's augmented step against the dense one 3.4e-12, 1.0e-10,
  5.6e-10, 1.2e-12, 6.3e-12);
- Q = DF^T r of the sparse step's evaluation within 1e-10 of the largest |Q| (the same
  kinematics and forces; measured 5e-16 to 7e-14);
- the equilibria: every DOF and coordinate within 1e-10 of its unit (both Newtons stop at
  1e-11 of a unit and converge quadratically).
"""

import numpy as np
import pytest
from kinematic_scenes import chain
from test_static_tangent import away_from_equilibrium

from flexure.core import build_model, load_scene
from flexure.core.analysis import static_engine
from flexure.core.analysis.static_augmented import AugmentedBalance
from flexure.core.analysis.static_engine import EngineBalance, EnginePoint
from flexure.core.analysis.statics import static_equilibrium, tangent_step
from flexure.core.mechanics.mechanics import Mechanics
from flexure.core.mechanics.scales import coordinate_units, dof_tolerances


def cantilever(n):
    """The benchmarks' spatial BEAM cantilever of n elements (6 n DOFs), 20 N at its tip
    (large deflection)."""
    from examples.benchmarks.spatial import spatial_cantilever

    model = spatial_cantilever(n)
    return model, 20.0 * model.loads


def manipulator(name):
    """A manipulator scene with 3 N on each of its x inputs' coordinates."""
    model = load_scene(name)
    loads = np.zeros(model.nx)
    loads[[port.coordinate for port in model.inputs]] = [3.0, 0.0] * 3
    return model, loads


STEPS = {
    "cantilever, 16 BEAMs (below the threshold)": lambda: cantilever(16),
    "cantilever, 40 BEAMs (at the threshold)": lambda: cantilever(40),
    "manipulator_control (rigid clusters)": lambda: manipulator("manipulator_control"),
}


def largest(a):
    return np.max(np.abs(a))


def three_steps(model, mech, config, load):
    """(sparse step, dense step, numpy's augmented step, Q of the sparse balance's step,
    Q of the dense one) of `model` at `config` under `load` (load factor, nodal loads,
    input values): the engine's sparse and dense balances and numpy's."""
    sparse, dense = EngineBalance(model, sparse=True), EngineBalance(model, sparse=False)
    assert sparse.sparse and not dense.sparse
    for balance in (sparse, dense):
        balance.set_load(*load)
    step = sparse.free_step(EnginePoint(config.q, config.x), np.zeros(model.ndof))
    Q, K = dense.residual_and_tangent(EnginePoint(config.q, config.x))
    numpy_balance = AugmentedBalance(mech)
    numpy_balance.set_load(*load)
    lean = mech.kinematics.configuration(config.q, config.x, first_order=False)
    numpy_step = numpy_balance.free_step(lean, np.zeros(model.ndof))
    return step, tangent_step(K, Q), numpy_step, sparse.step_balance(), Q


@pytest.mark.parametrize("name", STEPS)
def test_the_sparse_step_is_the_dense_and_the_numpy_step(name):
    """At 0.6 of the loads plus 0.5 N on every coordinate, away from equilibrium."""
    model, loads = STEPS[name]()
    mech = Mechanics(model, sparse=True)
    size = 1e-3 if name.startswith("manipulator") else 1e-2
    config, units = away_from_equilibrium(model, mech, 5, size)
    step, expected, numpy_step, step_Q, Q = three_steps(model, mech, config,
                                                        (0.6, loads + 0.5, None))
    bound = 1e-9 * largest(expected / units)
    assert largest((step - expected) / units) <= bound, name
    assert largest((numpy_step - expected) / units) <= bound, name
    assert largest(step_Q - Q) <= 1e-10 * largest(Q), name
    assert largest(expected / units) > 1e-6  # a step of some size: away from equilibrium


def test_the_rule_and_what_keeps_the_dense_step(monkeypatch):
    """From SPARSE_STEP_FROM DOFs the balance steps sparse; below, and with kinematic
    inputs at any size, dense; a balance asked to step dense packs the reduced form that
    the linearisation reads, a sparse one only when asked for it."""
    at, _ = cantilever(40)
    below, _ = cantilever(39)
    assert at.ndof == static_engine.SPARSE_STEP_FROM == below.ndof + 6
    assert static_engine.sparse_step(at) and not static_engine.sparse_step(below)
    balance = static_engine.engine_balance(at)  # the live one, which live_balance sees
    assert balance.sparse and not balance.packed_dense
    assert static_engine.live_balance(at) is None  # nothing packed for the linearisation
    assert balance.data.int_array("dims").size and balance.packed_dense  # packed when read
    assert static_engine.live_balance(at) is balance
    moved = build_model(chain())  # a kinematic input
    monkeypatch.setattr(static_engine, "SPARSE_STEP_FROM", 0)
    assert moved.kinematic_inputs and not static_engine.sparse_step(moved)
    assert static_engine.sparse_step(below)
    small = load_scene("stage_spatial_19dof")  # 19 DOFs: the Newton matrix's packing
    assert not EngineBalance(small, sparse=True).sparse  # refuses it (SPARSE_NEWTON_FROM)


def equilibria_match(model, loads):
    engine_path = static_equilibrium(model, loads=loads, load_steps=2, compiled=True)
    assert static_engine.engine_balance(model).sparse
    reference = static_equilibrium(model, loads=loads, load_steps=2, compiled=False)
    units = dof_tolerances(model, 1.0)
    error = np.max(np.abs(engine_path.q - reference.q) / units)
    assert error <= 1e-10, f"{model.name}: DOFs differ by {error:.2e} of their units"
    x_units = coordinate_units(model)[0]
    error = np.max(np.abs(engine_path.x - reference.x) / x_units)
    assert error <= 1e-10, f"{model.name}: coordinates differ by {error:.2e} of their units"
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    assert np.max(np.abs(reference.q - q0) / units) > 1e-6  # the load moved the model


def test_a_large_cantilever_equilibrium_matches_numpy():
    """The 64-BEAM cantilever (384 DOFs) under 20 N at its tip: the default path steps
    sparse, the equilibrium that of the numpy path (its sparse augmented steps)."""
    model, loads = cantilever(64)
    assert static_engine.preferred(model)
    equilibria_match(model, loads)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["manipulator_reduced", "manipulator"])
def test_a_large_manipulator_equilibrium_matches_numpy(name):
    """manipulator_reduced (507 DOFs) and manipulator (816 DOFs), 3 N on each x input."""
    model, loads = manipulator(name)
    assert static_engine.preferred(model)
    equilibria_match(model, loads)


def loaded_strip(n, *, gravity=True, moments=True, rho=7850.0):
    """The spatial cantilever of n BEAMs, 20 N down at its tip, under gravity (the BEAMs'
    consistent masses: their tangent points hang on the rotations) and with moment inputs
    about the three global axes on its tip's rotation."""
    from examples.benchmarks.spatial import cantilever_spec

    spec = cantilever_spec(n)
    spec["sections"]["strip"]["rho"] = rho
    spec["nodes"][str(n)]["force"] = [0.0, 0.0, -20.0]
    if gravity:
        spec["scene"]["gravity"] = [0.0, -9.81, -3.0]
    if moments:
        spec["inputs"] = {f"M{a}": {"node": f"{n}r", "coordinate": f"r{a}"} for a in "xyz"}
    return build_model(spec)


MOMENTS = np.array([0.3, -0.2, 0.5])  # N m about x, y, z


def manipulator_under_gravity():
    """manipulator_control under gravity (its folded rigid bodies' weight through
    `balance_force`), 3 N on each x input."""
    from test_engine import scene_with_gravity

    model = scene_with_gravity("manipulator_control", [0.0, -3.0, -9.81])
    loads = np.zeros(model.nx)
    loads[[port.coordinate for port in model.inputs]] = [3.0, 0.0] * 3
    return model, loads


@pytest.mark.parametrize("gravity, moments", [(True, False), (False, True), (True, True),
                                              ("manipulator", False)])
def test_the_sparse_step_under_gravity_on_element_masses_and_moment_inputs(gravity, moments):
    """The load stiffness of moment inputs (`newton`'s port map) and of the element masses'
    gravity (`gravity_stiffness`: on the BEAMs' tangent points), and the element masses'
    gravity in r (with rigid clusters their bodies' weight): the sparse step is the dense
    engine step to round-off (measured 7e-13 to 6e-12 of the largest), and numpy's
    augmented step within 1e-9 of the largest (measured 3e-12 to 2.7e-11; 1e-12 on the
    manipulator; without gravity's load stiffness it differed by 5.6e-7 to 6.7e-7)."""
    if gravity == "manipulator":
        model, loads = manipulator_under_gravity()
        size = 1e-3
    else:
        model = loaded_strip(16, gravity=gravity, moments=moments)
        loads, size = model.loads, 1e-2
    values = MOMENTS if moments else None
    mech = Mechanics(model, sparse=True)
    config, units = away_from_equilibrium(model, mech, 5, size)
    step, expected, numpy_step, step_Q, Q = three_steps(model, mech, config,
                                                        (0.6, loads + 0.5, values))
    scale = largest(expected / units)
    assert largest((step - expected) / units) <= 1e-9 * scale
    assert largest(step_Q - Q) <= 1e-10 * largest(Q)
    assert largest((numpy_step - expected) / units) <= 1e-9 * scale


def test_large_strip_under_gravity_and_moments_matches_numpy():
    """40 BEAMs (240 DOFs: the sparse step by default) under gravity and three moments:
    the equilibrium of the numpy path (whose tangent has the gravity's load stiffness)."""
    model = loaded_strip(40)
    assert static_engine.sparse_step(model)
    inputs = dict(zip(("Mx", "My", "Mz"), MOMENTS, strict=True))
    engine_path = static_equilibrium(model, load_steps=2, inputs=inputs, compiled=True)
    assert static_engine.engine_balance(model).sparse
    reference = static_equilibrium(model, load_steps=2, inputs=inputs, compiled=False)
    units = dof_tolerances(model, 1.0)
    assert largest((engine_path.q - reference.q) / units) <= 1e-10
    assert largest((engine_path.x - reference.x) / coordinate_units(model)[0]) <= 1e-10


def test_a_model_the_newton_packing_refuses_steps_dense_and_solves():
    """A massless 40-BEAM strip (240 DOFs): the rule asks for the sparse step, the sparse
    Newton matrix's packing refuses it (every element needs mass), so the balance steps
    dense and reaches numpy's equilibrium; engine_balance(sparse=False) repacks a sparse
    balance, and a repeated call keeps it."""
    model = loaded_strip(40, gravity=False, moments=False, rho=0.0)
    assert static_engine.sparse_step(model)
    engine_path = static_equilibrium(model, load_steps=2, compiled=True)
    balance = static_engine.engine_balance(model)
    assert balance.asked and not balance.sparse and balance.packed_dense
    reference = static_equilibrium(model, load_steps=2, compiled=False)
    units = dof_tolerances(model, 1.0)
    assert largest((engine_path.q - reference.q) / units) <= 1e-10
    strip = loaded_strip(40, gravity=False, moments=False)
    first = static_engine.engine_balance(strip)
    assert first.sparse and static_engine.engine_balance(strip) is first
    dense = static_engine.engine_balance(strip, sparse=False)
    assert dense is not first and not dense.sparse
    assert static_engine.engine_balance(strip) is dense  # the default keeps what is live
    assert static_engine.live_balance(strip) is dense


def test_the_linearisation_after_a_sparse_solve():
    """A sparse balance packs no reduced form, and compiled=True reads the sparse step's
    packing (`linear_sparse`) without packing that form: numpy's matrices, the moments' load
    stiffness in G0 included (the default here is numpy's: 280 free coordinates are below
    the statics' window, `static_engine.preferred`; `engine_balance` packs the balance); the
    statics' packing is left as it was (no damping, dims.static, actuators as force inputs):
    the next solve is the same."""
    from flexure.core.analysis import linear_engine
    from flexure.core.analysis.linearization import linearize
    from flexure.core.engine import data as ed

    model = loaded_strip(40, gravity=False)  # moments: their load stiffness in G0
    inputs = dict(zip(("Mx", "My", "Mz"), MOMENTS, strict=True))
    mech = Mechanics(model)
    solution = static_equilibrium(model, load_steps=2, inputs=inputs, mechanics=mech)
    balance = static_engine.engine_balance(model)
    assert balance.sparse and not linear_engine.preferred(model, mech)
    reference = linearize(model, solution, mechanics=mech, compiled=False)
    default = linearize(model, solution, mechanics=mech)
    assert np.array_equal(default.K, reference.K)
    engine_path = linearize(model, solution, mechanics=mech, compiled=True)
    assert static_engine.engine_balance(model) is balance and not balance.packed_dense
    for field in ("M0", "K0", "G0", "K"):
        scale = largest(reference.K if field == "G0" else getattr(reference, field))
        assert largest(getattr(engine_path, field) - getattr(reference, field)) <= 1e-10 * scale
    dims = balance.step_data.int_array("dims")
    assert dims[ed.HAS_DAMPING] == 0 and dims[ed.STATIC] == 1
    assert np.all(balance.step_data.int_array("actuators")[0::2] == ed.FORCE_INPUT)
    again = static_equilibrium(model, load_steps=2, inputs=inputs, compiled=True)
    assert static_engine.engine_balance(model) is balance and balance.sparse
    assert largest((again.q - solution.q) / dof_tolerances(model, 1.0)) <= 1e-10
