"""The spatial cantilever at equal error: flexure's implicit integrators against Exudyn's.

Why: one step of each code buys a different accuracy (flexure's ESDIRK at rtol 1e-6 is
within about 5e-7 of the largest deflection, Exudyn's generalized-alpha at h = 1e-4 s about
2e-2), so the cost of a step alone does not compare the work a user pays for an answer.

The error of a run: the tip's z (m) at the sample times 0.5, 1.0, ... 5 ms after the 1 N tip
load, the largest deviation from the same code's converged run, over the largest |z| of that
run (a relative error, 1). Each code against its own converged answer, because the two are
different problems: flexure's strip is damped (beta = 5e-5 s) and its BEAM has no shear,
Exudyn's geometrically exact beam is shear-deformable and its strip undamped (the element
leaves the section's damping out: `exudyn_cantilever`). How far apart the two converged
answers are is reported beside (`converged_gap`). The references: flexure's esdirk at rtol
1e-10 (within 5e-9 (16 BEAMs) and 8e-8 (64) of its rtol 1e-9 run), Exudyn at h = 1e-6 s
(within 1.3e-4 and 2.0e-4 of its h = 2e-6 run: with its observed first order, about its own
error; so Exudyn's errors below about 3e-4 are not resolved here). The converged answers are
9.7e-2 (16) and 9.6e-2 (64) of the deflection apart, far beyond the errors compared.

The cost of a run: the CPU time (user + system) of advancing over the 5 ms with the samples'
stops (flexure: `Simulator.advance_to` at each sample time, Jacobians and factorisations
included; Exudyn: `SolveDynamic` with a sensor stored at each sample), per simulated ms.
`precision_rows` interpolates, in log-log, each code's CPU at a common error and reports
flexure's over Exudyn's; `plot` draws error against CPU per simulated ms for both.
"""

import math
import time

import numpy as np

from .measure import log
from .spatial import CANTILEVER_END, spatial_cantilever

SAMPLES = np.linspace(0.5e-3, CANTILEVER_END, 10)  # s: where the tip's z is compared
REFERENCE_RTOL = 1e-10  # flexure's converged run
REFERENCE_STEP = 1e-6  # s: Exudyn's converged run
FLEXURE_RTOLS = (3e-2, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7)
FLEXURE_METHODS = ("esdirk", "esdirk3", "esdirk2")
EXUDYN_STEPS = (2.5e-4, 1e-4, 5e-5, 2.5e-5, 1e-5, 5e-6)  # s
COMMON_ERROR = 1e-3  # relative: the error at which the codes' CPU is compared
# --quick: the points around COMMON_ERROR only, and no check of the references
QUICK = {"methods": ("esdirk",), "rtols": (1e-2, 1e-3, 1e-4), "steps": (1e-5, 5e-6)}


def flexure_run(model, *, rtol, method="esdirk"):
    """(CPU s, steps, the tip's z (m) at SAMPLES) of one run of the cantilever `model` (with
    its output "tip", the tip's z: `tip_model`)."""
    from flexure.core import Simulator

    sim = Simulator(model, method=method, rtol=rtol)
    cpu, tip = 0.0, []
    for t in SAMPLES:
        start = time.process_time()
        sim.advance_to(float(t))
        cpu += time.process_time() - start
        tip.append(float(sim.outputs()[0]))  # outside the timing: the user's choice of output
    return cpu, int(sim.statistics["steps"]), np.array(tip)


def tip_model(n):
    """The benchmark's cantilever of n BEAMs with an output: the tip's z (m)."""
    return spatial_cantilever(n, output=True)


def relative_error(tip, reference):
    """max |tip - reference| over max |reference| (1) at the samples."""
    return float(np.max(np.abs(tip - reference)) / np.max(np.abs(reference)))


def measure(n, *, methods=FLEXURE_METHODS, rtols=FLEXURE_RTOLS, steps=EXUDYN_STEPS,
            repeat=1, check=True):
    """The work-precision points of the cantilever of n BEAMs: {"flexure <method>": [(rtol,
    error, CPU s per simulated ms, CPU s per step, steps)], "Exudyn": [(h, ...)]} and the
    converged answers' relative gap (None without exudyn). The CPU is the median of
    `repeat` runs; a first run of each flexure method is not timed (it loads the engine).
    With `check`, each reference is compared with its code's run at 10 x rtol or 2 x h."""
    from flexure.core.errors import SimulationError

    model = tip_model(n)
    ms = 1e3 * CANTILEVER_END
    flexure_run(model, rtol=1e-3)
    _, _, reference = flexure_run(model, rtol=REFERENCE_RTOL)
    if check:
        looser = flexure_run(model, rtol=10 * REFERENCE_RTOL)[2]
        log(f"cantilever {n}: flexure's reference within "
            f"{relative_error(looser, reference):.1e} of its rtol {10 * REFERENCE_RTOL:g} run")
    points = {}
    for method in methods:
        rows = points.setdefault(f"flexure {method}", [])
        for rtol in rtols:
            try:
                runs = [flexure_run(model, rtol=rtol, method=method) for _ in range(repeat)]
            except SimulationError as error:  # a point the integrator cannot make: left out
                log(f"cantilever {n}: {method} at rtol {rtol:g} failed: {error}")
                continue
            cpu = float(np.median([r[0] for r in runs]))
            count, tip = runs[0][1], runs[0][2]
            rows.append((rtol, relative_error(tip, reference), cpu / ms, cpu / count, count))
    gap = None
    try:
        from . import exudyn_cantilever
    except ImportError as error:
        log(f"exudyn not available ({error}): flexure's side only")
        return points, gap
    peer = exudyn_cantilever.tip_history(n, h=REFERENCE_STEP, samples=SAMPLES)[1]
    gap = relative_error(peer, reference)
    if check:
        coarser = exudyn_cantilever.tip_history(n, h=2 * REFERENCE_STEP, samples=SAMPLES)[1]
        log(f"cantilever {n}: Exudyn's reference within {relative_error(coarser, peer):.1e} "
            f"of its h = {2 * REFERENCE_STEP:g} run")
    log(f"cantilever {n}: the converged answers {gap:.1e} apart")
    rows = points.setdefault("Exudyn", [])
    for h in steps:
        runs = [exudyn_cantilever.tip_history(n, h=h, samples=SAMPLES) for _ in range(repeat)]
        cpu = float(np.median([r[0] for r in runs]))
        count = int(round(CANTILEVER_END / h))
        rows.append((h, relative_error(runs[0][1], peer), cpu / ms, cpu / count, count))
    return points, gap


def cpu_at(rows, error):
    """The CPU per simulated ms (s) at relative `error`, interpolated log-log between the
    two points around it (None where the points do not bracket it)."""
    pts = sorted((r[1], r[2]) for r in rows if r[1] > 0.0)
    for (e1, c1), (e2, c2) in zip(pts, pts[1:], strict=False):
        if e1 <= error <= e2:
            if e1 == e2:
                return c1
            w = math.log(error / e1) / math.log(e2 / e1)
            return math.exp(math.log(c1) + w * (math.log(c2) - math.log(c1)))
    return None


def plot(results, path):
    """Error against CPU per simulated ms, log-log, both codes, one panel per size;
    `results` {n: points of `measure`}."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(5.5 * len(results), 4.2), squeeze=False)
    for ax, (n, points) in zip(axes[0], results.items(), strict=True):
        for label, rows in points.items():
            cpu = [1e3 * r[2] for r in rows]
            err = [max(r[1], 1e-12) for r in rows]
            ax.loglog(cpu, err, "o-" if label.startswith("flexure") else "s--", label=label)
            for r, c, e in zip(rows, cpu, err, strict=True):
                ax.annotate(f"{r[0]:g}", (c, e), fontsize=6, xytext=(3, 3),
                            textcoords="offset points")
        ax.set_xlabel("CPU per simulated ms (ms)")
        ax.set_ylabel("tip error / largest deflection")
        ax.set_title(f"spatial cantilever, {n} BEAMs ({6 * n} DOFs), 5 ms")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def precision_rows(repeat, *, sizes=(16, 64), plot_path=None, quick=False):
    """(The rows "CPU at equal error, flexure/Exudyn" (one per size, `measure` with `repeat`
    timed runs a point; with `quick` the points of QUICK), {n: points}) and, with
    plot_path, the plot (`plot`)."""
    from .table import Row

    results, rows = {}, []
    for n in sizes:
        log(f"spatial cantilever {n}: work-precision")
        points, gap = (measure(n, repeat=repeat, check=False, **QUICK) if quick
                       else measure(n, repeat=repeat))
        results[n] = points
        own = cpu_at(points["flexure esdirk"], COMMON_ERROR)
        peer = cpu_at(points.get("Exudyn", []), COMMON_ERROR)
        best = min(points["flexure esdirk"], key=lambda r: r[2])  # its cheapest run
        ratio = own / peer if own and peer else None
        peer_text = (f"Exudyn {1e3 * peer:.1f} ms CPU per simulated ms; converged answers "
                     f"{gap:.1e} apart (damping, shear)" if peer else "(exudyn not measured)")
        rows.append(Row(
            f"spatial cantilever, {n} BEAMs ({6 * n} DOFs): CPU at equal error "
            f"({COMMON_ERROR:g} of the deflection over 5 ms), flexure/Exudyn",
            f"esdirk {1e3 * own:.2f} ms CPU per simulated ms (cheapest run: rtol {best[0]:g}, "
            f"error {best[1]:.1e}, {best[4]} steps of {1e3 * best[3]:.2f} ms)" if own else
            "esdirk: error not bracketed", peer_text, ratio, None))
    if plot_path:
        plot(results, plot_path)
        log(f"work-precision plot written to {plot_path}")
    return rows, results


def table(results):
    """The points of `measure` per size as text lines."""
    lines = []
    for n, points in results.items():
        lines.append(f"{n} BEAMs ({6 * n} DOFs)")
        lines.append(f"  {'run':16s} {'rtol/h':>8s} {'error':>9s} {'CPU/ms':>9s} "
                     f"{'CPU/step':>9s} {'steps':>6s}")
        for label, rows in points.items():
            for r in rows:
                lines.append(f"  {label:16s} {r[0]:8.1e} {r[1]:9.2e} {1e3 * r[2]:7.2f}ms "
                             f"{1e3 * r[3]:7.3f}ms {r[4]:6d}")
    return "\n".join(lines)


def main(argv=None):
    """python -m examples.benchmarks.cantilever_precision [--plot FILE] [--repeat N]"""
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE", help="write the work-precision plot (PNG)")
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per point (median)")
    parser.add_argument("--sizes", default="16,64", help="BEAMs of the cantilevers")
    args = parser.parse_args(argv)
    sizes = tuple(int(v) for v in args.sizes.split(","))
    rows, results = precision_rows(args.repeat, sizes=sizes, plot_path=args.plot)
    print(table(results))
    for row in rows:
        print(" | ".join(row.cells()))
    return 0


if __name__ == "__main__":
    import sys

    sys.exit(main())
