"""The ESDIRK's stage positions kept on the stage equation's linear half (mass form).

On the sparse Newton path a stage's iterates z = [q, v] keep q = base_q + hg v
(`esdirk_newton.consistent_positions`), so the residual's position half r1 is zero to the
bit and the Newton solve skips J's solve and K_x's product of it (`engine.newton.solve`).
Checked here on the 16-BEAM spatial cantilever (96 DOFs):

- the residual in mass form (`_mass_form_residual`) of such a z has r1 exactly 0 (the
  property the skip relies on: bit identity is the point), its velocity half hg g;
- NEWTON_FORCE_SOLVE of [0; M_bar r2] (the skip) against NEWTON_SOLVE of [0; r2] (J's solve
  of the zero vector taken) and against NEWTON_FORCE_SOLVE of [d; M_bar r2] with a position
  half d of 1e-290 (no skip), at the Newton matrix's state.
The run's answers: tests/test_stage_force.py (mass form against accelerations' form, within
the Newton tolerance's bound).
"""

import numpy as np

from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import Simulator
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.operations import (
    OP_MASS,
    OP_NEWTON_FACTOR,
    OP_NEWTON_FORCE_SOLVE,
    OP_NEWTON_JACOBIAN,
    OP_NEWTON_SOLVE,
    OP_STAGE_FORCE,
)
from flexure.core.simulation.esdirk_newton import consistent_positions, mass_form_residual
from tests.test_engine import close


def cantilever_at(t=1e-3):
    """A simulator of the 16-BEAM cantilever run to t (s) after its tip load, its state y."""
    sim = Simulator(spatial_cantilever(16), method="esdirk", rtol=1e-6)
    sim.advance_to(t)
    assert sim.data.int_array("dims")[ed.NEWTON_SPARSE] == 1
    return sim, np.array(sim.state, dtype=float)


def test_consistent_stage_positions_have_no_position_residual():
    """For z = [base_q + hg v, v] about the run's state the mass-form residual's position half
    is exactly 0.0 at hg 1e-6, 3e-5, 1e-3 s, and its velocity half is hg g, g the stage force
    (OP_STAGE_FORCE) at z for a_c = (v - base_v) / hg, to 1e-14 of its size."""
    sim, y = cantilever_at()
    data, n = sim.data, y.size // 2
    engine.connect(data, OP_STAGE_FORCE)
    rng = np.random.default_rng(41)
    flags = np.zeros(32, dtype=np.int64)
    for hg in (1e-6, 3e-5, 1e-3):
        base = y + 1e-4 * np.abs(y).max() * rng.standard_normal(y.size)
        z = y + 1e-4 * np.abs(y).max() * rng.standard_normal(y.size)
        consistent_positions(z, base, hg)
        delta = np.full(y.size, np.nan)
        assert mass_form_residual(data.address, z, base, hg, delta, flags, 0.0) == ed.OK
        assert np.all(delta[:n] == 0.0)
        g = (z[n:] - base[n:]) / hg
        assert engine.call(data, OP_STAGE_FORCE, z, g.copy(), g) == ed.OK
        close(delta[n:], hg * g, 1e-14)


def test_the_force_solve_of_no_position_residual_is_the_full_solve():
    """At the Newton matrix's state (M_bar there lifts r2) and hg 2e-8, 1e-5, 1e-3 s:
    NEWTON_FORCE_SOLVE of [0; M_bar r2] equals NEWTON_SOLVE of [0; r2] to 1e-9 of the
    solution's size (the solves' round-off, tests/test_stage_force.py's bound) and the
    force solve of [1e-290 d; M_bar r2] (its position half not zero: J's solve and K_x's
    product taken) to 1e-13."""
    sim, y = cantilever_at()
    data, n = sim.data, y.size // 2
    assert engine.call(data, OP_NEWTON_JACOBIAN, y, np.zeros(1)) == ed.OK
    assert engine.call(data, OP_MASS) == ed.OK
    mass = data.float_array("mass")[: n * n].reshape(n, n).copy()
    rng = np.random.default_rng(42)
    for hg in (2e-8, 1e-5, 1e-3):
        assert engine.call(data, OP_NEWTON_FACTOR, s=hg) == ed.OK
        r2 = rng.standard_normal(n)
        expected = np.concatenate([np.zeros(n), r2])
        assert engine.call(data, OP_NEWTON_SOLVE, expected, s=hg) == ed.OK
        skipped = np.concatenate([np.zeros(n), mass @ r2])
        assert engine.call(data, OP_NEWTON_FORCE_SOLVE, skipped, s=hg) == ed.OK
        full = np.concatenate([1e-290 * rng.standard_normal(n), mass @ r2])
        assert engine.call(data, OP_NEWTON_FORCE_SOLVE, full, s=hg) == ed.OK
        assert np.max(np.abs(skipped)) > 0.0
        close(skipped, expected, 1e-9)
        close(skipped, full, 1e-13)
