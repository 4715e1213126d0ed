"""Where the ESDIRK's Newton iterations go on a model with the sparse Newton matrix: a Python
replica of `esdirk_kernels.advance` on the engine's operations, and a probe of how far one
stage's Newton can converge.

- `replay`: the compiled step (order-4 "esdirk" tableau, no inputs, no history predictor:
  the spatial cantilever's case) retraced in Python with the engine's RHS, NEWTON_JACOBIAN,
  NEWTON_FACTOR and NEWTON_SOLVE, and the stages' residual in mass form as the compiled
  stage takes it on this path (STAGE_FORCE and NEWTON_FORCE_SOLVE, `engine.stage_force`),
  recording per attempt t, h, hg, the error estimate and per
  stage the Newton iterations, the contractions theta and the last |dz| (the weighted RMS
  norm of the step's error test: 1 = the error a step may make), and the hg (s) of the
  Newton matrix it used. Its counts (steps,
  rejections, evaluations, factorisations) are the compiled kernel's to the unit
  (tests/test_newton_replica.py), so its records say where that run's evaluations went.
- `newton_floor`: one stage's Newton iterated far past its tolerance, with the kinematics
  warm-started from the last iterate (as in a run) or from the step's start before every
  evaluation: the second shows the floor the rhs's dependence on the previous evaluation
  (the kinematics accept their first-order prediction within their tolerance) sets.

Run: python -m examples.benchmarks.newton_replica [BEAMS ...] (default 16 64: 96 and 384
DOFs of `spatial.spatial_cantilever`). Units: s, and the states' own (m, rad, m/s, rad/s).
"""

import sys

import numpy as np

from flexure.core import Simulator
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.operations import (
    OP_NEWTON_FACTOR,
    OP_NEWTON_FORCE_SOLVE,
    OP_NEWTON_JACOBIAN,
    OP_NEWTON_SOLVE,
    OP_STAGE_FORCE,
)
from flexure.core.simulation import esdirk_kernels as K
from flexure.core.simulation import esdirk_layout as L
from flexure.core.simulation import esdirk_newton as N


def weighted_norm(v, weight):
    """sqrt(mean((v weight)^2)), the ESDIRK's norm."""
    return float(np.sqrt(np.mean((v * weight) ** 2)))


class Replay:
    """The replica's run of a `Simulator` (method "esdirk", sparse Newton matrix) from its
    state at t = 0: `run(t_end)`; counts in rhs, jacobians, factorizations, steps, rejected;
    per attempt (t, h, hg, error, [(stage, iterations, thetas, last |dz|), ...], hg of the
    Newton matrix) in attempts (error None when a stage's Newton failed)."""

    def __init__(self, sim):
        if not sim.integrator.sparse_newton or sim.integrator.label != "ESDIRK4(3)6L[2]SA":
            raise ValueError("the replica retraces the esdirk method on the sparse Newton "
                             "matrix only")
        self.sim, self.data = sim, sim.data
        self.atol, self.rtol = sim.integrator.atol.copy(), float(sim.integrator.memory[L.M_RTOL])
        self.A, self.EW, self.P = sim.integrator.tableau.arrays()
        self.y = np.array(sim.state, dtype=float)
        self.rhs = self.jacobians = self.factorizations = self.steps = self.rejected = 0
        self.attempts = []
        self.hg_lu = 0.0

    def f(self, y, t):
        """(status, f(t, y)) by the engine's RHS, counted."""
        out = np.zeros(y.size)
        self.rhs += 1
        return engine.call(self.data, engine.OP_RHS, np.ascontiguousarray(y), out, t=t), out

    def solve(self, v):
        """v <- (I - hg J)^-1 v in place with the last factors."""
        engine.call(self.data, OP_NEWTON_SOLVE, v, s=self.hg_lu)

    def mass_form_residual(self, z, base, hg, t):
        """(status, [base_q + hg v - q; hg g]) at z = [q, v], g = M_bar (qddot(z) - a_c) for
        a_c = (v - base_v) / hg (`esdirk_newton.mass_form_residual`), counted as an rhs."""
        n = z.size // 2
        acc = (z[n:] - base[n:]) / hg
        g = np.zeros(n)
        self.rhs += 1
        status = engine.call(self.data, OP_STAGE_FORCE, np.ascontiguousarray(z), acc, g, t=t)
        return status, np.concatenate([base[:n] + hg * z[n:] - z[:n], hg * g])

    def stage(self, i, t, h, y, F, eta):
        """Stage i's simplified Newton (`esdirk_newton.solve_stage`): (converged, eta, record,
        z)."""
        A, P = self.A, self.P
        hg = h * A[1, 1]
        base = y + h * (A[i, :i] @ F[:i])
        z = base + hg * (P[i, :i] @ F[:i])
        m = z.size // 2
        z[:m] = base[:m] + hg * z[m:]  # on the linear half (`consistent_positions`)
        weight = 1.0 / (self.rtol * np.abs(y) + self.atol)
        eta = max(eta, 1e-16) ** (0.8 if i == 1 else 1.0)
        previous, thetas = 0.0, []
        for iteration in range(N.MAX_NEWTON):
            status, delta = self.mass_form_residual(z, base, hg, t + A[i, : i + 1].sum() * h)
            if status != ed.OK:
                break
            engine.call(self.data, OP_NEWTON_FORCE_SOLVE, delta, s=self.hg_lu)
            z = z + delta
            z[:m] = base[:m] + hg * z[m:]
            norm = weighted_norm(delta, weight)
            if iteration > 0:
                theta = norm / previous
                thetas.append(theta)
                if theta >= 0.99:
                    break
                eta = theta / (1.0 - theta)
            if eta * norm <= N.NEWTON_TOLERANCE or norm == 0.0:
                F[i] = (z - base) / hg
                return True, eta, (i, iteration + 1, thetas, norm), z
            previous = norm
        return False, eta, (i, iteration + 1, thetas, norm), z

    def run(self, t_end):
        """Integrate from t = 0 to t_end (s) as `esdirk_kernels.advance` does; the final
        state (the simulator's y)."""
        A, EW, n = self.A, self.EW, self.y.size
        stages, y, t, h, eta = A.shape[0], self.y.copy(), 0.0, 0.0, 1.0
        F = np.zeros((stages, n))
        F[0] = self.f(y, t)[1]
        have_jacobian = fresh = refresh = factored = False
        extra, failures, h_rejected, error_rejected = 0, 0, 0.0, 0.0
        exponent = float(self.sim.integrator.memory[L.M_EXPONENT])
        while t < t_end:
            if h <= 0.0:
                h = self.initial_step(t, y, F[0], t_end)
            step, remaining = h, t_end - t
            if step >= remaining * (1.0 - 1e-10):
                step = remaining
            elif 2.0 * step > remaining:
                step = 0.5 * remaining
            if extra >= N.jacobian_cost(n, True):
                refresh = True
            if refresh or not have_jacobian:
                engine.call(self.data, OP_NEWTON_JACOBIAN, y, np.zeros(1))
                self.jacobians += 1
                have_jacobian, fresh, refresh, factored, extra = True, True, False, False, 0
            hg = step * A[1, 1]
            if not factored or abs(hg / self.hg_lu - 1.0) > N.SPARSE_LU_SLACK:
                engine.call(self.data, OP_NEWTON_FACTOR, s=hg)
                self.factorizations, factored, self.hg_lu = self.factorizations + 1, True, hg
            record, converged = [], True
            for i in range(1, stages):  # z: the last stage's, the new state (stiffly accurate)
                converged, eta, stage_record, z = self.stage(i, t, step, y, F, eta)
                record.append(stage_record)
                extra += sum(theta >= N.THETA_STALE for theta in stage_record[2])
                if not converged:
                    break
            failures += 1
            if not converged:
                self.attempts.append((t, step, hg, None, record, self.hg_lu))
                if not fresh:
                    refresh = True
                else:
                    h, extra = 0.25 * step, 0
                eta = 1.0
                continue
            err = step * (EW @ F)
            weight = 1.0 / (self.rtol * np.maximum(np.abs(y), np.abs(z)) + self.atol)
            self.solve(err)
            error = weighted_norm(err, weight)
            self.attempts.append((t, step, hg, error, record, self.hg_lu))
            if error > 1.0:
                self.rejected += 1
                shrink = max(K.SHRINK, K.SAFETY * error ** -exponent)
                if 0.0 < h_rejected and step < h_rejected:
                    order = np.log(error_rejected / error) / np.log(h_rejected / step)
                    if order * exponent < 1.0:
                        shrink = min(shrink, max(K.SHRINK_FLOOR, K.SAFETY * error ** (
                            -1.0 / max(order, K.ORDER_FLOOR))))
                h_rejected, error_rejected, h = step, error, step * shrink
                continue
            y, F[0] = z, F[stages - 1]
            t = t_end if step == remaining else t + step
            h = step * min(K.GROW, K.SAFETY * error ** -exponent) if error > 0.0 \
                else step * K.GROW
            self.steps += 1
            fresh, failures, h_rejected = False, 0, 0.0
        self.y = y
        return y

    def initial_step(self, t, y, F1, t_stop):
        """`esdirk_kernels._initial_step` (s)."""
        weight = 1.0 / (self.rtol * np.abs(y) + self.atol)
        d0, d1 = weighted_norm(y, weight), weighted_norm(F1, weight)
        h0 = min(0.01 * d0 / d1 if d0 > 1e-5 and d1 > 1e-5 else 1e-6, t_stop - t)
        d2 = weighted_norm((self.f(y + h0 * F1, t + h0)[1] - F1) / h0, weight)
        big = max(d1, d2)
        h1 = (0.01 / big) ** 0.25 if big > 1e-15 else max(1e-6, 1e-3 * h0)
        return min(100.0 * h0, h1)


def newton_floor(replay, t, h, *, from_start, iterations=10):
    """|dz| (the step's weighted norm) of `iterations` simplified-Newton iterations of the
    second stage of a step of size h (s) from the replay's state at time t, with a Newton
    matrix from a Jacobian there; from_start: the engine evaluates the step's start y before
    every f(z) (the kinematics then warm-start from y's coordinates, not the last iterate's)."""
    y, A = replay.y, replay.A
    engine.call(replay.data, OP_NEWTON_JACOBIAN, y, np.zeros(1))
    hg = h * A[1, 1]
    replay.hg_lu = hg
    engine.call(replay.data, OP_NEWTON_FACTOR, s=hg)
    F1 = replay.f(y, t)[1]
    weight = 1.0 / (replay.rtol * np.abs(y) + replay.atol)
    base = y + h * A[1, 0] * F1
    z, sizes = base + hg * F1, []
    for _ in range(iterations):
        if from_start:
            replay.f(y, t)
        delta = base + hg * replay.f(z, t + 2.0 * A[1, 1] * h)[1] - z
        replay.solve(delta)
        z = z + delta
        sizes.append(weighted_norm(delta, weight))
    return np.array(sizes)


def main(beams=(16, 64), rtol=1e-6, t_end=5e-3):
    """Print the replica's counts, the mean Newton iterations per stage and the Newton
    floors at 2 ms for each cantilever of `beams` BEAMs."""
    from .spatial import spatial_cantilever

    for n in beams:
        replay = Replay(Simulator(spatial_cantilever(n), method="esdirk", rtol=rtol))
        replay.run(t_end)
        per_stage = {}
        for *_, record, _ in replay.attempts:
            for stage, iterations, _, _ in record:
                per_stage.setdefault(stage, []).append(iterations)
        print(f"{6 * n} DOFs: {replay.steps} steps, {replay.rejected} rejected, "
              f"{replay.rhs} rhs, {replay.jacobians} Jacobians, {replay.factorizations} "
              "factorisations; Newton iterations per stage "
              + ", ".join(f"{s + 1}: {np.mean(v):.2f}" for s, v in sorted(per_stage.items())))
        probe = Replay(Simulator(spatial_cantilever(n), method="esdirk", rtol=rtol))
        probe.run(2e-3)
        for h in (1e-6, 1e-4):
            for from_start in (False, True):
                sizes = newton_floor(probe, 2e-3, h, from_start=from_start)
                print(f"  h {h:.0e} s, kinematics from {'y' if from_start else 'the last iterate'}"
                      f": |dz| " + " ".join(f"{s:.1e}" for s in sizes))


if __name__ == "__main__":
    main(tuple(int(a) for a in sys.argv[1:]) or (16, 64))
