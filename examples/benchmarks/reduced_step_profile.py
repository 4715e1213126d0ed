"""Where a step of manipulator_reduced's nonlinear loop goes: the loop's counts a step (the
ESDIRK's statistics and the engine's counters over a closed-loop run) times each operation's
cost a call (us, medians of batches, at the run's last state, through `engine.call`), beside
the loop's CPU a step.

The run: `run_loop` on the nonlinear move path as the benchmark's row runs it (esdirk2 at
rtol 1e-5, 4 kHz), the 6 mm xy move in the row's `REDUCED_MOVE` (move, settle; s). The
operations:

    stage force      OP_STAGE_FORCE (FORCE): g = M_bar (qddot - a_c), a stage iteration's
                     evaluation (`esdirk_newton.mass_form_residual`)
    Newton J         OP_NEWTON_JACOBIAN: M, C_x, K_x and J's LU at the state
    H's LU           OP_NEWTON_FACTOR: the sparse saddle-point matrix at hg, factored
    Newton solve     OP_NEWTON_FORCE_SOLVE: a stage iteration's correction
    FACTOR_A         OP_STAGE_FORCE (FACTOR_A): the augmented system assembled and factored
                     at the state, for the input response once a sample where no kept
                     factors refine it

python -m examples.benchmarks.reduced_step_profile [BATCH]
"""

import statistics
import sys
import time

import numpy as np

from .manipulator import REDUCED_MOVE as MOVE  # s: the benchmark row's move and settling

STEP = 2e-5  # s: the states' distance, about the median step of the loop's samples


def loop_counts(model):
    """(the loop's CPU s, {count: per step}, the plant's Simulator at the end)."""
    from flexure.controllers import runner
    from flexure.controllers.move_path import move_path
    from flexure.core.engine import data as ed

    from ..manipulator_loop import MOVES, targets

    path = move_path(model, targets(*MOVES["6 mm xy"]), kind="nonlinear")
    made = []
    compiled = runner.compiled_loop

    def recording(*args, ended, **kwargs):  # the plant's Simulator at the end
        return compiled(*args, ended=lambda sim: (made.append(sim), ended(sim)), **kwargs)
    runner.compiled_loop = recording
    try:
        result = runner.run_loop(model, path=path, plant="inprocess", duration=MOVE[0],
                                 settle=MOVE[1])
    finally:
        runner.compiled_loop = compiled
    sim = made[-1]
    solver = sim.integrator.statistics()
    counters = sim.data.int_array("counters")
    steps = solver["steps"]
    counts = {"samples": (len(result.t) - 1) / steps,
              "rejected steps": solver["rejected_steps"] / steps,
              "stage forces (rhs)": int(counters[ed.RHS_COUNT]) / steps,
              "Newton Jacobians": int(counters[ed.JACOBIAN_COUNT]) / steps,
              "H's LUs": solver["factorizations"] / steps,
              "refined responses": int(counters[ed.REFINED_RESPONSES]) / steps,
              "refinement products": int(counters[ed.REFINEMENT_PRODUCTS]) / steps,
              "responses by FACTOR_A": int(counters[ed.RESPONSE_FACTORS]) / steps}
    return result.cpu_time_s / steps, counts, steps, sim


def costs(sim, batch):
    """{operation: us a call} at the Simulator's state and one `STEP` on (medians of 5
    batches)."""
    from flexure.core.engine import engine
    from flexure.core.engine.engine import OP_RHS
    from flexure.core.engine.operations import (
        FACTOR_A,
        FORCE,
        OP_NEWTON_FACTOR,
        OP_NEWTON_FORCE_SOLVE,
        OP_NEWTON_JACOBIAN,
        OP_STAGE_FORCE,
    )

    data = sim.data
    y = np.ascontiguousarray(sim.state, dtype=float)
    n = y.size // 2
    ydot = np.zeros(y.size)
    engine.call(data, OP_RHS, y, ydot)
    # two states a step apart (STEP along the state's derivative), alternated: each stage
    # force's kinematics start from the other state's solution, as a stage's first iteration
    # does in the loop
    states = (y, y + STEP * ydot)
    calls = [0]
    acc = np.zeros(n)
    out = np.zeros(y.size)
    v = np.zeros(y.size)
    hg = 0.29 * STEP  # s: esdirk2's diagonal coefficient (2 - sqrt 2) / 2 times the step

    def stage():
        calls[0] += 1
        acc[:] = 0.0
        engine.call(data, OP_STAGE_FORCE, states[calls[0] % 2], acc, acc, s=FORCE)

    def solve():
        v[:] = 1e-6
        engine.call(data, OP_NEWTON_FORCE_SOLVE, v, s=hg)

    def factor_a():
        calls[0] += 1
        engine.call(data, OP_STAGE_FORCE, states[calls[0] % 2], s=FACTOR_A)

    operations = {"stage force": stage,
                  "Newton J": lambda: engine.call(data, OP_NEWTON_JACOBIAN, y, out),
                  "H's LU": lambda: engine.call(data, OP_NEWTON_FACTOR, s=hg),
                  "Newton solve": solve,
                  "FACTOR_A": factor_a}
    operations["Newton J"]()
    result = {}
    for name, operation in operations.items():
        operation()
        times = []
        for _ in range(5):
            start = time.process_time()
            for _ in range(batch):
                operation()
            times.append((time.process_time() - start) / batch)
        result[name] = 1e6 * statistics.median(times)
    return result


def main(argv=None):
    """Print the counts a step, the costs a call and what they account for of a step."""
    from flexure.core import load_scene

    batch = int((argv or sys.argv[1:] or ["50"])[0])
    model = load_scene("manipulator_reduced")
    cpu_step, counts, steps, sim = loop_counts(model)
    print(f"loop: {steps} steps, {1e6 * cpu_step:.0f} us of the loop's CPU a step")
    for name, count in counts.items():
        print(f"  {name} a step: {count:.3f}")
    per_call = costs(sim, batch)
    for name, us in per_call.items():
        print(f"  {name}: {us:.1f} us a call")
    accounted = {"stage forces": counts["stage forces (rhs)"] * per_call["stage force"],
                 "Newton solves (one a stage force, one for the error estimate)":
                     (counts["stage forces (rhs)"] + 1) * per_call["Newton solve"],
                 "H's LUs": counts["H's LUs"] * per_call["H's LU"],
                 "Newton Jacobians": counts["Newton Jacobians"] * per_call["Newton J"],
                 "FACTOR_A": counts["responses by FACTOR_A"] * per_call["FACTOR_A"]}
    for name, us in accounted.items():
        print(f"  {name}: {us:.0f} us a step ({us / (1e6 * cpu_step):.0%})")
    rest = 1e6 * cpu_step - sum(accounted.values())
    print(f"  the rest (predictors, norms, refinement products, the controller): {rest:.0f} "
          "us a step")
    return cpu_step, counts, per_call


if __name__ == "__main__":
    main()
