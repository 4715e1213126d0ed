"""The statics' Newton step from the sparse augmented system (core/analysis/static_augmented.py)
against the reduced step on the DOFs, K dq = Q, of the numpy reference (`Mechanics`'
static_balance and tangent_stiffness), which `static_equilibrium(..., augmented=False)` runs.

Every built-in scene, scenes with gravity on element masses, moments about global axes, an
actuator, and a kinematic input; the small ones through a forced sparse `Mechanics` (the
augmented step needs it; by default only models of 300 free coordinates and more take it).

Tolerances:
- one step, at a configuration away from equilibrium: every DOF's step within 1e-8 of the
  largest, both in the DOFs' units (the two solve one linear system in two arrangements;
  their round-off is K's condition number times eps of the step, measured 5e-11 on
  manipulator_reduced);
- the equilibria: every DOF and coordinate within 1e-10 of its unit, the stress resultants
  within the bounds of tests/test_static_engine.py (both Newtons stop at 1e-11 of a unit and
  converge quadratically: measured 1e-15 of a unit).
"""

import numpy as np
import pytest
from kinematic_scenes import chain
from test_static_engine import LARGE, SCENES, stress_bound
from test_static_tangent import away_from_equilibrium

from flexure.core import build_model, load_scene
from flexure.core.analysis.static_augmented import AugmentedBalance
from flexure.core.analysis.statics import static_equilibrium
from flexure.core.mechanics.actuators import steady_port_values
from flexure.core.mechanics.mechanics import Mechanics
from flexure.core.mechanics.scales import coordinate_units, dof_tolerances

# the massless truss has no mass to test beyond the truss; manipulator_stage is a mechanism
# (its tangent singular: any step solves it, tests/test_static_engine.py solves its statics)
CASES = {name: make for name, make in SCENES.items()
         if name not in ("massless truss", "manipulator_stage")}
CASES["spring chain, kinematic input"] = lambda: (build_model(chain()), None)


def marked(names):
    return [pytest.param(name, marks=pytest.mark.slow) if name in LARGE else name
            for name in names]


def reduced_step(mech, config, load, dq):
    """The free DOFs' step of `statics._newton` from K and Q: K_ff dq_f = Q_f - K_fk dq_k."""
    model = mech.model
    Q, _, sigma = mech.static_balance(config, *load)
    K = mech.tangent_stiffness(config, sigma, load[0], inputs=load[2])
    free, held = model.free_dofs, model.prescribed_dofs
    return np.linalg.solve(K[np.ix_(free, free)], Q[free] - K[np.ix_(free, held)] @ dq[held])


@pytest.mark.parametrize("name", marked(CASES))
def test_the_augmented_step_is_the_reduced_step(name):
    """At 0.6 of the scene's loads (plus 0.5 N on every coordinate) and inputs, 1e-2 units
    (1e-3 on the manipulators) from the scene's configuration; a kinematic input moved by
    1e-3 of its unit."""
    model, values = CASES[name]()
    if values is not None and model.actuators:  # the port values at rest
        values = steady_port_values(model, values)
    mech = Mechanics(model, sparse=True)
    size = 1e-3 if name.startswith("manipulator") else 1e-2
    config, units = away_from_equilibrium(model, mech, 5, size)
    load = (0.6, model.loads + 0.5, values)
    dq = np.zeros(model.ndof)
    dq[model.prescribed_dofs] = 1e-3 * units[model.prescribed_dofs]
    expected = reduced_step(mech, config, load, dq)
    balance = AugmentedBalance(mech)
    balance.set_load(*load)
    lean = mech.kinematics.configuration(config.q, config.x, first_order=False)
    step = balance.free_step(lean, dq)
    scale = units[model.free_dofs]
    error = np.max(np.abs(step - expected) / scale)
    assert error <= 1e-8 * np.max(np.abs(expected) / scale), f"{name}: {error:.2e}"


@pytest.mark.parametrize("name", marked(CASES))
def test_augmented_equilibria_match_the_reduced_ones(name):
    model, inputs = CASES[name]()
    motions = {"u": 0.102} if model.kinematic_inputs else None  # 2 mm from node 1's 0.1 m
    solutions = [static_equilibrium(model, inputs=inputs, motions=motions, compiled=False,
                                    augmented=augmented,
                                    mechanics=Mechanics(model, sparse=True))
                 for augmented in (True, False)]
    units = dof_tolerances(model, 1.0)
    error = np.max(np.abs(solutions[0].q - solutions[1].q) / units, initial=0.0)
    assert error <= 1e-10, f"{name}: DOFs differ by {error:.2e} of their units"
    error = np.max(np.abs(solutions[0].x - solutions[1].x) / coordinate_units(model)[0])
    assert error <= 1e-10, f"{name}: coordinates differ by {error:.2e} of their units"
    mech = Mechanics(model)
    sigma = solutions[1].stress_resultants
    bound = stress_bound(model, mech, np.max(np.abs(sigma)))
    assert np.all(np.abs(solutions[0].stress_resultants - sigma) <= bound), name
    assert solutions[0].config.DF is not None  # formed for the linear analyses
    if motions:
        assert abs(solutions[0].efforts()["u"] - solutions[1].efforts()["u"]) <= 1e-12


def test_a_large_model_takes_the_augmented_step_by_default():
    """manipulator_control's numpy path (784 free coordinates) steps through the augmented
    system unless told otherwise; a model on the dense mechanics cannot."""
    model = load_scene("manipulator_control")
    assert Mechanics(model).sparse
    small = load_scene("truss_1dof_x")
    with pytest.raises(ValueError, match="sparse mechanics"):
        static_equilibrium(small, compiled=False, augmented=True)


def unprojected_steps(name, size, count):
    """The free DOFs' steps (in their units) of `count` Newton iterations of the augmented
    balance from the scene's equilibrium with every DOF moved by `size` units at random
    (projected there), and the unprojected iterates with their projections (`solved`)."""
    model, inputs = CASES[name]()
    values = inputs
    if values is not None and model.actuators:
        values = steady_port_values(model, values)
    mech = Mechanics(model, sparse=True)
    solution = static_equilibrium(model, inputs=inputs, compiled=False, mechanics=mech)
    units = dof_tolerances(model, 1.0)
    moved = solution.q + size * units * np.random.default_rng(3).standard_normal(units.size)
    config = mech.kinematics.solve(moved, solution.x)
    balance = AugmentedBalance(mech)
    balance.set_load(1.0, None, values)
    steps, unprojected = [], []
    for _ in range(count):
        dq = np.zeros(model.ndof)
        dq[model.free_dofs] = balance.free_step(config, dq)
        steps.append(np.max(np.abs(dq) / units))
        config = balance.moved(config, config.q + dq, as_stepped=True)
        if balance.is_unprojected(config):  # (a round-off step is projected)
            unprojected.append((config, balance.solved(config)))
    return mech, unprojected, np.array(steps)


@pytest.mark.parametrize("name", ["spatial cantilever, 26 BEAMs",
                                  "spatial beam, moments about global axes, gravity",
                                  "planar stage, gravity"])
def test_unprojected_iterates_converge_to_the_projected_equilibrium(name):
    """Newton on the coordinates and multipliers without projecting the iterates onto the
    constraints (static_augmented's module docstring), 1e-3 units from the equilibrium: the
    steps (in the DOFs' units) reach round-off, 1e-13, in five iterations, as the projected
    iterates do (measured: the same steps to two digits on the two scenes with gravity);
    on the cantilever each step above 1e-7 is followed by one at most 100 times its square
    (Newton's quadratic convergence: measured 3e-3, 3e-5, 7e-10). The projected solution
    satisfies the constraints to 10 times the kinematics' step tolerance and its DOFs are
    the last unprojected iterate's within 1e-12 of their units (the projection corrects by
    the order of the last step squared)."""
    mech, unprojected, steps = unprojected_steps(name, 1e-3, 5)
    assert len(unprojected) >= 2, f"{name}: {len(unprojected)} iterates not projected"
    assert steps[-1] <= 1e-13, f"{name}: steps {steps}"
    if name.startswith("spatial cantilever"):
        for before, after in zip(steps[:-1], steps[1:], strict=True):
            if before > 1e-7:
                assert after <= 100.0 * before**2, f"{name}: steps {steps}"
    last, solved = unprojected[-1]
    kin = mech.kinematics
    residual = kin.residual(solved.x, solved.e, solved.q)
    assert np.all(np.abs(residual) <= 10.0 * kin.step_tolerance), name
    units = dof_tolerances(mech.model, 1.0)
    assert np.max(np.abs(solved.q - last.q) / units) <= 1e-12, name


def test_an_unprojected_step_far_beyond_reach_is_a_convergence_error():
    """A step that takes x + dx where the deformations are not finite raises (the load step
    is then halved by `static_equilibrium`), it is not integrated as NaN."""
    from flexure.core.errors import ConvergenceError

    model, _ = CASES["spatial cantilever, 26 BEAMs"]()
    mech = Mechanics(model, sparse=True)
    balance = AugmentedBalance(mech)
    config = mech.initial_configuration()
    balance.set_load(1.0, model.loads + 0.5, None)
    dq = np.zeros(model.ndof)
    dq[model.free_dofs] = balance.free_step(config, dq)
    made_at, dx = balance._step
    balance._step = (made_at, np.full_like(dx, 1e300))
    with pytest.raises(ConvergenceError, match="reach"):
        balance.moved(config, config.q + dq, as_stepped=True)


def test_an_iterate_not_the_balances_own_step_is_projected():
    """`moved` leaves an iterate unprojected only when the caller says it is the balance's
    own step unchanged (as_stepped); the same q otherwise, as after the curvature
    predictor, is projected: the kinematics solved for q, so its constraints hold to 10
    times the kinematics' step tolerance and its DOFs are q's to round-off (1e-12 of their
    units), while the unprojected iterate's rigid deformations are off by about the step
    squared."""
    model, _ = CASES["spatial cantilever, 26 BEAMs"]()
    mech = Mechanics(model, sparse=True)
    balance = AugmentedBalance(mech)
    config = mech.initial_configuration()
    balance.set_load(1.0, model.loads * 50.0, None)
    dq = np.zeros(model.ndof)
    dq[model.free_dofs] = balance.free_step(config, dq)
    q = config.q + dq
    projected = balance.moved(config, q, as_stepped=False)
    assert not balance.is_unprojected(projected)
    kin = mech.kinematics
    residual = kin.residual(projected.x, projected.e, projected.q)
    assert np.all(np.abs(residual) <= 10.0 * kin.step_tolerance)
    units = dof_tolerances(model, 1.0)
    assert np.max(np.abs(projected.q - q) / units) <= 1e-12
    unprojected = balance.moved(config, q, as_stepped=True)
    assert balance.is_unprojected(unprojected)
    off = kin.residual(unprojected.x, unprojected.e, unprojected.q)
    assert np.max(np.abs(off)) > 10.0 * np.max(kin.step_tolerance)


@pytest.mark.slow
def test_a_workspace_pose_of_the_manipulator_matches_the_reduced_newton():
    """manipulator_reduced (507 DOFs) at the report's -3 mm z pose (examples/
    manipulator_report.py's loads: the actuator forces K_dc (-3 mm radial strokes)),
    stepped through the unprojected augmented iterates and through the reduced K dq = Q on
    the DOFs (the numpy reference): every DOF and coordinate within 1e-10 of its unit."""
    from flexure.core import linearize, static_gain

    model = load_scene("manipulator_reduced")
    mech = Mechanics(model)
    rest = static_equilibrium(model, mechanics=mech)
    stiffness = np.linalg.inv(static_gain(model, linear_model=linearize(model, rest,
                                                                        mechanics=mech)))
    angles = np.radians([90.0, 210.0, 330.0])
    strokes = np.ravel([(3e-3 * np.cos(a), 3e-3 * np.sin(a)) for a in angles])
    loads = np.zeros(model.nx)
    loads[[port.coordinate for port in model.inputs]] = stiffness @ strokes
    solutions = [static_equilibrium(model, loads=loads, load_steps=2, compiled=False,
                                    augmented=augmented, mechanics=mech)
                 for augmented in (True, False)]
    units = dof_tolerances(model, 1.0)
    error = np.max(np.abs(solutions[0].q - solutions[1].q) / units)
    assert error <= 1e-10, f"DOFs differ by {error:.2e} of their units"
    error = np.max(np.abs(solutions[0].x - solutions[1].x) / coordinate_units(model)[0])
    assert error <= 1e-10, f"coordinates differ by {error:.2e} of their units"
