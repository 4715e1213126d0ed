"""manipulator_reduced's loop replayed with the order-4 esdirk and a new Jacobian forced every k
samples: what the Newton matrix's age costs in Newton iterations and CPU, at what position
error (`evaluation_trace` counts the iterations a stage by that age).

The held forces of `reduced_methods.loop_run` (esdirk2 at 1e-5, the 6 mm xy move in
`manipulator.REDUCED_MOVE`) are replayed in a new Simulator per choice (every, rtol); before
every `every`-th sample the integrator's refresh flag is set from Python (the library's own
rule when every = 0), so that its next step makes a new Jacobian and factors the Newton matrix
again. CPU: medians of `REPEATS` replays, the choices alternating; errors at every sample's end
against esdirk at `REFERENCE_RTOL` (`reduced_methods.errors`); counts from the integrator.

    python -m examples.benchmarks.jacobian_refresh [SCENE]
"""

import statistics
import sys
import time

import numpy as np

# (a Jacobian every so many samples (0: the integrator's rule), rtol)
CHOICES = ((0, 1e-4), (2, 1e-4), (3, 1e-4), (4, 1e-4), (3, 5e-5), (4, 5e-5), (6, 5e-5),
           (4, 3e-5))
REFERENCE_RTOL = 1e-7
REPEATS = 3


def refreshed_replays(model, t, force, choices=CHOICES, repeats=REPEATS):
    """{(every, rtol): (CPU s (median of `repeats`, alternating), counts, (q error, v error))}
    of the order-4 esdirk's replay with a new Jacobian forced at every `every`-th sample
    (the integrator's refresh flag set from Python; 0: its own rule), errors against esdirk at
    `REFERENCE_RTOL` (`reduced_methods.errors`)."""
    from flexure.core import Simulator
    from flexure.core.simulation.esdirk_layout import I_REFRESH

    from .reduced_methods import errors, replay

    reference = replay(model, t, force, "esdirk", REFERENCE_RTOL)[0]

    def run(every, rtol):
        sim = Simulator(model, method="esdirk", rtol=rtol)
        states = np.zeros((len(t) - 1, sim.nstate))
        start = time.process_time()
        for k in range(len(t) - 1):
            sim.set_inputs(force[k])
            if every and k and k % every == 0:
                sim.integrator.flags[I_REFRESH] = 1
            sim.advance_to(t[k + 1])
            states[k] = sim.state
        cpu = time.process_time() - start
        s = sim.integrator.statistics()
        counts = (s["solver_rhs_evaluations"], s["solver_jacobian_evaluations"],
                  s["factorizations"], s["steps"])
        return cpu, counts, errors(states, reference, model.declared_dof_count)
    found = {c: [] for c in choices}
    for _ in range(repeats):
        for choice in choices:
            found[choice].append(run(*choice))
    return {c: (statistics.median(r[0] for r in v), v[0][1], v[0][2]) for c, v in found.items()}


def main(argv=None):
    """Replay with each choice; print the table."""
    from flexure.core import load_scene

    from .manipulator import REDUCED_MOVE
    from .reduced_methods import loop_run

    args = list(argv if argv is not None else sys.argv[1:])
    model = load_scene(args[0] if args else "manipulator_reduced")
    _, t, force = loop_run(model, *REDUCED_MOVE)
    print("| J every (samples) | rtol | stage forces | Js | LUs | steps | q error | v error | "
          "replay CPU (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for (every, rtol), (cpu, counts, (eq, ev)) in refreshed_replays(model, t, force).items():
        print(f"| {every or 'rule'} | {rtol:g} | " + " | ".join(map(str, counts))
              + f" | {eq:.3e} | {ev:.3e} | {cpu:.3f} |", flush=True)


if __name__ == "__main__":
    main()
