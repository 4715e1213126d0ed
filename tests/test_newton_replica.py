"""The Python replica of the ESDIRK's step on the sparse Newton matrix
(`examples.benchmarks.newton_replica`) against the compiled kernel, and what it shows.

- The replica's run of the 96-DOF spatial cantilever (esdirk, rtol 1e-6, 2 ms from the
  1 N tip load) counts the compiled run's steps, rejections, evaluations, Jacobians and
  factorisations to the unit (a factorisation at every attempt with a new step size) and
  ends at its state within 1e-7 of the largest state, a tenth of the integrator's rtol
  (measured: about 1e-9; the two differ in round-off only,
  numpy's sums against the kernel's loops, which Newton's corrections, stopped at a
  tolerance, and the rhs's dependence on the previous evaluation (below) carry on): its
  per-stage records are then those of the compiled run.
- The rhs depends on the engine's previous evaluation (the kinematics accept their
  first-order prediction within their tolerance), so a stage's Newton, whose kinematics
  warm-start from the last iterate in a run, stalls when they start from the step's state
  instead: at a floor (measured 3.4e-5 at 96 DOFs, 1.4e-5 at 384, in the step's weighted
  norm where 1 is the error a step may make) at most 1e-2 of the Newton tolerance (0.05),
  so it costs no iterations; from the last iterate the iterates converge below 1e-6
  (measured 7e-9).
"""

import numpy as np
import pytest

from examples.benchmarks.newton_replica import Replay, newton_floor
from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import Simulator
from flexure.core.simulation import esdirk_layout, esdirk_newton

# The slow tier: the replica is a benchmark's tool (5.6 s of CPU); the compiled step it
# replays is checked in the default tier by tests/test_sparse_newton.py.
pytestmark = pytest.mark.slow

END = 2e-3  # s after the load


@pytest.fixture(scope="module")
def runs():
    """(the replica after END, the compiled simulator after END) on 16 BEAMs (96 DOFs). The
    compiled run grows the contraction estimate at every step, the replica's rule: on the
    sparse path it holds it for ETA_HOLD steps by default (`esdirk_kernels`), which the
    replica does not model."""
    replay = Replay(Simulator(spatial_cantilever(16), method="esdirk", rtol=1e-6))
    replay.run(END)
    compiled = Simulator(spatial_cantilever(16), method="esdirk", rtol=1e-6)
    compiled.integrator.flags[esdirk_layout.I_ETA_HOLD] = 0
    compiled.advance_to(END)
    return replay, compiled


def test_the_replica_counts_what_the_compiled_step_counts(runs):
    replay, compiled = runs
    counts = compiled.integrator.statistics()
    assert counts["steps"] == replay.steps > 20
    assert counts["rejected_steps"] == replay.rejected
    assert counts["solver_rhs_evaluations"] == replay.rhs
    assert counts["solver_jacobian_evaluations"] == replay.jacobians
    assert counts["factorizations"] == replay.factorizations
    state = np.asarray(compiled.state)
    assert np.max(np.abs(replay.y - state)) <= 1e-7 * np.max(np.abs(state))
    # the records add up to the count: the first stage's F_1, the initial step's probe and
    # one evaluation per Newton iteration
    iterations = sum(record[1] for *_, stages, _ in replay.attempts for record in stages)
    assert iterations + 2 == replay.rhs
    # on the sparse Newton matrix every attempt's factors are at its own hg
    # (esdirk_newton.SPARSE_LU_SLACK), so the factorisations are the attempts at a new hg
    slack = esdirk_newton.SPARSE_LU_SLACK
    assert all(abs(hg_lu / hg - 1.0) <= slack for _, _, hg, *_, hg_lu in replay.attempts)
    pairs = zip(replay.attempts[:-1], replay.attempts[1:], strict=True)
    new_hg = sum(abs(b[2] / a[2] - 1.0) > slack for a, b in pairs)
    assert replay.factorizations == 1 + new_hg


def test_the_rhs_history_floor_is_far_below_newtons_tolerance(runs):
    replay, _ = runs
    warm = newton_floor(replay, END, 1e-4, from_start=False)
    from_start = newton_floor(replay, END, 1e-4, from_start=True)
    assert warm[0] > 1.0  # the stage's first correction: far from converged
    assert warm[-1] <= 1e-6
    floor = np.median(from_start[-5:])
    assert 1e-7 <= floor <= 1e-2 * esdirk_newton.NEWTON_TOLERANCE
    assert np.min(from_start[-5:]) >= 10.0 * warm[-1]  # a floor, not convergence
