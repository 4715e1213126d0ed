"""What the input response costs a sample on manipulator_reduced's loop, and in which parts.

The response (OP_INPUT_RESPONSE, `core/engine/input_response.py`) runs once a sample, at the
first stage after the held force's change: A d = T^T B du at the last stage force's state,
refined with A's kept factors (`refinement.refined_solve_within`: d_1 = A_kept^-1 b, then
per product the residual b - A d by an element pass and the rigid rows, and a solve with the
kept factors), until the ESDIRK's weighted bound (`esdirk_kernels.response_weights`) or the
fixed 1e-12 accepts, or the refinement gives up and A is assembled and factored at the
state (STAGE_FORCE (FACTOR_A)), whose factors the next responses refine with.

The run: the loop's held forces (`reduced_methods.loop_run`, esdirk2 at 1e-5, or a file
saved by an earlier run: --forces FILE, written when missing) replayed in a new Simulator
(esdirk at 1e-4 unless asked otherwise), traced whole (`evaluation_trace.replay_traced`);
printed: the response's calls a sample and their time (inclusive us a sample, the trace's
cycles), its products and factorisations (the engine's counters) and how the samples split
by (products, refined, factored); then the parts, timed from Python at the state after
`PARTS_SAMPLE` samples (the kernels a product is made of, a kept solve, FACTOR_A).

    python -m examples.benchmarks.response_cost [METHOD RTOL] [--forces FILE]

Imports are absolute (examples.benchmarks....) so that the file also runs from another
clone's root, that clone's code measured (the base's, which has no such file):

    python -c "import runpy, sys; sys.path.insert(0, '.'); sys.argv[1:] = ['--forces', 'F'];
               runpy.run_path('/path/to/response_cost.py', run_name='__main__')"
"""

import collections
import os
import sys
import time

import numpy as np

PARTS_SAMPLE = 100  # the fastest motion is about the middle of the 250 samples
RESPONSE = "INPUT_RESPONSE"


def held_forces(model, path):
    """(t (N+1,) s, force (N, inputs) N): the loop's, from `path` when it exists, else run
    and saved there (None: not saved)."""
    if path and os.path.exists(path):
        saved = np.load(path)
        return saved["t"], saved["force"]
    from examples.benchmarks.manipulator import REDUCED_MOVE
    from examples.benchmarks.reduced_methods import loop_run

    _, t, force = loop_run(model, *REDUCED_MOVE)
    if path:
        np.savez(path, t=t, force=force)
    return t, force


def split_by_sample(model, t, force, method, rtol):
    """{(products, refined, factored): samples}, and the totals, of one untraced replay."""
    from flexure.core import Simulator
    from flexure.core.engine import data as ed

    sim = Simulator(model, method=method, rtol=rtol)
    counters = sim.data.int_array("counters")
    fields = (ed.REFINEMENT_PRODUCTS, ed.REFINED_RESPONSES, ed.RESPONSE_FACTORS)
    split = collections.Counter()
    for k in range(len(t) - 1):
        before = [int(counters[f]) for f in fields]
        sim.set_inputs(force[k])
        sim.advance_to(t[k + 1])
        split[tuple(int(counters[f]) - b for f, b in zip(fields, before, strict=True))] += 1
    return split, [int(counters[f]) for f in fields]


def response_rows(model, t, force, method, rtol):
    """[(call, calls a sample, inclusive us a sample, median us a call)] under the
    response, traced over the whole replay but its first sample; CPU us a sample."""
    from examples.benchmarks.evaluation_trace import replay_traced, summary

    samples = range(1, len(t) - 1)
    rows, rate, cpu, _, _, _, _ = replay_traced(model, t, force, method, rtol, samples)
    table = summary(rows, rate, len(samples))
    out = [(call, v[0], 1e6 * v[1], 1e6 * v[3]) for (top, call), v in table.items()
           if top == RESPONSE]
    return sorted(out, key=lambda r: -r[2]), 1e6 * cpu


def parts(model, t, force, method, rtol, reps=200):
    """{part: median us a call} at the state after PARTS_SAMPLE samples, from Python (each
    call's dispatch, about 1 us, included)."""
    from flexure.core import Simulator
    from flexure.core.engine import data as ed
    from flexure.core.engine import engine
    from flexure.core.engine.factors import kept_resolve
    from flexure.core.engine.inertia_product import minus_mass_product
    from flexure.core.engine.operations import FACTOR_A, OP_STAGE_FORCE
    from flexure.core.engine.refinement import constraint_products, weighted_size

    sim = Simulator(model, method=method, rtol=rtol)
    for k in range(PARTS_SAMPLE):
        sim.set_inputs(force[k])
        sim.advance_to(t[k + 1])
    data = sim.data
    dims = data.int_array("dims")
    nf, nx, n = int(dims[ed.NFREE]), int(dims[ed.NX]), int(dims[ed.NDOF])
    na = nf + int(dims[ed.NRIGID])
    d = np.random.default_rng(0).standard_normal(na)
    c, a, total = np.zeros(na), np.zeros(nx), np.zeros(nx)
    w, qddot = np.ones(n), np.zeros(n)

    def solve():
        c[:] = d
        kept_resolve(data.address, True, na, c)

    calls = {"kept solve (A_kept^-1 v)": solve,
             "-M_ff d (inertia_product.minus_mass_product)":
                 lambda: minus_mass_product(data.address, d[:nf], a, total, c[:nf]),
             "the rigid rows (constraint_products)":
                 lambda: constraint_products(data.address, d, c),
             "weighted_size": lambda: weighted_size(data.address, d, w, a, qddot),
             "FACTOR_A (assemble and factor A)":
                 lambda: engine.call(data, OP_STAGE_FORCE, s=FACTOR_A)}
    out = {}
    for name, call in calls.items():
        call()
        times = []
        for _ in range(5):
            start = time.process_time()
            for _ in range(reps if "FACTOR_A" not in name else reps // 10):
                call()
            times.append((time.process_time() - start)
                         / (reps if "FACTOR_A" not in name else reps // 10))
        out[name] = 1e6 * sorted(times)[2]
    return out


def arguments(argv):
    """(method, rtol, forces file or None) of the command line."""
    args = list(argv)
    path = None
    if "--forces" in args:
        k = args.index("--forces")
        path = args[k + 1]
        del args[k: k + 2]
    method, rtol = (args[0], float(args[1])) if args else ("esdirk", 1e-4)
    return method, rtol, path


def main(argv=None):
    """Print the response's trace, its split by sample and its parts."""
    from flexure.core import load_scene

    method, rtol, path = arguments(sys.argv[1:] if argv is None else argv)
    model = load_scene("manipulator_reduced")
    t, force = held_forces(model, path)
    samples = len(t) - 1
    split, (products, refined, factored) = split_by_sample(model, t, force, method, rtol)
    print(f"{method} {rtol:g}, {samples} samples: {products} products, {refined} responses "
          f"refined, {factored} with A factored ({products / samples:.2f} and "
          f"{factored / samples:.3f} a sample)")
    print("| products | refined | A factored | samples |")
    print("|---|---|---|---|")
    for key in sorted(split):
        print(f"| {key[0]} | {key[1]} | {key[2]} | {split[key]} |")
    rows, cpu = response_rows(model, t, force, method, rtol)
    print(f"\nunder {RESPONSE} (traced; the replay's CPU {cpu:.0f} us a sample)")
    print("| call | calls a sample | us a sample | median us a call |")
    print("|---|---|---|---|")
    for call, calls, inclusive, median in rows:
        print(f"| {call} | {calls:.2f} | {inclusive:.1f} | {median:.1f} |")
    print(f"\nthe parts at sample {PARTS_SAMPLE} (Python calls, median of 5)")
    for name, us in parts(model, t, force, method, rtol).items():
        print(f"| {name} | {us:.1f} us |")


if __name__ == "__main__":
    main()
