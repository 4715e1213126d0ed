"""manipulator_reduced's nonlinear loop at equal position accuracy: the ESDIRK methods and rtols
on the loop's held forces replayed open loop, and the closed loop itself.

The run: `run_loop` on the nonlinear 6 mm xy path (esdirk2 at rtol 1e-5, 4 kHz; the move in
(move, settle) s, default the benchmark row's `REDUCED_MOVE`) gives the held forces and the
loop's CPU; each choice (method, rtol) replays them in a new `Simulator` (`set_inputs` and
`advance_to` per sample, as the compiled loop restarts at each input change), and so does the
reference, esdirk at `REFERENCE_RTOL`. The errors at every sample's end: max |q - q_ref| over
the reference's largest motion max |q_ref - q_0|, max |v - v_ref| over max |v_ref|. The
loop's x real time is estimated as the loop's, scaled by the replay's CPU over the base
replay's (medians of `REPEATS` alternating replays). A position-equivalent (modal) velocity
error measure was measured beside these with a patch of the error test that is not kept (no
gain at equal position error: docs/benchmarks.md, session 39).

    python -m examples.benchmarks.reduced_methods [--loops] [MOVE SETTLE]

With --loops: the closed loop itself with `LOOP_CHOICES`, against the reference loop.
"""

import statistics
import sys
import time

import numpy as np

from .manipulator import REDUCED_MOVE

REFERENCE_RTOL = 1e-9
REPEATS = 3
CHOICES = (  # (label, method, rtol)
    ("base", "esdirk2", 1e-5),
    ("looser", "esdirk2", 3e-5),
    ("looser", "esdirk2", 1e-4),
    ("order 4", "esdirk", 1e-4),
    ("order 4", "esdirk", 1e-3),
    ("order 3", "esdirk3", 1e-4),
    ("order 4", "esdirk", 1e-5),
    ("order 4", "esdirk", 3e-4),
    ("sdirk2", "sdirk2", 1e-5),
    ("sdirk2", "sdirk2", 1e-4),
    # the fewest stage forces a sample this family reaches: about one step a sample and two
    # Newton iterations a stage, at 100 times the base's q error (the method's ceiling)
    ("ceiling", "sdirk2", 1e-2),
    ("ceiling", "esdirk2", 1e-2),
)
LOOP_CHOICES = (("esdirk2", 1e-5), ("esdirk", 1e-4), ("esdirk3", 1e-4))


def errors(states, reference, n):
    """(q error, v error) of states against reference (samples, 2 n): max |q - q_ref| over
    max |q_ref| (the integrator's q is the deviation from the start) and max |v - v_ref|
    over max |v_ref|."""
    q, v = states[:, :n], states[:, n:2 * n]
    q_ref, v_ref = reference[:, :n], reference[:, n:2 * n]
    return (float(np.max(np.abs(q - q_ref)) / np.max(np.abs(q_ref))),
            float(np.max(np.abs(v - v_ref)) / np.max(np.abs(v_ref))))


def replay(model, t, force, method, rtol):
    """(states at every sample's end (N, 2 n), counts, CPU s) of the held forces replayed."""
    from flexure.core import Simulator

    sim = Simulator(model, method=method, rtol=rtol)
    states = np.zeros((len(t) - 1, sim.nstate))
    start = time.process_time()
    for k in range(len(t) - 1):
        sim.set_inputs(force[k])
        sim.advance_to(t[k + 1])
        states[k] = sim.state
    cpu = time.process_time() - start
    s = sim.integrator.statistics()
    counts = {"steps": s["steps"], "rejected": s["rejected_steps"],
              "rhs": s["solver_rhs_evaluations"], "LUs": s["factorizations"]}
    return states, counts, cpu


def loop_run(model, move, settle):
    """(the loop's CPU s, t (N+1,) s, force (N, inputs) N) of `run_loop` on the 6 mm xy
    move's nonlinear path."""
    from flexure.controllers.move_path import move_path
    from flexure.controllers.runner import run_loop

    from ..manipulator_loop import MOVES, targets

    path = move_path(model, targets(*MOVES["6 mm xy"]), kind="nonlinear")
    result = run_loop(model, path=path, plant="inprocess", duration=move, settle=settle)
    return result.cpu_time_s, result.t, result.force


def rhs_cost(model, reps=500):
    """CPU (s) of one engine rhs evaluation from Python (a ctypes call, about 1 us more) at
    a small made-up state about the start."""
    from flexure.core import Simulator
    from flexure.core.engine import engine

    sim = Simulator(model, method="esdirk2", rtol=1e-5)
    y = 1e-6 * np.random.default_rng(0).standard_normal(sim.nstate)
    out = np.zeros(sim.nstate)
    engine.call(sim.data, engine.OP_RHS, y, out)
    start = time.process_time()
    for _ in range(reps):
        engine.call(sim.data, engine.OP_RHS, y, out)
    return (time.process_time() - start) / reps


def closed_loops(model, move, settle):
    """Print the closed loop (`run_loop`, compiled, in process) with each of `LOOP_CHOICES`:
    its CPU (median of `REPEATS`, alternating), x real time, the loop's positions' largest
    difference from the reference loop's (esdirk at `REFERENCE_RTOL`) over the stroke, and
    the tracking error over the stroke."""
    from flexure.controllers.move_path import move_path
    from flexure.controllers.runner import run_loop

    from ..manipulator_loop import MOVES, targets

    path = move_path(model, targets(*MOVES["6 mm xy"]), kind="nonlinear")

    def run(method, rtol):
        return run_loop(model, path=path, plant="inprocess", duration=move, settle=settle,
                        method=method, rtol=rtol)
    ref = run("esdirk", REFERENCE_RTOL)
    stroke = np.max(np.abs(ref.reference - ref.reference[0]))
    print(f"reference loop: tracking error / stroke {ref.summary()['error_ratio']:.6e}")
    cpu, last = {choice: [] for choice in LOOP_CHOICES}, {}
    for _ in range(REPEATS):
        for choice in LOOP_CHOICES:
            last[choice] = run(*choice)
            cpu[choice].append(last[choice].cpu_time_s)
    print("| method | rtol | loop CPU (s) | x real time | positions' error / stroke | "
          "tracking error / stroke |")
    print("|---|---|---|---|---|---|")
    duration = move + settle
    for choice in LOOP_CHOICES:
        error = np.max(np.abs(last[choice].position - ref.position)) / stroke
        median = statistics.median(cpu[choice])
        print(f"| {choice[0]} | {choice[1]:g} | {median:.2f} | {duration / median:.4f} | "
              f"{error:.3e} | {last[choice].summary()['error_ratio']:.6e} |")


def arguments(argv=None):
    """(loops, move s, settle s) of the command line `[--loops] [MOVE SETTLE]`; the move
    default `REDUCED_MOVE`."""
    args = list(argv if argv is not None else sys.argv[1:])
    loops = "--loops" in args
    args = [a for a in args if a != "--loops"]
    move, settle = (float(args[0]), float(args[1])) if args else REDUCED_MOVE
    return loops, move, settle


def main(argv=None):
    """Run the loop, the reference and the choices; print the table."""
    from flexure.core import load_scene

    loops, move, settle = arguments(argv)
    model = load_scene("manipulator_reduced")
    if loops:
        closed_loops(model, move, settle)
        return
    n = model.declared_dof_count
    loop_cpu = [loop_run(model, move, settle) for _ in range(2)]
    t, force = loop_cpu[-1][1:]
    loop_cpu = [run[0] for run in loop_cpu]
    duration = t[-1] - t[0]
    print(f"move {move:g} + {settle:g} s, {len(t) - 1} samples; the loop (run_loop, in "
          f"process) {loop_cpu} s CPU: {duration / min(loop_cpu):.4f} x real time", flush=True)
    reference, ref_counts, ref_cpu = replay(model, t, force, "esdirk", REFERENCE_RTOL)
    print(f"reference esdirk {REFERENCE_RTOL:g}: {ref_counts}, {ref_cpu:.1f} s", flush=True)
    print(f"one rhs {1e6 * rhs_cost(model):.1f} us", flush=True)
    results = {}
    for rep in range(REPEATS):
        for choice in CHOICES:
            label, method, rtol = choice
            states, counts, cpu = replay(model, t, force, method, rtol)
            entry = results.setdefault(choice, {"cpu": []})
            entry["cpu"].append(cpu)
            entry.update(counts, errors=errors(states, reference, n))
            print(f"rep {rep} {label} {method} {rtol:g}: {counts} "
                  f"{entry['errors']} {cpu:.2f} s", flush=True)
    base_cpu = statistics.median(results[CHOICES[0]]["cpu"])
    samples = len(t) - 1
    print("| choice | method | rtol | steps | steps a sample | rejected | stage "
          "forces | LUs | q error | v error | replay CPU (s) | loop x real time |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for choice in CHOICES:
        label, method, rtol = choice
        r = results[choice]
        cpu = statistics.median(r["cpu"])
        speed = duration / (min(loop_cpu) * cpu / base_cpu)
        print(f"| {label} | {method} | {rtol:g} | {r['steps']} | "
              f"{r['steps'] / samples:.2f} | {r['rejected']} | {r['rhs']} | {r['LUs']} | "
              f"{r['errors'][0]:.3e} | {r['errors'][1]:.3e} | {cpu:.2f} | {speed:.4f} |")


if __name__ == "__main__":
    main()
