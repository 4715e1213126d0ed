"""What bounds the step of manipulator_reduced's nonlinear loop: the loop's held forces
replayed open loop, one accepted step at a time, with the integrator's own error vector,
counters and step sizes after each step.

The run: `run_loop` on the nonlinear move path as the benchmark's row runs it (esdirk2 at
rtol 1e-5, 4 kHz), the 6 mm xy move in (move, settle) s (default the row's `REDUCED_MOVE`);
then a new `Simulator` (the loop's method and rtol) given force[k] over [t_k, t_k+1) for
every sample k (`set_inputs`, `advance_to` with a record after each accepted step), as the
compiled loop restarts at each input change. Printed:

- per step index within a sample (samples from `SKIP` on): the median step (us), the median
  weighted RMS error (1 = the tolerance), its positions' and velocities' RMS, the stage
  forces (rhs), H's LUs and the rejections before it;
- which half (positions or velocities) holds the largest weighted error component, and the
  DOFs that hold it most often;
- the error constant C = error / h^3 (esdirk2's error estimate is O(h^3)) of a sample's
  first step against that of the previous sample's last step: the jump an input change
  makes in it (why the step-size history cannot carry over a sample boundary);
- the controller's slack: the steps a sample would take if every step had the error the
  controller aims at (SAFETY^3 = 0.73) with each sample's own measured C, taken piecewise
  constant over each measured step and its largest over a candidate step;
- the Newton matrix: how much the step changes from one step to the next, and the LUs a
  ladder of step sizes (h rounded down to r^k) with one kept LU per rung and Jacobian would
  need, against the loop's one per new h;
- the velocity error's modal content in the samples `MODAL_SAMPLES`: the mass-weighted
  shares of the modes in frequency bands (the eigenvectors of K0, M0 at the static
  equilibrium, `linearize`), and the weighted RMS the error would have with only the
  modes below each band's top.

    python -m examples.benchmarks.reduced_step_bounds [MOVE SETTLE]
"""

import statistics
import sys

import numpy as np

from .manipulator import REDUCED_MOVE

SKIP = 5                      # samples left out of the per-index table (the move's start)
MODAL_SAMPLES = (100, 101)     # samples whose error vectors are split into modes
BANDS = (0.0, 100.0, 1e3, 3e3, 1e4, 3e4, np.inf)  # Hz
TARGET = 0.9 ** 3             # the elementary controller's aim: SAFETY^3 (`esdirk_kernels`)
LADDERS = (2 ** 0.25, 2 ** 0.5, 2.0)


def loop_forces(model, move, settle):
    """(t (N+1,) s, force (N, inputs) N, tracking error over the stroke) of the loop."""
    from flexure.controllers.move_path import move_path
    from flexure.controllers.runner import run_loop

    from ..manipulator_loop import MOVES, targets

    path = move_path(model, targets(*MOVES["6 mm xy"]), kind="nonlinear")
    result = run_loop(model, path=path, plant="inprocess", duration=move, settle=settle)
    return result.t, result.force, result.summary()["error_ratio"]


def replay(model, t, force, keep=MODAL_SAMPLES):
    """Per accepted step: (sample, t_end s, weighted RMS, its positions' and velocities' RMS,
    index of the largest weighted component, cumulative rejections, LUs, rhs, Jacobians);
    the error vectors (unweighted, with their weights) of the steps of the samples in
    `keep`; the replay's CPU (s)."""
    import time

    from flexure.core import Simulator
    from flexure.core.simulation.esdirk_layout import V_ERR, V_WEIGHT
    from flexure.core.simulation.methods import LOOP_METHOD, LOOP_RTOL

    sim = Simulator(model, method=LOOP_METHOD, rtol=LOOP_RTOL)
    integrator, n = sim.integrator, model.ndof
    rows, vectors, current = [], [], [0]

    def record(time_s, _y):
        v = integrator.vectors
        e = v[V_ERR] * v[V_WEIGHT]
        s = integrator.statistics()
        rows.append((current[0], time_s, np.sqrt(np.mean(e ** 2)),
                     np.sqrt(np.mean(e[:n] ** 2)), np.sqrt(np.mean(e[n:] ** 2)),
                     int(np.argmax(np.abs(e))), s["rejected_steps"], s["factorizations"],
                     s["solver_rhs_evaluations"], s["solver_jacobian_evaluations"]))
        if current[0] in keep:
            vectors.append((current[0], time_s, v[V_ERR].copy(), v[V_WEIGHT].copy()))

    start = time.process_time()
    for k in range(len(t) - 1):
        current[0] = k
        sim.set_inputs(force[k])
        sim.advance_to(t[k + 1], _record=record)
    return np.array(rows), vectors, time.process_time() - start


def per_index(rows, period):
    """Print the per-step-index table; returns each step's index within its sample."""
    sample, t_end = rows[:, 0].astype(int), rows[:, 1]
    h = np.diff(np.concatenate([[0.0], t_end]))
    counts = {name: np.diff(np.concatenate([[0], rows[:, col]]))
              for name, col in (("rejected", 6), ("LUs", 7), ("rhs", 8))}
    index = np.zeros(len(rows), int)
    for i in range(1, len(rows)):
        index[i] = index[i - 1] + 1 if sample[i] == sample[i - 1] else 0
    late = sample >= SKIP
    print(f"per step of a sample (samples {SKIP} on; {period * 1e6:.0f} us each):")
    print("| step | count | h (us, median) | error | positions | velocities | rhs | LUs "
          "| rejections before |")
    print("|---|---|---|---|---|---|---|---|---|")
    for i in range(index.max() + 1):
        m = late & (index == i)
        if m.sum() < 5:
            continue
        print(f"| {i} | {m.sum()} | {1e6 * np.median(h[m]):.2f} | {np.median(rows[m, 2]):.2f} "
              f"| {np.median(rows[m, 3]):.4f} | {np.median(rows[m, 4]):.2f} "
              f"| {counts['rhs'][m].mean():.2f} | {counts['LUs'][m].mean():.2f} "
              f"| {int(counts['rejected'][m].sum())} |")
    samples = len(np.unique(sample[late]))
    print(f"steps a sample {late.sum() / samples:.2f}, rhs a step {counts['rhs'][late].mean():.2f}"
          f", LUs a step {counts['LUs'][late].mean():.3f}, rejections "
          f"{int(counts['rejected'].sum())}, Jacobians {int(rows[-1, 9])}")
    return index, h


def largest(rows, n):
    """Print where the largest weighted component lies."""
    which = rows[:, 5].astype(int)
    print(f"largest component a velocity at {np.mean(which >= n):.3f} of the steps; the DOFs "
          "holding it most often (DOF: steps):",
          ", ".join(f"{d}: {c}" for d, c in sorted(
              zip(*np.unique(which % n, return_counts=True), strict=True),
              key=lambda p: -p[1])[:8]))


def jumps(rows, index, h):
    """Print C = error / h^3 of each sample's first step over its predecessor's last."""
    first = np.flatnonzero((index == 0) & (rows[:, 0] >= SKIP))
    ratios = [(rows[i, 2] / h[i] ** 3) / (rows[i - 1, 2] / h[i - 1] ** 3) for i in first]
    print(f"error constant of a sample's first step / the last step's before it: median "
          f"{statistics.median(ratios):.3g} (quartiles {np.percentile(ratios, 25):.3g}, "
          f"{np.percentile(ratios, 75):.3g})")


def ideal_count(rows, h, period):
    """(steps taken, steps at the controller's aim) over the samples from `SKIP` on: each
    sample's C = error / h^3 piecewise constant over its measured steps, a candidate step
    (s) taking the largest C it overlaps, shortened by 2 % until C h^3 <= TARGET."""
    sample = rows[:, 0].astype(int)
    actual = ideal = 0
    for k in np.unique(sample[sample >= SKIP]):
        m = sample == k
        hs, c = h[m], rows[m, 2] / h[m] ** 3
        start = np.concatenate([[0.0], np.cumsum(hs)[:-1]])
        tau, steps = 0.0, 0
        while tau < period * (1.0 - 1e-9):
            step = period - tau
            while True:
                over = (start < tau + step) & (start + hs > tau)
                if c[over].max() * step ** 3 <= TARGET:
                    break
                step *= 0.98
            tau, steps = tau + step, steps + 1
        actual, ideal = actual + int(m.sum()), ideal + steps
    return actual, ideal


def ladder_count(rows, h, r):
    """(LUs, rungs, mean shortening) of steps h (s) rounded down to r^k, one LU kept per rung
    and Jacobian (rows' column 9 counts the Jacobians)."""
    rung = np.floor(np.log(h) / np.log(r))
    lus = len(set(zip(rows[:, 9].astype(int), rung, strict=True)))
    return lus, len(np.unique(rung)), float(1.0 - np.mean(r ** rung / h))


def ideal_steps(rows, h, period):
    """Print the steps at the controller's aim with each sample's measured C."""
    actual, ideal = ideal_count(rows, h, period)
    print(f"steps taken {actual}; at the controller's aim ({TARGET:.2f}) with the measured "
          f"error constants {ideal} ({ideal / actual:.3f} of them)")


def ladders(rows, h):
    """Print the step-to-step change and the LUs a ladder of kept LUs would need."""
    change = np.abs(h[1:] / h[:-1] - 1.0)
    print("|h_n / h_n-1 - 1| within 1e-9, 5 %, 20 %: "
          + ", ".join(f"{np.mean(change <= x):.3f}" for x in (1e-9, 0.05, 0.2)))
    for r in LADDERS:
        lus, rungs, shorter = ladder_count(rows, h, r)
        print(f"ladder r = {r:.3f}: {lus} LUs ({lus / len(h):.3f} a step, the loop "
              f"{rows[-1, 7] / len(h):.3f}), {rungs} rungs, the steps {shorter:.3f} shorter "
              "on average")


def modal(model, vectors):
    """Print each kept step's velocity error by modal band."""
    import scipy.linalg

    from flexure.core.analysis.linearization import linearize

    linear = linearize(model)
    M, K = np.asarray(linear.M0), np.asarray(linear.K0)
    w2, phi = scipy.linalg.eigh(K, M)
    f = np.sqrt(np.abs(w2)) / (2.0 * np.pi)
    n = model.ndof
    print(f"modes: {f.min():.1f} Hz to {f.max():.0f} Hz, median {np.median(f):.0f} Hz")
    names = [f"{a:g}-{b:g}" for a, b in zip(BANDS[:-1], BANDS[1:], strict=True)]
    print("| sample | t in sample (us) | velocities' RMS | " + " | ".join(names)
          + " | RMS below 1k, 3k, 10k, 30k Hz |")
    print("|---|---|---|" + "---|" * len(names) + "---|")
    for k, t_end, err, weight in vectors:
        ev, wv = err[n:], weight[n:]
        c = phi.T @ (M @ ev)  # mass-normalised modes: ev = phi c
        share = [np.sum(c[(f >= a) & (f < b)] ** 2)
                 for a, b in zip(BANDS[:-1], BANDS[1:], strict=True)]
        below = [np.sqrt(np.mean((phi[:, f < top] @ c[f < top] * wv) ** 2))
                 for top in (1e3, 3e3, 1e4, 3e4)]
        tau = 1e6 * (t_end - k / 4000.0)
        print(f"| {k} | {tau:.1f} | {np.sqrt(np.mean((ev * wv) ** 2)):.3f} | "
              + " | ".join(f"{s / sum(share):.2f}" for s in share) + " | "
              + ", ".join(f"{b:.3f}" for b in below) + " |")


def main(argv=None):
    """Run the loop, replay it and print the tables."""
    from flexure.core import load_scene

    args = argv if argv is not None else sys.argv[1:]
    move, settle = (float(args[0]), float(args[1])) if args else REDUCED_MOVE
    model = load_scene("manipulator_reduced")
    t, force, tracking = loop_forces(model, move, settle)
    rows, vectors, cpu = replay(model, t, force)
    period = t[1] - t[0]
    print(f"move {move:g} + {settle:g} s: {len(t) - 1} samples, tracking error {tracking:.4e} "
          f"of the stroke; replay {len(rows)} steps in {cpu:.2f} s of CPU")
    index, h = per_index(rows, period)
    largest(rows, model.ndof)
    jumps(rows, index, h)
    ideal_steps(rows, h, period)
    ladders(rows, h)
    modal(model, vectors)


if __name__ == "__main__":
    main()
