"""The engine's rhs with the BEAMs' quadratic forms h = xdot^T D2e xdot from their
directional kernel (`beam_directional`), and the readers of D2e after it.

At a kinematic solution the engine evaluates a BEAM's e and De alone (`kinematics.
AT_SOLUTION`) and its Hessians only where a tangent reads them (`kinematics.
hessians_at_solution`). Checked on a 4-BEAM spatial cantilever (24 DOFs, every deformation
a DOF, so every BEAM row needs h), damped, at states away from rest:

- the rhs against the numpy reference's accelerations (`Mechanics`, tests/test_engine.py's
  plain formulas), to the backward error of qddot;
- the first-order Jacobian taken after a Jacobian at another state and an rhs at this one
  (the sequence in which a reader would meet the other state's D2e, were it not evaluated
  again) against the numpy reference's tangent (M_bar J = -[K0 + G0, C0] to 1e-10, as
  tests/test_engine.py; not central differences of the rhs: away from the static
  equilibrium they include the derivatives of the mass and velocity terms, which the
  tangent leaves out, 2 % here on base and branch alike) and against a fresh simulator's
  Jacobian there (1e-9: the two kinematic solutions differ by their warm starts'
  round-off);
- the Hessians the tangent evaluated equal to the BEAM kernel's at the solution, bit for bit
  (the same kernel at the same x).
"""

import numpy as np
from test_engine import close, plain_dynamics, plain_tangent

from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import Mechanics, Simulator
from flexure.core.engine import data as ed
from flexure.core.engine import engine


def cantilever_states(count, seed=11):
    """(model, simulator, q0, [(q, qdot)]): DOFs 1e-4 from the initial ones, velocities of
    0.05 (1/s, m/s by the deformation)."""
    model = spatial_cantilever(4)
    sim = Simulator(model)
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    rng = np.random.default_rng(seed)
    n = q0.size
    return model, sim, q0, [(q0 + 1e-4 * rng.standard_normal(n), 0.05 * rng.standard_normal(n))
                            for _ in range(count)]


def test_rhs_matches_the_plain_equations_of_motion():
    model, sim, _, states = cantilever_states(2)
    mechanics = Mechanics(model)
    u = np.zeros(len(model.inputs))
    for q, qdot in states:
        plain = plain_dynamics(model, mechanics, q, qdot, u)
        ydot = sim.derivative(0.0, np.concatenate([q - sim.q_ref, qdot]))
        close(ydot[q.size:], plain["qddot"], 1e-12,
              scale=np.max(plain["size"]) / np.linalg.eigvalsh(plain["mass"])[0])


def test_jacobian_after_an_rhs_reads_the_hessians_of_its_own_state():
    model, sim, _, ((q1, v1), (q2, v2)) = cantilever_states(2)
    n = q1.size
    y1 = np.concatenate([q1 - sim.q_ref, v1])
    y2 = np.concatenate([q2 - sim.q_ref, v2])
    sim.jacobian_matrix(0.0, y1)  # D2e at y1's solution
    sim.derivative(0.0, y2)  # a solution at y2: the BEAMs' e, De alone
    J = sim.jacobian_matrix(0.0, y2)
    # the Hessians the tangent read: the kernel's at the solution, bit for bit
    D2e = sim.data.float_array("D2e").copy()
    x = sim.data.float_array("x").copy()
    assert engine.call(sim.data, engine.OP_DEFORMATIONS, x, s=2.0) == ed.OK
    assert np.array_equal(sim.data.float_array("D2e"), D2e)
    fresh = Simulator(model).jacobian_matrix(0.0, y2)
    for block in (slice(None, n), slice(n, None)):
        close(J[n:, block], fresh[n:, block], 1e-9)
    # the plain tangent (K0 + G0 at the dynamic balance, C0) of the numpy reference
    mechanics = Mechanics(model)
    plain = plain_dynamics(model, mechanics, q2, v2, np.zeros(len(model.inputs)))
    K, C = plain_tangent(mechanics, plain, sim.derivative(0.0, y2)[n:])
    close(plain["mass"] @ J[n:, :n], -K, 1e-10)
    close(plain["mass"] @ J[n:, n:], -C, 1e-10)
    # the state counts: the Jacobian at y1 differs from it by more than the tolerances
    other = Simulator(model).jacobian_matrix(0.0, y1)
    assert np.max(np.abs(other[n:, :n] - J[n:, :n])) > 1e-3 * np.max(np.abs(J[n:, :n]))
