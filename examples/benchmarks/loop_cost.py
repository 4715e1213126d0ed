"""Where the compiled sampled loop's CPU goes beyond a replay of its held forces from Python.

The loop (`run_loop` in process, the compiled loop of `sampled_loop`, on a manipulator's 6 mm
xy nonlinear move; esdirk at rtol 1e-4 on manipulator_reduced, run_loop's default method
elsewhere, unless asked otherwise) against the replay of its held
forces through `Simulator.set_inputs` / `advance_to` (`reduced_methods.replay`: the same
steps, stage forces and LUs). Three views:

- the loop's `cpu_time_s` in parts: the Simulator's construction (its packed models and its
  default atol), `run_sampled_loop`, the rest; against the replay's CPU (which builds its
  Simulator before its clock starts);
- both runs traced whole (`evaluation_trace.Tracer` on the plant's table of operations, the
  loop's addresses[ENGINE] pointed at it, so that the measurement's OP_POSITIONS is traced
  too): every top-level engine call per sample, the loop's and the replay's side by side;
- what is left of the CPU per sample outside the traced calls (the integrator's own work,
  the controller, Python).

    python -m examples.benchmarks.loop_cost [SCENE [METHOD RTOL]] [--repeat N]

SCENE: manipulator_reduced (the 6 mm move in 0.05 + 0.0125 s, `manipulator.REDUCED_MOVE`) or
manipulator_control (`run_loop`'s defaults: the move in 1 + 0.25 s, esdirk2 at 1e-5, as
`manipulator_rhs_ratio --loop`).
"""

import statistics
import sys
import time

from .evaluation_trace import Tracer, cycle_rate, print_summary, summary


def _move(name):
    """run_loop's duration and settle for the scene (s)."""
    from .manipulator import REDUCED_MOVE

    return REDUCED_MOVE if name == "manipulator_reduced" else (1.0, 0.25)


def _method(name):
    """The scene's loop method and rtol: the order-4 esdirk at 1e-4 on manipulator_reduced
    (issue 35's fastest at its error), run_loop's defaults elsewhere."""
    from flexure.core.simulation.methods import LOOP_METHOD, LOOP_RTOL

    return ("esdirk", 1e-4) if name == "manipulator_reduced" else (LOOP_METHOD, LOOP_RTOL)


def loop_parts(model, path, method, rtol, move, trace=False):
    """(LoopResult, {part: CPU s}, tracer or None) of one `run_loop`: the Simulator's
    construction and `run_sampled_loop` timed inside it (wrapped where `compiled_loop` finds
    them); with `trace` the whole run traced."""
    import flexure.core as fc
    from flexure.controllers.runner import run_loop
    from flexure.core.simulation import sampled_loop as sl
    from flexure.core.simulation.sampled_measure import ENGINE

    parts, held = {}, {}
    real_simulator, real_run, real_driver = fc.Simulator, fc.run_sampled_loop, \
        sl.DRIVERS["esdirk"]

    def simulator(*args, **kwargs):
        start = time.process_time()
        sim = real_simulator(*args, **kwargs)
        parts["Simulator"] = time.process_time() - start
        held["sim"] = sim
        return sim

    def run(sim, **kwargs):
        if trace:  # the tracers made (numba compiles them) before the clock starts
            from flexure.core.engine import engine

            engine.connect(sim._output_data, engine.OP_POSITIONS)
            held["tracer"], held["outputs"] = Tracer(sim.data), Tracer(sim._output_data)
        start = time.process_time()
        out = real_run(sim, **kwargs)
        parts["run_sampled_loop"] = time.process_time() - start
        return out

    def driver(sim, solver, addresses, *rest):
        if "tracer" in held:  # the plant's calls and the measurement's through the tracers
            held["tracer"].install()
            held["outputs"].install()
            addresses[ENGINE] = held["tracer"].table.ctypes.data
        return real_driver(sim, solver, addresses, *rest)

    fc.Simulator, fc.run_sampled_loop, sl.DRIVERS["esdirk"] = simulator, run, driver
    try:
        result = run_loop(model, path=path, plant="inprocess", duration=move[0],
                          settle=move[1], method=method, rtol=rtol)
    finally:
        fc.Simulator, fc.run_sampled_loop, sl.DRIVERS["esdirk"] = real_simulator, real_run, \
            real_driver
    parts["rest"] = result.cpu_time_s - parts["Simulator"] - parts["run_sampled_loop"]
    return result, parts, (held.get("tracer"), held.get("outputs"))


def replay(model, t, force, method, rtol, trace=False):
    """(CPU s, tracer or None) of the held forces replayed from Python (as
    `reduced_methods.replay`), traced whole with `trace`."""
    from flexure.core import Simulator
    from flexure.core.engine import engine as e

    sim = Simulator(model, method=method, rtol=rtol)
    tracer = None
    if trace:
        e.connect(sim.data, e.OP_RHS)
        tracer = Tracer(sim.data)
        tracer.install()
    start = time.process_time()
    for k in range(len(t) - 1):
        sim.set_inputs(force[k])
        sim.advance_to(t[k + 1])
    return time.process_time() - start, tracer


def compare_traces(loop_rows, replay_rows, rate, samples):
    """Print the top-level calls a sample (calls, inclusive us), loop against replay."""
    a, b = summary(loop_rows, rate, samples), summary(replay_rows, rate, samples)
    tops = sorted({k[0] for k in a} | {k[0] for k in b},
                  key=lambda k: -a.get((k, "(itself)"), b.get((k, "(itself)"), (0, 0)))[1])
    print("| top-level call | loop calls | loop us | replay calls | replay us | loop - replay us |")
    print("|---|---|---|---|---|---|")
    totals = [0.0, 0.0]
    for top in tops:
        la = a.get((top, "(itself)"), (0, 0.0))
        lb = b.get((top, "(itself)"), (0, 0.0))
        totals[0] += la[1]
        totals[1] += lb[1]
        print(f"| {top} | {la[0]:.2f} | {1e6 * la[1]:.1f} | {lb[0]:.2f} | {1e6 * lb[1]:.1f} | "
              f"{1e6 * (la[1] - lb[1]):+.1f} |")
    print(f"| all traced | | {1e6 * totals[0]:.1f} | | {1e6 * totals[1]:.1f} | "
          f"{1e6 * (totals[0] - totals[1]):+.1f} |")
    return totals


def main(argv=None):
    """The parts of the loop's CPU (`--repeat` runs, loop and replay alternating), then one
    traced pair."""
    from flexure.controllers.move_path import move_path
    from flexure.core import load_scene

    from ..manipulator_loop import MOVES, targets

    args = list(argv if argv is not None else sys.argv[1:])
    repeat = 3
    if "--repeat" in args:
        i = args.index("--repeat")
        repeat = int(args[i + 1])
        del args[i: i + 2]
    name = args[0] if args else "manipulator_reduced"
    method, rtol = (args[1], float(args[2])) if len(args) > 2 else _method(name)
    model = load_scene(name)
    move = _move(name)
    path = move_path(model, targets(*MOVES["6 mm xy"]), kind="nonlinear")
    rows = []
    for _ in range(repeat):
        result, parts, _ = loop_parts(model, path, method, rtol, move)
        cpu, _ = replay(model, result.t, result.force, method, rtol)
        rows.append((result.cpu_time_s, parts, cpu))
        samples = len(result.t) - 1
        print(f"loop CPU {result.cpu_time_s:.3f} s (Simulator {parts['Simulator']:.3f}, "
              f"run_sampled_loop {parts['run_sampled_loop']:.3f}, rest {parts['rest']:.3f}); "
              f"replay {cpu:.3f} s; run_sampled_loop - replay "
              f"{1e3 * (parts['run_sampled_loop'] - cpu) / samples:+.3f} ms a sample; "
              f"tracking error {result.summary()['error_ratio']:.13e} of the stroke",
              flush=True)
    print(f"medians: loop {statistics.median(r[0] for r in rows):.3f} s, Simulator "
          f"{statistics.median(r[1]['Simulator'] for r in rows):.3f}, run_sampled_loop "
          f"{statistics.median(r[1]['run_sampled_loop'] for r in rows):.3f}, replay "
          f"{statistics.median(r[2] for r in rows):.3f}; x real time by the loop's CPU "
          f"{(samples / 4000.0) / statistics.median(r[0] for r in rows):.4f}")
    result, parts, (loop_tracer, output_tracer) = loop_parts(model, path, method, rtol, move,
                                                             trace=True)
    loop_rows = loop_tracer.rows()
    replay_cpu, replay_tracer = replay(model, result.t, result.force, method, rtol, trace=True)
    replay_rows = replay_tracer.rows()
    rate = cycle_rate()
    samples = len(result.t) - 1
    print(f"\n{name}, {method} at rtol {rtol:g}, {samples} samples traced whole (us a sample; "
          f"cycle rate {rate / 1e9:.3f} GHz):")
    traced = compare_traces(loop_rows, replay_rows, rate, samples)
    print(f"| CPU (process time) a sample | | {1e6 * parts['run_sampled_loop'] / samples:.1f} "
          f"| | {1e6 * replay_cpu / samples:.1f} | "
          f"{1e6 * (parts['run_sampled_loop'] - replay_cpu) / samples:+.1f} |")
    print(f"| untraced: CPU a sample - traced | | "
          f"{1e6 * parts['run_sampled_loop'] / samples - 1e6 * traced[0]:.1f} | | "
          f"{1e6 * replay_cpu / samples - 1e6 * traced[1]:.1f} | |")
    print("\nthe measurement's own calls (on the outputs' packed model; us a sample):")
    print_summary("", summary(output_tracer.rows(), rate, samples))



if __name__ == "__main__":
    main()
