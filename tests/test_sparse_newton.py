"""The ESDIRK's sparse Newton matrix (`engine.newton`) against the dense one.

On a model the engine packs with dims[NEWTON_SPARSE] = 1 the ESDIRK solves (I - hg J) v = r
through the saddle-point system on the free coordinates. Checked here:

- the solve against the dense path's (I - hg J)^-1 r (the engine's first-order Jacobian,
  numpy's solve) to round-off, and against the numpy reference's J (`Mechanics`: M_bar,
  K0 + G0 - the moment inputs' load stiffness, C0; tests/test_engine.py's plain formulas),
  at states away from rest: an 8-BEAM damped spatial cantilever (48 DOFs) and a rod with a
  body under a moment input (the load stiffness; tests/test_rotation_ports.py);
- a 5 ms ESDIRK run of that cantilever on either path within a run's global error of the
  converged coordinates;
- which models take the path (`newton_packing`'s rule).

The DOF threshold `newton_packing.SPARSE_NEWTON_FROM` (50) is lowered to force the path on
these small models (it is read at packing).
"""

import numpy as np
import pytest
from test_engine import plain_dynamics, plain_tangent
from test_rotation_ports import rod_body

from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import Mechanics, Simulator, build_model, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine, newton_packing
from flexure.core.engine.data import EngineData
from flexure.core.engine.operations import OP_NEWTON_FACTOR, OP_NEWTON_JACOBIAN, OP_NEWTON_SOLVE

MODELS = {"cantilever_8": lambda: spatial_cantilever(8),
          "rod_body": lambda: build_model(rod_body())}
# hg (s): the Newton matrix near I (2e-8: the 384-DOF cantilever's first steps after its tip
# load, hg 8e-9 to 3e-8) and far from it
STEPS = (2e-8, 1e-5, 1e-3)


def sparse_data(model, monkeypatch):
    """The model packed with the sparse Newton matrix forced on (the augmented form)."""
    monkeypatch.setattr(newton_packing, "SPARSE_NEWTON_FROM", 0)
    data = EngineData(model, augmented=True)
    assert data.int_array("dims")[ed.NEWTON_SPARSE] == 1
    return data


def newton_solve_beside_dense(data, J, hg, r):
    """(v, expected): r through the engine's NEWTON_FACTOR and NEWTON_SOLVE at hg (s), and
    (I - hg J)^-1 r by numpy's dense solve with the first-order Jacobian J."""
    expected = np.linalg.solve(np.eye(J.shape[0]) - hg * J, r)
    assert engine.call(data, OP_NEWTON_FACTOR, s=hg) == ed.OK
    v = r.copy()
    assert engine.call(data, OP_NEWTON_SOLVE, v, s=hg) == ed.OK
    return v, expected


@pytest.mark.parametrize("name", sorted(MODELS))
def test_the_sparse_newton_solve_is_the_dense_one(name, monkeypatch):
    """(I - hg J)^-1 r by the sparse path against numpy's solve with the engine's dense J
    and with the numpy reference's J, each to 1e-9 of the solution's size (measured: 1.6e-12
    to 3.4e-12 on the cantilever, whose matrix's condition number is up to 1e13 from the
    mixed units of q and qdot; 2e-15 on the rod). The state: DOFs 1e-4 (m or rad) and
    velocities 0.05 m/s (rad/s) from the initial ones, a moment of 0.5 N m on each moment
    input, so that the stress resultants (G0), the damping (C0) and the load stiffness
    enter; the solve with J at rest differs from the one there by 1e-6 of its size at least
    (measured: 1.0 on the cantilever, 3e-3 on the rod), so the state counts."""
    model = MODELS[name]()
    data = sparse_data(model, monkeypatch)
    mechanics = Mechanics(model)
    q0 = mechanics.kinematics.dofs_of(model.initial_coordinates)
    n = q0.size
    rng = np.random.default_rng(7)
    q, qdot = q0 + 1e-4 * rng.standard_normal(n), 0.05 * rng.standard_normal(n)
    u = np.full(len(model.inputs), 0.5)
    data.float_array("inputs")[:] = u
    y = np.concatenate([q - data.float_array("q_ref"), qdot])
    J = np.zeros(4 * n * n)
    assert engine.call(data, engine.OP_JACOBIAN, y, J) == ed.OK
    J = J.reshape(2 * n, 2 * n)
    plain = plain_dynamics(model, mechanics, q, qdot, u)
    K, C = plain_tangent(mechanics, plain, plain["qddot"])
    solve_mass = np.linalg.solve(plain["mass"], np.hstack([K, C]))
    reference = np.block([[np.zeros((n, n)), np.eye(n)], [-solve_mass]])
    at_rest = np.zeros(4 * n * n)
    data.float_array("inputs")[:] = 0.0
    rest_state = np.concatenate([q0 - data.float_array("q_ref"), np.zeros(n)])
    assert engine.call(data, engine.OP_JACOBIAN, rest_state, at_rest) == ed.OK
    data.float_array("inputs")[:] = u
    assert engine.call(data, OP_NEWTON_JACOBIAN, y, np.zeros(1)) == ed.OK
    for hg in STEPS:
        r = rng.standard_normal(2 * n)
        v, expected = newton_solve_beside_dense(data, J, hg, r)
        size = np.max(np.abs(expected))
        assert np.max(np.abs(v - expected)) <= 1e-9 * size
        plain_solution = np.linalg.solve(np.eye(2 * n) - hg * reference, r)
        assert np.max(np.abs(v - plain_solution)) <= 1e-9 * size
        rest = np.linalg.solve(np.eye(2 * n) - hg * at_rest.reshape(2 * n, 2 * n), r)
        assert np.max(np.abs(rest - expected)) > 1e-6 * size


def tip_run(monkeypatch, threshold, rtol=1e-6):
    """The coordinates (m, 1) of the 8-BEAM cantilever 5 ms after its 1 N tip load (ESDIRK
    at rtol) and whether the sparse Newton matrix served."""
    monkeypatch.setattr(newton_packing, "SPARSE_NEWTON_FROM", threshold)
    sim = Simulator(spatial_cantilever(8), method="esdirk", rtol=rtol)
    sim.advance_to(5e-3)
    return sim.data.float_array("x").copy(), bool(sim.data.int_array("dims")[ed.NEWTON_SPARSE])


def test_the_cantilever_moves_alike_on_either_newton_matrix(monkeypatch):
    """The run on the sparse path and on the dense one at rtol 1e-6, each against the dense
    path's converged run (rtol 1e-10): within 1e-3 of the largest displacement, the global
    error such a run makes (measured: 2.6e-4 sparse, 7.0e-5 dense). Their steps differ: the
    sparse Newton matrix is factored at every new step size, the dense one within a slack
    (`esdirk_newton.SPARSE_LU_SLACK`), so the two are two integrations of the same
    equations, not one to round-off (the solves agree to round-off: above)."""
    sparse, on = tip_run(monkeypatch, 0)
    dense, off = tip_run(monkeypatch, 10**9)
    converged, _ = tip_run(monkeypatch, 10**9, rtol=1e-10)
    assert on and not off
    moved = np.max(np.abs(converged - spatial_cantilever(8).initial_coordinates))
    assert moved > 1e-5  # m: the tip has moved
    for run in (sparse, dense):
        assert np.max(np.abs(run - converged)) <= 1e-3 * moved


def test_which_models_take_the_sparse_newton_matrix(monkeypatch):
    """The rule of `newton_packing`: the 384-DOF cantilever by default; not the 48-DOF one
    (below SPARSE_NEWTON_FROM), nor, forced, a model with rigid clusters whose augmented
    system is banded (stage_planar_3dof; with clusters: tests/test_rigid_sparse_newton.py)
    or one in the reduced form."""
    assert EngineData(spatial_cantilever(64)).int_array("dims")[ed.NEWTON_SPARSE] == 1
    assert EngineData(spatial_cantilever(8)).int_array("dims")[ed.NEWTON_SPARSE] == 0
    monkeypatch.setattr(newton_packing, "SPARSE_NEWTON_FROM", 0)
    stage = EngineData(load_scene("stage_planar_3dof"), augmented=True)
    assert stage.int_array("dims")[ed.NEWTON_SPARSE] == 0
    reduced = EngineData(spatial_cantilever(8), augmented=False)
    assert reduced.int_array("dims")[ed.NEWTON_SPARSE] == 0
