"""`flexure bench SCENE`: a work-precision study (error against wall time per method).

    flexure bench stage_planar_3dof --t-end 1 --input F=1 --csv wp.csv --markdown wp.md \
        --plot wp.png

Every method (CVODE BDF and Adams, IDA, scipy Radau, BDF and DOP853 on the same right-hand
side) runs at every tolerance; the error is the largest output deviation from a tight
CVODE Adams reference at equally spaced times.
"""

import argparse
from pathlib import Path

from ..errors import SimulationError, UsageError
from ..simulation.workprecision import ALL_METHODS, DEFAULT_METHODS, work_precision
from . import (
    PLOT_SUFFIXES,
    add_scene_arguments,
    distinct_outputs,
    fraction,
    number,
    output_file,
    positive,
    write_outputs,
)
from .simulate import parse_inputs

SAMPLES = number(2, 1_000_000, integer=True, low_open=False, high_open=False)
TOP_ORDER = {"cvode-adams": 12, "cvode-bdf": 5, "ida": 5}
REFERENCE_MARGIN = 10  # the reference's rtol at most a tenth of the tightest measured


def method_list(text):
    """argparse type of --methods: known methods (NAME or NAME:ORDER), each once."""
    methods = [m.strip() for m in text.split(",")]
    for method in methods:
        name, _, order = method.partition(":")
        top = TOP_ORDER.get(name)
        if name not in ALL_METHODS or (order and (top is None or not order.isdigit()
                                                  or not 1 <= int(order) <= top)):
            raise argparse.ArgumentTypeError(
                f"unknown method {method!r}; expected some of {', '.join(ALL_METHODS)} "
                "separated by commas, a SUNDIALS one optionally with ':ORDER' (1 to 5, 12 for "
                "cvode-adams), e.g. cvode-bdf:2")
        if methods.count(method) > 1:
            raise argparse.ArgumentTypeError(f"{method!r} is listed {methods.count(method)} "
                                             "times; list each method once")
    return methods


def rtol_list(text):
    """argparse type of --rtols: relative tolerances in (0, 1), each once."""
    rtols = []
    for part in text.split(","):
        try:
            rtols.append(fraction(part.strip()))
        except argparse.ArgumentTypeError as error:
            raise argparse.ArgumentTypeError(f"{text!r}: {error}; separate the tolerances "
                                             "by commas") from None
        if rtols.count(rtols[-1]) > 1:
            raise argparse.ArgumentTypeError(f"{text!r}: {part.strip()} is listed twice")
    return rtols


def register(subparsers):
    """Add the `bench` subcommand."""
    parser = subparsers.add_parser(
        "bench", help="work-precision study: error against wall time for each integrator",
        description="Run every integrator over a range of tolerances against a tight "
                    "reference; print the table, and write it as CSV, markdown and a log-log "
                    "plot.")
    add_scene_arguments(parser)
    parser.add_argument("--t-end", type=positive, default=1.0, metavar="T",
                        help="end time (s)")
    parser.add_argument("--input", action="append", default=[], metavar="NAME=VALUE",
                        help="a constant input force (N); default F=1 if the scene has F")
    parser.add_argument("--methods", type=method_list, default=list(DEFAULT_METHODS),
                        help=f"comma-separated subset of {','.join(ALL_METHODS)}; a SUNDIALS "
                             "method may end in :ORDER, its largest order (cvode-bdf:2)")
    parser.add_argument("--rtols", type=rtol_list, default=[1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8],
                        help="comma-separated relative tolerances, each in (0, 1) (default "
                             "1e-3,1e-4,1e-5,1e-6,1e-7,1e-8)")
    parser.add_argument("--reference-rtol", type=fraction, default=1e-11)
    parser.add_argument("--samples", type=SAMPLES, default=101,
                        help="equally spaced comparison times (at least 2)")
    parser.add_argument("--time-limit", type=positive, default=60.0,
                        help="seconds after which a single run is stopped")
    parser.add_argument("--csv", type=output_file(), help="write the table as CSV")
    parser.add_argument("--markdown", type=output_file(), help="write the table as markdown")
    parser.add_argument("--plot", type=output_file(PLOT_SUFFIXES),
                        help="write the log-log plot (PNG, or .pdf, .svg)")
    parser.set_defaults(run=run)


def run(args):
    from ..scene.building import load_scene

    # each run's error is measured against the reference: a reference no tighter than the
    # runs would measure its own error, not theirs
    if args.reference_rtol * REFERENCE_MARGIN > min(args.rtols):
        raise UsageError(f"--reference-rtol {args.reference_rtol:g}: the reference must be at "
                         f"least {REFERENCE_MARGIN} times tighter than the tightest of --rtols "
                         f"({min(args.rtols):g}): give at most "
                         f"{min(args.rtols) / REFERENCE_MARGIN:g}")
    model = load_scene(args.scene, overrides=args.set)
    inputs = parse_inputs(args.input)
    if not args.input and "F" in [p.name for p in model.inputs]:
        inputs = {"F": 1.0}
    if any(isinstance(v, tuple) for v in inputs.values()):
        raise SimulationError("bench: inputs must be constants (NAME=VALUE)")
    outputs = [("--csv", args.csv), ("--markdown", args.markdown), ("--plot", args.plot)]
    distinct_outputs(*outputs)
    study = work_precision(model, args.t_end, inputs=inputs, methods=args.methods,
                           rtols=args.rtols,
                           reference_rtol=args.reference_rtol, samples=args.samples,
                           time_limit=args.time_limit,
                           progress=lambda row: print(f"  {row['method']} rtol "
                                                      f"{row['rtol']:.0e}: {row['status']}",
                                                      flush=True))
    print(study.text())
    code = write_outputs("flexure bench", [
        ("--csv", args.csv, study.to_csv),
        ("--markdown", args.markdown,
         lambda path: Path(path).write_text(study.markdown() + "\n")),
        ("--plot", args.plot, study.plot)])
    failed = [row for row in study.rows if row["status"] != "ok"]
    if study.rows and len(failed) == len(study.rows):
        raise SimulationError(f"bench {model.name}: every run failed ({len(failed)} of "
                              f"{len(study.rows)}; first: {failed[0]['method']} rtol "
                              f"{failed[0]['rtol']:g}: {failed[0]['status']}); no result to "
                              "compare")
    return code
