"""manipulator_reduced's replay with J's factors kept from an earlier kinematic solution
(`core.engine.kept_factors`): CPU, errors and counts against J factored at every solution.

The loop's held forces (`reduced_methods.loop_run`: esdirk2 at 1e-5, the 6 mm xy move) are
replayed (`reduced_methods.replay`'s way) with each (method, rtol, settings[J_KEPT_MOVE],
settings[J_REFINEMENTS]) of `CHOICES`, the choices alternating `REPEATS` times in one process;
errors against esdirk at `reduced_methods.REFERENCE_RTOL` (q and v as `reduced_methods.errors`).
Printed: per choice its CPU's median and range, the errors, the steps and stage forces, and
the kinematic solutions that factored J or kept factors (counters SOLUTION_FACTORS,
SOLUTION_KEPT), with the 1-minute load before and after. With --loop: the closed loop itself
(`run_loop`, its default esdirk2 at 1e-5) with each of `LOOP_CHOICES` (every packed model of
the process given those settings), alternating `REPEATS` times: its CPU and tracking error.

    python -m examples.benchmarks.kept_factors [--loop] [MOVE SETTLE]
"""

import os
import statistics
import sys
import time

import numpy as np

from .manipulator import REDUCED_MOVE
from .reduced_methods import REFERENCE_RTOL, errors, loop_run

REPEATS = 4
CHOICES = (  # (method, rtol, the move kept in step tolerances (0: factored at every
    # solution), refinements of each solve)
    ("esdirk", 1e-4, 0.0, 0), ("esdirk", 1e-4, 1e9, 0), ("esdirk", 1e-4, 3e9, 0),
    ("esdirk", 1e-4, 1e9, 1), ("esdirk", 1e-4, 3e9, 1), ("esdirk", 1e-4, 1e11, 1),
    ("esdirk2", 1e-5, 0.0, 0), ("esdirk2", 1e-5, 1e9, 0), ("esdirk2", 1e-5, 3e9, 0),
    ("esdirk2", 1e-5, 3e9, 1), ("esdirk2", 1e-5, 1e11, 1),
)
LOOP_CHOICES = ((0.0, 0), (1e9, 0), (3e9, 1))  # (move kept, refinements)


def packed_with(move, refinements):
    """Every model packed from here on with the kept-factor settings (move in step
    tolerances, refinements): the packing's settings record patched."""
    from flexure.core.engine import data as ed
    from flexure.core.engine import packing

    # the packing's own function, under the patch an earlier call left
    original = getattr(packing.PACKERS["dimensions"], "original", packing.PACKERS["dimensions"])

    def dimensions(c):
        packed = original(c)
        packed["settings"][ed.J_KEPT_MOVE] = move
        packed["settings"][ed.J_REFINEMENTS] = refinements
        return packed
    dimensions.original = original
    packing.PACKERS["dimensions"] = dimensions


def closed_loops(model, move, settle):
    """Print the closed loop's CPU (median, range) and tracking error per `LOOP_CHOICES`."""
    from flexure.controllers.move_path import move_path
    from flexure.controllers.runner import run_loop

    from ..manipulator_loop import MOVES, targets

    path = move_path(model, targets(*MOVES["6 mm xy"]), kind="nonlinear")
    cpu, error = {c: [] for c in LOOP_CHOICES}, {}
    print(f"load before {os.getloadavg()[0]:.2f}", flush=True)
    for _ in range(REPEATS):
        for choice in LOOP_CHOICES:
            packed_with(*choice)
            result = run_loop(model, path=path, plant="inprocess", duration=move,
                              settle=settle)
            cpu[choice].append(result.cpu_time_s)
            error[choice] = result.summary()["error_ratio"]
    print(f"load after {os.getloadavg()[0]:.2f}")
    print("| move kept | refinements | loop CPU (s) | range | tracking error / stroke |")
    print("|---|---|---|---|---|")
    for choice in LOOP_CHOICES:
        print(f"| {choice[0]:g} | {choice[1]} | {statistics.median(cpu[choice]):.3f} | "
              f"{min(cpu[choice]):.3f} to {max(cpu[choice]):.3f} | {error[choice]:.10e} |")


def replay(model, t, force, method, rtol, move=0.0, refinements=0):
    """(states at every sample's end (N, 2 n), CPU s, counts) of the held forces replayed
    with the kept-factor settings (move in step tolerances, refinements)."""
    from flexure.core import Simulator
    from flexure.core.engine import data as ed

    sim = Simulator(model, method=method, rtol=rtol)
    settings = sim.data.float_array("settings")
    settings[ed.J_KEPT_MOVE], settings[ed.J_REFINEMENTS] = move, refinements
    states = np.zeros((len(t) - 1, sim.nstate))
    start = time.process_time()
    for k in range(len(t) - 1):
        sim.set_inputs(force[k])
        sim.advance_to(t[k + 1])
        states[k] = sim.state
    cpu = time.process_time() - start
    s, counters = sim.integrator.statistics(), sim.data.int_array("counters")
    counts = {"steps": s["steps"], "stage forces": s["solver_rhs_evaluations"],
              "factored": int(counters[ed.SOLUTION_FACTORS]),
              "kept": int(counters[ed.SOLUTION_KEPT])}
    return states, cpu, counts


def main(argv=None):
    """Run the loop, the reference and the choices; print the table."""
    from flexure.core import load_scene

    args = list(argv if argv is not None else sys.argv[1:])
    loop = "--loop" in args
    args = [a for a in args if a != "--loop"]
    move, settle = (float(args[0]), float(args[1])) if args else REDUCED_MOVE
    model = load_scene("manipulator_reduced")
    if loop:
        closed_loops(model, move, settle)
        return
    n = model.declared_dof_count
    _, t, force = loop_run(model, move, settle)
    reference = replay(model, t, force, "esdirk", REFERENCE_RTOL)[0]
    print(f"load before {os.getloadavg()[0]:.2f}", flush=True)
    cpu, last = {c: [] for c in CHOICES}, {}
    for _ in range(REPEATS):
        for choice in CHOICES:
            states, seconds, counts = replay(model, t, force, *choice)
            cpu[choice].append(seconds)
            last[choice] = errors(states, reference, n), counts
    print(f"load after {os.getloadavg()[0]:.2f}")
    print("| method | rtol | move kept | refinements | CPU (s) | range | q error | v error | "
          "steps | stage forces | factored | kept |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for choice in CHOICES:
        (q_error, v_error), counts = last[choice]
        print(f"| {choice[0]} | {choice[1]:g} | {choice[2]:g} | {choice[3]} | "
              f"{statistics.median(cpu[choice]):.3f} | {min(cpu[choice]):.3f} to "
              f"{max(cpu[choice]):.3f} | {q_error:.4e} | {v_error:.4e} | {counts['steps']} | "
              f"{counts['stage forces']} | {counts['factored']} | {counts['kept']} |")


if __name__ == "__main__":
    main()
