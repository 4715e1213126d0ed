"""Kinematics: Newton on the constraints, and DF, D2F against finite differences."""

import numpy as np
import pytest

from flexure.core import Kinematics, Mechanics, load_scene, static_equilibrium
from flexure.core.mechanics.assembly import deformations


@pytest.fixture(params=["stage_planar_1dof", "stage_planar_3dof", "truss_1dof_e"])
def model(request):
    return load_scene(request.param)


def deformed_configuration(model, kin):
    rng = np.random.default_rng(7)
    q0 = kin.dofs_of(model.initial_coordinates)
    q = q0 + rng.normal(scale=2e-3, size=q0.size)
    return kin.solve(q, model.initial_coordinates)


def test_solve_satisfies_constraints_and_dofs(model):
    kin = Kinematics(model)
    config = deformed_configuration(model, kin)
    e = deformations(model, config.x)
    assert np.max(np.abs(e[model.rigid_deformations]), initial=0.0) < 1e-14
    np.testing.assert_allclose(kin.dofs_of(config.x), config.q, atol=1e-14)
    fixed = model.fixed_coordinates
    np.testing.assert_array_equal(config.x[fixed], model.initial_coordinates[fixed])


def differences_in_q(kin, config, of, h=1e-6):
    """d (kin.solve(q).`of`) / d q at the configuration's q by central differences with step
    h, each solve started from its x; the derivative along the last axis."""
    columns = []
    for j in range(config.q.size):
        step = np.zeros_like(config.q)
        step[j] = h
        plus = getattr(kin.solve(config.q + step, config.x), of)
        minus = getattr(kin.solve(config.q - step, config.x), of)
        columns.append((plus - minus) / (2 * h))
    return np.stack(columns, axis=-1)


def test_first_order_transfer_function(model):
    kin = Kinematics(model)
    config = deformed_configuration(model, kin)
    np.testing.assert_allclose(config.DF, differences_in_q(kin, config, "x"), atol=1e-8)


def test_second_order_transfer_function(model):
    kin = Kinematics(model)
    config = deformed_configuration(model, kin)
    D2F = kin.second_order(config)
    np.testing.assert_allclose(D2F, differences_in_q(kin, config, "DF"), atol=1e-6)
    qdot = np.linspace(0.3, -0.2, config.q.size)
    np.testing.assert_allclose(kin.convective_acceleration(config, qdot),
                               np.einsum("ajk,j,k->a", D2F, qdot, qdot), atol=1e-12)


def test_tangent_stiffness_is_the_derivative_of_the_generalised_force(model):
    """K0 + G0 = -dQ/dq, checked by finite differences in a loaded, deformed state."""
    mech = Mechanics(model)
    kin = mech.kinematics
    loads = np.zeros(model.nx)
    loads[model.coordinate_index(model.coordinate_names[model.free_coordinates[0]])] = 3.0
    config = deformed_configuration(model, kin)
    _, _, sigma = mech.static_balance(config, 1.0, loads)
    K = mech.structural_stiffness(config) + mech.geometric_stiffness(config, sigma)
    h = 1e-7
    for j in range(config.q.size):
        step = np.zeros_like(config.q)
        step[j] = h
        plus = mech.static_balance(kin.solve(config.q + step, config.x), 1.0, loads)[0]
        minus = mech.static_balance(kin.solve(config.q - step, config.x), 1.0, loads)[0]
        np.testing.assert_allclose(K[:, j], -(plus - minus) / (2 * h),
                                   rtol=1e-5, atol=1e-5 * np.abs(K).max())


def test_static_equilibrium_balances_forces():
    model = load_scene("stage_planar_3dof")
    loads = np.zeros(model.nx)
    loads[model.coordinate_index("3.x")] = 20.0  # N sideways: about 2 cm, 20 % of the spring
    solution = static_equilibrium(model, loads=loads)
    mech = Mechanics(model)
    Q, _, _ = mech.static_balance(solution.config, 1.0, loads)
    assert np.max(np.abs(Q)) < 1e-8
    x = solution.coordinates()["3.x"]
    assert 0.015 < x < 0.0212  # stiffening makes it less than the linear 20/945 m


def test_tangent_stiffness_with_gravity_on_distributed_mass():
    """Gravity on the beams' consistent mass depends on their rotations: its derivative
    enters the tangent stiffness, checked by differences in a rotated configuration."""
    model = load_scene("stage_planar_3dof")
    model.gravity[:] = [3.0, -9.81]
    mech = Mechanics(model)
    kin = mech.kinematics
    config = kin.solve(kin.dofs_of(model.initial_coordinates) + [0.01, -0.002, 0.3],
                       model.initial_coordinates)
    _, _, sigma = mech.static_balance(config)
    K = mech.structural_stiffness(config) + mech.geometric_stiffness(config, sigma)
    h = 1e-7
    for j in range(3):
        step = np.zeros(3)
        step[j] = h
        plus = mech.static_balance(kin.solve(config.q + step, config.x))[0]
        minus = mech.static_balance(kin.solve(config.q - step, config.x))[0]
        np.testing.assert_allclose(K[:, j], -(plus - minus) / (2 * h),
                                   rtol=1e-5, atol=1e-6 * np.abs(K).max())


def test_static_sag_under_gravity():
    """The bar and the upper halves of the springs (consistent load) hang on 2 EA / l0."""
    model = load_scene("stage_planar_3dof")
    model.gravity[:] = [0.0, -9.81]
    solution = static_equilibrium(model)
    weight = 9.81 * (0.206 + 2 * 0.07065 * 0.1 / 2)  # N
    sag = weight / (2 * 1.89e6 / 0.1)  # m
    assert solution.coordinates()["3.y"] - 0.1 == pytest.approx(-sag, rel=1e-6)
    assert abs(solution.coordinates()["3.x"]) < 1e-15


def test_dofs_beyond_the_reach_of_the_mechanism_are_a_clear_error():
    """One PLBEAM per spring with a rigid elongation reaches about 92 mm sideways (a limit
    point); asking for 95 mm is refused, naming the DOF values."""
    from flexure.core import ConvergenceError

    model = load_scene("stage_planar_1dof")
    kin = Kinematics(model)
    x = model.initial_coordinates.copy()
    for q in np.linspace(0.0, -0.09, 19):  # follow the branch to 90 mm
        x = kin.solve(np.array([q]), x).x
    with pytest.raises(ConvergenceError, match=r"q = \[-0\.095\].*beyond the reach"):
        kin.solve(np.array([-0.095]), x)


def test_the_sparse_constraint_factor_gives_the_dense_ones_results(monkeypatch):
    """Large models factor J with SuperLU instead of LAPACK's dense LU: the same static
    equilibrium, DF and constraint multipliers, to round-off, on the 19-DOF stage forced
    through each path."""
    from flexure.core.mechanics import kinematics

    results = {}
    for path, threshold in (("dense", 10**9), ("sparse", 0)):
        monkeypatch.setattr(kinematics, "SPARSE_FROM", threshold)
        model = load_scene("stage_spatial_19dof")
        solution = static_equilibrium(model)
        assert solution.config.lu.sparse == (path == "sparse")
        force = np.linspace(-1.0, 1.0, model.nx)
        multipliers = Kinematics(model).multipliers(solution.config, force)
        results[path] = (solution.x, solution.config.DF, multipliers)
    for dense, sparse in zip(results["dense"], results["sparse"], strict=True):
        np.testing.assert_allclose(sparse, dense, rtol=1e-9, atol=1e-12 * np.abs(dense).max())


def test_a_sparse_factor_of_a_non_finite_jacobian_solves_to_nan():
    import scipy.sparse

    from flexure.core.mechanics.kinematics import JacobianFactor

    J = scipy.sparse.csc_matrix(np.array([[1.0, 0.0], [np.inf, 1.0]]))
    assert np.all(np.isnan(JacobianFactor(J).solve(np.ones(2))))
    singular = scipy.sparse.csc_matrix(np.array([[1.0, 1.0], [1.0, 1.0]]))
    assert np.all(np.isnan(JacobianFactor(singular).solve(np.ones(2))))


def test_an_unloaded_model_is_at_rest_where_it_was_built():
    """No load, no gravity: one Newton step at full load confirms the reference configuration
    (stage_spatial_1dof's only force is its buckling reference load)."""
    model = load_scene("stage_spatial_1dof")
    assert not np.any(model.loads) and not np.any(model.gravity)
    solution = static_equilibrium(model)
    assert solution.iterations == 1
    np.testing.assert_allclose(solution.x, model.initial_coordinates, rtol=0, atol=1e-15)
