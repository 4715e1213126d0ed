"""The load stiffness of gravity on element masses that hang on rotations in the engine's
tangent (core/engine/gravity_stiffness.py, in OP_TANGENT's K_x and the sparse static step's):
-d(Dp^T Mp g_p)/dx = -sum_p w_p D2p_p, w = Mp g_p, against the numpy reference
(`Inertia.gravity_stiffness`, in `Mechanics.tangent_stiffness`) and against central
differences of the engine's own static balance.

Models: the spatial BEAM cantilever with a rigid body on its tip under gravity and three
moments (test_static_tangent), the planar stage under gravity (PLBEAMs), the spatial 1-DOF
stage under gravity, and manipulator_control under gravity (rigid clusters: its BEAMs'
masses on the clusters' z-coordinates).

Tolerances:
- K = K0 + G0 of the engine (`linear_engine.engine_matrices`) against numpy's linearisation
  within 1e-10 of K's largest entry (the same products summed in another order; measured
  1.2e-17 on the cantilever); and, so that the check sees the term, within 1e-3 of the
  term itself where it exceeds 1e-10 of K (the cantilever's is 8e-9 of K);
- the natural frequencies through the engine against numpy's within 1e-9 relative (the
  matrices' round-off times M0's conditioning; without the term the cantilever's moved by
  3.5e-6);
- central differences of the engine's Q(q) (steps of 1e-5 units, truncation O(h^2)) against
  its K within 1e-6 of the largest entry of U K U, as tests/test_static_tangent.py bounds
  numpy's, on a strip whose gravity's load stiffness is 1e-3 of that (a density 1e5 times
  steel's): without the term the check fails.
"""

import numpy as np
import pytest
from test_engine import scene_with_gravity
from test_sparse_newton import newton_solve_beside_dense, sparse_data
from test_static_step import loaded_strip
from test_static_tangent import away_from_equilibrium, cantilever_with_gravity

from examples.benchmarks.spatial import cantilever_spec
from flexure.core import build_model
from flexure.core.analysis import linear_engine
from flexure.core.analysis.linearization import linearize
from flexure.core.analysis.modal import natural_frequencies
from flexure.core.analysis.static_engine import EngineBalance, EnginePoint
from flexure.core.analysis.statics import static_equilibrium
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.operations import OP_NEWTON_JACOBIAN
from flexure.core.mechanics.mechanics import Mechanics


def largest(a):
    return float(np.max(np.abs(a)))


def with_inputs(model, values=None):
    return model, values


MODELS = {
    "spatial BEAM cantilever": lambda: cantilever_with_gravity()[:2],
    "planar stage": lambda: with_inputs(scene_with_gravity("stage_planar_3dof", [0.0, -9.81])),
    "manipulator_control": lambda: with_inputs(scene_with_gravity(
        "manipulator_control", [0.0, -3.0, -9.81])),
}


def solved(name):
    """(model, mechanics, its static equilibrium under the scene's loads and gravity)."""
    model, values = MODELS[name]()
    mech = Mechanics(model)
    return model, mech, static_equilibrium(model, inputs=values, mechanics=mech)


@pytest.mark.parametrize("name", list(MODELS))
def test_the_engine_tangent_has_gravity_load_stiffness(name):
    model, mech, solution = solved(name)
    assert linear_engine.supports(model, mech)
    reference = linearize(model, solution, mechanics=mech, compiled=False)
    _, _, K0, G0 = linear_engine.engine_matrices(model, solution, mech)
    DF = solution.config.DF
    term = largest(DF.T @ mech.inertia.gravity_stiffness(solution.x) @ DF)
    error = largest(K0 + G0 - reference.K)
    print(f"{name}: term {term / largest(reference.K):.2e}, error "
          f"{error / largest(reference.K):.2e} of K")
    assert error <= 1e-10 * largest(reference.K)
    assert error <= 1e-3 * term  # the check sees the term


@pytest.mark.parametrize("name", ["spatial BEAM cantilever", "planar stage"])
def test_frequencies_through_the_engine_match_numpy(name):
    model, mech, solution = solved(name)
    assert linear_engine.supports(model, mech)  # compiled=True takes the engine
    engine_path, reference = (natural_frequencies(model, linear_model=linearize(
        model, solution, mechanics=mech, compiled=compiled)) for compiled in (True, False))
    error = largest(engine_path.frequencies_hz / reference.frequencies_hz - 1.0)
    print(f"{name}: frequencies {error:.2e} relative")
    assert error <= 1e-9


STEP, TOLERANCE = 1e-5, 1e-6  # units of each DOF; of the largest entry of U K U


def test_the_engine_tangent_is_the_jacobian_of_its_static_balance():
    model = loaded_strip(4, moments=False, rho=7850.0e6)
    mech = Mechanics(model)
    config, units = away_from_equilibrium(model, mech, 3, 1e-2)
    balance = EngineBalance(model, sparse=False)
    balance.set_load(1.0)

    def residual(q):
        return balance.residual_and_tangent(EnginePoint(q, config.x.copy()))[0]

    _, K = balance.residual_and_tangent(EnginePoint(config.q, config.x.copy()))
    differences = np.empty_like(K)
    for j in range(units.size):
        h = np.zeros(units.size)
        h[j] = STEP * units[j]
        differences[:, j] = -(residual(config.q + h) - residual(config.q - h)) / (2 * h[j])
    U = np.diag(units)
    term = U @ config.DF.T @ mech.inertia.gravity_stiffness(config.x) @ config.DF @ U
    scale = largest(U @ differences @ U)
    error = largest(U @ (K - differences) @ U)
    without = largest(U @ (K - differences) @ U + term)  # K less gravity's load stiffness
    print(f"term {largest(term) / scale:.2e}, error {error / scale:.2e}, without it "
          f"{without / scale:.2e}")
    assert error <= TOLERANCE * scale
    assert without > 1e2 * TOLERANCE * scale  # the check sees the term



def test_the_sparse_newton_matrix_has_it_as_the_dense_jacobian(monkeypatch):
    """The ESDIRK's sparse Newton solve (`newton`) against numpy's (I - hg J)^-1 r with the
    engine's dense first-order Jacobian J (OP_TANGENT's K) on an 8-BEAM cantilever under
    gravity (a density 1e3 times steel's), DOFs 1e-4 from the initial ones: within 1e-9 of
    the solution's size (tests/test_sparse_newton.py's bound); without gravity's load
    stiffness in J's K the solve moves by more than 1e-6 of it at hg = 1e-3 s."""
    spec = cantilever_spec(8)
    spec["sections"]["strip"]["rho"] = 7850.0e3
    spec["scene"]["gravity"] = [0.0, -9.81, -3.0]
    model = build_model(spec)
    data = sparse_data(model, monkeypatch)
    mech = Mechanics(model)
    q0 = mech.kinematics.dofs_of(model.initial_coordinates)
    n = q0.size
    q = q0 + 1e-4 * np.random.default_rng(7).standard_normal(n)
    y = np.concatenate([q - data.float_array("q_ref"), np.zeros(n)])
    J = np.zeros(4 * n * n)
    assert engine.call(data, engine.OP_JACOBIAN, y, J) == ed.OK
    J = J.reshape(2 * n, 2 * n)
    assert engine.call(data, OP_NEWTON_JACOBIAN, y, np.zeros(1)) == ed.OK
    config = mech.kinematics.solve(q, model.initial_coordinates)
    term = config.DF.T @ mech.inertia.gravity_stiffness(config.x) @ config.DF
    without = J.copy()  # J's lower left is -M_bar^-1 K; K less the term is K + term
    without[n:, :n] -= np.linalg.solve(config.DF.T @ mech.inertia.mass_matrix(config.x)
                                       @ config.DF, term)
    r = np.random.default_rng(8).standard_normal(2 * n)
    for hg in (1e-5, 1e-3):
        v, expected = newton_solve_beside_dense(data, J, hg, r)
        size = largest(expected)
        assert largest(v - expected) <= 1e-9 * size
    moved = np.linalg.solve(np.eye(2 * n) - 1e-3 * without, r)
    print(f"without the term {largest(moved - expected) / size:.2e}")
    assert largest(moved - expected) > 1e-6 * size
