"""`flexure optimize SCENE --vary KEY=LO:HI ... --objective ... --constraint ...`.

    flexure optimize stage_planar_3dof --set sections.leaf.rho=0 \
        --vary sections.leaf.height=0.3e-3:2e-3 --vary sections.leaf.width=0.01:0.03 \
        --objective max:frequency[2] --constraint "frequency[1]=30+-1"

Varies scene keys within bounds (`flexure.core.analysis.optimize`), with the objective and
constraints of the grammar of `flexure.core.analysis.optimize_goals`; prints a line per
iteration on stderr and the history as a table, and writes the optimum as a scene (--out),
the history as CSV (--history) and its plot beside it. docs/optimize.md.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

from ..errors import UsageError
from ..reporting.tables import format_table
from . import (
    PLOT_SUFFIXES,
    add_scene_arguments,
    check_output,
    count,
    output_file,
    positive,
    refuse_overwriting_inputs,
    write_outputs,
)


def register(subparsers):
    """Add the `optimize` subcommand."""
    parser = subparsers.add_parser(
        "optimize", help="vary scene values within bounds for an objective under constraints",
        description="Vary scene keys within bounds to maximise or minimise a quantity "
                    "(frequency[K], buckling[K], output[NAME], von_mises, dc_gain[IN->OUT]) "
                    "under constraints, with scipy.optimize and the design sensitivities as "
                    "gradients; write the optimum as a scene. Grammar: docs/optimize.md.")
    add_scene_arguments(parser)
    parser.add_argument("--vary", action="append", required=True, metavar="KEY=LO:HI",
                        help="a scene key the scene gives a number for and its bounds, SI "
                             "(repeatable), e.g. sections.leaf.height=0.3e-3:2e-3")
    parser.add_argument("--objective", required=True, metavar="max:Q|min:Q",
                        help="e.g. max:frequency[2] (the first parasitic frequency)")
    parser.add_argument("--constraint", action="append", default=[], metavar="Q<=B|Q>=B|Q=T+-D",
                        help="repeatable: frequency[1]=30+-1, buckling[1]>=3, "
                             "von_mises<=0.5*yield")
    parser.add_argument("--yield", type=positive, dest="yield_stress", metavar="PA",
                        help="the yield stress (Pa) that 'yield' in a constraint stands for "
                             "(default: the sections' yield_stress)")
    parser.add_argument("--method", choices=("SLSQP", "trust-constr"), default="SLSQP",
                        help="scipy.optimize.minimize's method (default SLSQP)")
    parser.add_argument("--tol", type=positive, default=1e-9, metavar="TOL",
                        help="the optimiser's relative tolerance on the objective (1e-9)")
    parser.add_argument("--max-iterations", type=count, default=100, metavar="N",
                        help="the most iterations (100)")
    parser.add_argument("--out", type=output_file((".toml",)), metavar="TOML",
                        help="the optimum scene (default: SCENE_NAME_optimum.toml here)")
    parser.add_argument("--history", type=output_file((".csv",)), metavar="CSV",
                        help="the history (default: SCENE_NAME_optimize.csv here); its plot "
                             "goes beside it with .png")
    parser.add_argument("--no-plot", action="store_true", help="write no plot")
    parser.set_defaults(run=run)


def run(args):
    from ..analysis.optimize import optimize, parse_variable
    from ..analysis.optimize_goals import (
        parse_constraint,
        parse_objective,
        scene_yield_stress,
    )
    from ..scene.building import load_scene, scene_path
    from ..scene.scene_writer import scene_toml

    # every option checked before the first analysis
    bounds = {}
    for text in args.vary:
        key, low, high = parse_variable(text)
        if key in bounds:
            raise UsageError(f"--vary {key}: given twice; give each key once")
        if key in args.set:
            raise UsageError(f"--vary {key}: also given to --set; a key is either varied or set")
        bounds[key] = (low, high)
    objective = parse_objective(args.objective)
    path = scene_path(args.scene)
    model = load_scene(path, overrides=args.set)
    yield_stress = args.yield_stress
    if yield_stress is None:
        yield_stress = scene_yield_stress(model.scene)
    constraints = [parse_constraint(text, yield_stress=yield_stress)
                   for text in args.constraint]
    out = args.out or output_file((".toml",))(f"{model.name}_optimum.toml")
    history_path = args.history or output_file((".csv",))(f"{model.name}_optimize.csv")
    plot = None if args.no_plot else check_output(history_path.with_suffix(".png"),
                                                  suffixes=PLOT_SUFFIXES, option="the plot")
    refuse_overwriting_inputs([("--out", out), ("--history", history_path),
                               ("the plot", plot)], [path])
    width = max(len(key) for key in bounds)

    def progress(step):
        point = "  ".join(f"{key:>{width}} = {value:.6g}" for key, value in
                          zip(bounds, step.x, strict=True))
        print(f"flexure optimize: iteration {step.number:3d}  {objective.quantity.text} = "
              f"{step.objective:.8g}  violation {step.violation:.2e}  {point}",
              file=sys.stderr, flush=True)

    found = optimize(model, bounds, objective, constraints, method=args.method,
                     tolerance=args.tol, max_iterations=args.max_iterations,
                     on_iteration=progress)
    header, rows = history_table(found)
    print(format_table(header, rows, title="history"))
    print()
    print(format_table(["optimum", "value"], summary(found)))
    header_text = (f"the optimum of: flexure optimize {path.name} "
                   + "".join(f"--set {k}={v} " for k, v in args.set.items())
                   + f"--objective {objective.text!r} "
                   + " ".join(f"--constraint {c.text!r}" for c in constraints)
                   + "\n" + ", ".join(f"{k} = {float(v)!r}" for k, v in zip(found.keys, found.x,
                                                                             strict=True)))
    outputs = [("--out", out, lambda t: Path(t).write_text(scene_toml(found.scene, header_text))),
               ("--history", history_path, lambda t: write_history(t, header, rows))]
    if plot is not None:
        outputs.append(("the plot", plot, lambda t: plot_history(t, found, model.name)))
    code = write_outputs("flexure optimize", outputs)
    if not found.success:
        hint = (f"; the constraints were not met together (largest violation "
                f"{found.violation:.2g} of its bound): widen --vary's bounds or loosen a "
                "constraint" if found.violation > 0 else "")
        print(f"flexure optimize: the optimiser stopped without success: {found.message}"
              f"{hint}", file=sys.stderr)
        return code or 1
    return code


def history_table(found):
    """(header, rows) of the history: iteration, design points analysed, the keys, the
    objective quantity, each constrained quantity, the largest relative violation."""
    header = ["iteration", "evaluations",
              *[f"{k} [{u}]" for k, u in zip(found.keys, found.key_units, strict=True)],
              _label(found.objective.quantity),
              *[_label(c.quantity) for c in found.constraints], "violation [-]"]
    rows = [[step.number, step.evaluations, *map(float, step.x), step.objective,
             *map(float, step.constraints), step.violation] for step in found.history]
    return header, rows


def _label(quantity):
    return f"{quantity.text} [{quantity.unit}]" if quantity.unit else quantity.text


def summary(found):
    """The rows of the optimum's table: how it ended, each key, the objective, each
    constraint with its bounds."""
    rows = [("result", "converged" if found.success else f"not converged: {found.message}"),
            ("method", found.method), ("iterations", len(found.history) - 1),
            ("design points analysed", found.evaluations)]
    for key, unit, low, high, start, value in zip(found.keys, found.key_units, found.lower,
                                                  found.upper, found.start, found.x,
                                                  strict=True):
        near = 1e-9 * (high - low)  # the optimiser's u in [0, 1] rounds back to within this
        bound = " (at LO)" if value <= low + near else " (at HI)" if value >= high - near else ""
        rows.append((f"{key} [{unit}]", f"{value:.8g}{bound}  (from {start:.6g}; "
                                        f"{low:g}:{high:g})"))
    rows.append((f"{found.objective.text}", f"{found.objective_value:.8g} (from "
                                            f"{found.history[0].objective:.8g})"))
    for constraint, value in zip(found.constraints, found.constraint_values, strict=True):
        rows.append((f"{constraint.text}", f"{value:.8g}"))
    rows.append(("largest violation (relative)", f"{found.violation:.2e}"))
    return rows


def write_history(path, header, rows):
    """The history as CSV, every float as its repr (it reads back to the same number)."""
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows([[repr(v) if isinstance(v, float) else v for v in row]
                          for row in rows])


def plot_history(path, found, name):
    """Three panels over the iterations: the objective, each constrained quantity divided by
    its (upper, else lower) bound with the bounds dashed, and each key as the fraction of its
    range (0 at LO, 1 at HI)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.ticker import MaxNLocator

    steps = [step.number for step in found.history]
    panels = 2 + bool(found.constraints)
    fig, axes = plt.subplots(panels, 1, figsize=(6.5, 2.6 * panels), sharex=True)
    axes[0].plot(steps, [s.objective for s in found.history], "o-", markersize=3)
    axes[0].set_ylabel(_label(found.objective.quantity), fontsize=8)
    axes[0].set_title(f"{name}: {found.objective.text}", fontsize=9)
    if found.constraints:  # each over its bound, so that Hz, Pa and factors share an axis
        for k, constraint in enumerate(found.constraints):
            scale = abs(constraint.upper if constraint.upper is not None else constraint.lower)
            scale = scale or 1.0
            line, = axes[1].plot(steps, [s.constraints[k] / scale for s in found.history],
                                 "o-", markersize=3, label=constraint.text)
            for bound in (constraint.lower, constraint.upper):
                if bound is not None:
                    axes[1].axhline(bound / scale, color=line.get_color(), linestyle="--",
                                    lw=0.8)
        if all(s.constraints.min() > 0 for s in found.history):
            axes[1].set_yscale("log")
        axes[1].set_ylabel("quantity / its bound (dashed)", fontsize=8)
        axes[1].legend(fontsize=7)
    share = np.array([(s.x - found.lower) / (found.upper - found.lower) for s in found.history])
    for j, key in enumerate(found.keys):
        axes[-1].plot(steps, share[:, j], "o-", markersize=3, label=key)
    axes[-1].set_ylabel("(key - LO) / (HI - LO)", fontsize=8)
    axes[-1].set_xlabel("iteration", fontsize=8)
    axes[-1].xaxis.set_major_locator(MaxNLocator(integer=True))  # no iteration 0.5
    axes[-1].legend(fontsize=7)
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.tick_params(labelsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
