"""`flexure bench SCENE`: a work-precision study (error against wall time per method).

    flexure bench stage_planar_3dof --t-end 1 --input F=1 --csv wp.csv --markdown wp.md \
        --plot wp.png

Every method (CVODE BDF and Adams, IDA, scipy Radau, BDF and DOP853 on the same right-hand
side) runs at every tolerance; the error is the largest output deviation from a tight
CVODE Adams reference at equally spaced times.
"""

from pathlib import Path

from .cli_simulate import parse_inputs
from .errors import SimulationError
from .scene import load_scene
from .workprecision import ALL_METHODS, DEFAULT_METHODS, work_precision


def register(subparsers):
    """Add the `bench` subcommand."""
    parser = subparsers.add_parser(
        "bench", help="work-precision study: error against wall time for each integrator",
        description="Run every integrator over a range of tolerances against a tight "
                    "reference; print the table, and write it as CSV, markdown and a log-log "
                    "plot.")
    parser.add_argument("scene", help="scene file or built-in scene name")
    parser.add_argument("--t-end", type=float, default=1.0, metavar="T", help="end time (s)")
    parser.add_argument("--input", action="append", default=[], metavar="NAME=VALUE",
                        help="a constant input force (N); default F=1 if the scene has F")
    parser.add_argument("--methods", default=",".join(DEFAULT_METHODS),
                        help=f"comma-separated subset of {','.join(ALL_METHODS)}; a SUNDIALS "
                             "method may end in :ORDER, its largest order (cvode-bdf:2)")
    parser.add_argument("--rtols", default="1e-3,1e-4,1e-5,1e-6,1e-7,1e-8",
                        help="comma-separated relative tolerances")
    parser.add_argument("--reference-rtol", type=float, default=1e-11)
    parser.add_argument("--samples", type=int, default=101,
                        help="equally spaced comparison times")
    parser.add_argument("--time-limit", type=float, default=60.0,
                        help="seconds after which a single run is stopped")
    parser.add_argument("--csv", type=Path, help="write the table as CSV")
    parser.add_argument("--markdown", type=Path, help="write the table as markdown")
    parser.add_argument("--plot", type=Path, help="write the log-log plot (PNG)")
    parser.set_defaults(run=run)


def run(args):
    model = load_scene(args.scene)
    inputs = parse_inputs(args.input)
    if not args.input and "F" in [p.name for p in model.inputs]:
        inputs = {"F": 1.0}
    if any(isinstance(v, tuple) for v in inputs.values()):
        raise SimulationError("bench: inputs must be constants (NAME=VALUE)")
    try:
        rtols = [float(r) for r in args.rtols.split(",")]
    except ValueError:
        raise SimulationError(
            f"--rtols {args.rtols!r}: expected numbers separated by commas") from None
    study = work_precision(model, args.t_end, inputs=inputs,
                           methods=[m.strip() for m in args.methods.split(",")], rtols=rtols,
                           reference_rtol=args.reference_rtol, samples=args.samples,
                           time_limit=args.time_limit,
                           progress=lambda row: print(f"  {row['method']} rtol "
                                                      f"{row['rtol']:.0e}: {row['status']}",
                                                      flush=True))
    print(study.text())
    if args.csv:
        study.to_csv(args.csv)
        print(f"wrote {args.csv}")
    if args.markdown:
        args.markdown.write_text(study.markdown() + "\n")
        print(f"wrote {args.markdown}")
    if args.plot:
        study.plot(args.plot)
        print(f"wrote {args.plot}")
    return 0
