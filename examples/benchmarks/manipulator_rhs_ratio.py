"""Issue 35's rhs target in one process: one right-hand side of manipulator_control per DOF
against the refined planar stage's (`refined_stage(16)`, 93 DOFs), as `refined.rhs_cost`
measures each (the engine's OP_RHS at one state, in-process medians, the cost of the call
from Python subtracted), the two models alternating `ROUNDS` times; and, with `--loop`, the
6 mm xy move on manipulator_control as the manipulator row runs it (`run_loop` on the
nonlinear move path, plant "inprocess"): the loop's CPU (user + system, s) and its tracking
error of the stroke.

Run it in each of two clones, the processes alternating, and compare the printed figures
side by side: only ratios measured that way carry over on a shared machine.

python -m examples.benchmarks.manipulator_rhs_ratio [--loop]
"""

import statistics
import sys

ROUNDS = 3  # each model's rhs_cost this many times, alternating


def rhs_ratio(rounds=ROUNDS):
    """(manipulator us an rhs, stage us an rhs, per-DOF ratio): medians over `rounds`."""
    from flexure.core import load_scene

    from .refined import rhs_cost
    from .stage_models import refined_stage

    manipulator, stage = load_scene("manipulator_control"), refined_stage(16)
    costs = {"manipulator": [], "stage": []}
    for _ in range(rounds):
        costs["manipulator"].append(rhs_cost(manipulator)[0])
        costs["stage"].append(rhs_cost(stage)[0])
    m, s = statistics.median(costs["manipulator"]), statistics.median(costs["stage"])
    ratio = (m / manipulator.declared_dof_count) / (s / stage.declared_dof_count)
    return 1e6 * m, 1e6 * s, ratio


def loop():
    """(loop CPU s, tracking error of the stroke) of the 6 mm xy move on manipulator_control."""
    from flexure.controllers.move_path import move_path
    from flexure.controllers.runner import run_loop
    from flexure.core import load_scene

    from ..manipulator_loop import MOVES, targets

    model = load_scene("manipulator_control")
    path = move_path(model, targets(*MOVES["6 mm xy"]), kind="nonlinear")
    result = run_loop(model, path=path, plant="inprocess")
    return result.cpu_time_s, result.summary()["error_ratio"]


def main(argv):
    if "--loop" in argv:
        cpu, error = loop()
        print(f"loop CPU {cpu:.3f} s; tracking error {error:.13e} of the stroke")
        return
    m, s, ratio = rhs_ratio()
    print(f"manipulator_control {m:.1f} us; refined_stage(16) {s:.1f} us; "
          f"per DOF ratio {ratio:.3f}")


if __name__ == "__main__":
    main(sys.argv[1:])
