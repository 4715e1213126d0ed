"""`flexure simulate SCENE --t-end T`: a nonlinear time-domain simulation to CSV and PNG.

    flexure simulate stage_planar_3dof --t-end 1 --input F=1 --out step.csv --plot step.png
    flexure simulate stage_planar_1dof --t-end 2 --input F=force.csv --method ida
    flexure simulate stage_planar_3dof --t-end 0.5 --input F=1 --dofs run.csv  # flexure view

An input is a constant (N) or a CSV file of samples `time,value` (a header line is allowed),
held from each sample time to the next (zero-order hold).
"""

from pathlib import Path

import numpy as np

from ..analysis.pictures import MAX_FRAMES
from ..errors import SimulationError, UsageError
from ..reporting.progress import Progress
from ..reporting.tables import format_table
from ..simulation.methods import METHOD_TABLE, METHODS
from . import (
    PLOT_SUFFIXES,
    add_scene_arguments,
    count,
    distinct_outputs,
    fraction,
    number,
    output_file,
    positive,
    refuse_overwriting_inputs,
    write_outputs,
)

# a million samples: a CSV of a million rows, a plot far finer than its pixels; ten million
# took minutes of output stops and of outputs computed per sample, with little to show
SAMPLES = number(1, 1_000_000, integer=True, low_open=False, high_open=False)
# t_end / max_step above this is refused before the run: at a few microseconds a step of a
# small model, 1e8 steps take longer than anyone waits for an answer on purpose
MAX_STEPS = 1e8


def register(subparsers):
    """Add the `simulate` subcommand."""
    parser = subparsers.add_parser(
        "simulate", help="nonlinear time-domain simulation (SUNDIALS CVODE and IDA, one-step "
                               "ESDIRKs)",
        description="Simulate a scene from rest under its loads and the given inputs; print a "
                    "summary, and write the outputs to CSV (--out) and a plot (--plot).")
    add_scene_arguments(parser)
    parser.add_argument("--t-end", type=positive, required=True, metavar="T",
                        help="end time (s)")
    parser.add_argument("--input", action="append", default=[], metavar="NAME=VALUE|NAME=FILE",
                        help="an input force: a constant (N) or a CSV file time,value "
                             "(zero-order hold); repeat for several inputs")
    parser.add_argument("--motion-duration", type=positive, default=None, metavar="T",
                        help="a scene with kinematic inputs: the time (s) each takes to move "
                             "from its start to its value (a rest-to-rest quintic from t = 0; "
                             "default --t-end); their efforts become outputs NAME.effort")
    parser.add_argument("--method", choices=METHODS, default="cvode-bdf",
                        help="the integrator (default cvode-bdf): "
                             + "; ".join(f"{m.name}, {m.summary}" for m in METHOD_TABLE))
    parser.add_argument("--max-order", type=count, default=None,
                        help="largest order of the multistep formulas (default SUNDIALS': 5 "
                             "for BDF and IDA)")
    parser.add_argument("--rtol", type=fraction, default=1e-8,
                        help="relative tolerance, in (0, 1)")
    parser.add_argument("--atol", type=positive, default=None,
                        help="absolute tolerance on the deviation from the start "
                             "configuration (default: per state, rtol x 1e-3 x the model's "
                             "length scale on lengths, see default_atol)")
    parser.add_argument("--max-step", type=positive, default=None, help="largest step (s)")
    parser.add_argument("--samples", type=SAMPLES, default=None, metavar="N",
                        help="record N + 1 equally spaced times (default: every solver step)")
    parser.add_argument("--out", type=output_file(),
                        help="CSV file: time and one column per output")
    parser.add_argument("--dofs", type=output_file((".csv",)), metavar="CSV",
                        help="CSV file: time and one column per DOF, what `flexure view "
                             "--simulation` animates")
    parser.add_argument("--plot", type=output_file(PLOT_SUFFIXES),
                        help="PNG (or .pdf, .svg) file: the outputs against time")
    parser.add_argument("--animate", type=output_file((".gif",)), metavar="GIF",
                        help="GIF file: the motion over the undeformed model, magnified so "
                             "that the largest displacement is 10 %% of the model's size, at "
                             f"most {MAX_FRAMES} frames (recorded times nearest to equally "
                             "spaced ones; --samples sets them)")
    parser.set_defaults(run=run)


def parse_inputs(specs, *, source="--input"):
    """{name: float or (times, values)} from NAME=VALUE or NAME=FILE.csv strings."""
    inputs = {}
    for spec in specs:
        name, sep, value = spec.partition("=")
        if not sep or not name:
            raise SimulationError(f"{source} {spec!r}: expected NAME=VALUE or NAME=FILE.csv")
        if name in inputs:
            raise UsageError(f"{source} {spec!r}: the input {name!r} is given twice")
        try:
            inputs[name] = float(value)
        except ValueError:
            pass
        else:
            if not np.isfinite(inputs[name]):
                raise UsageError(f"{source} {spec!r}: input {name!r} is not finite ({value})")
            continue
        path = Path(value)
        if not path.is_file():
            raise SimulationError(f"{source} {spec!r}: {value!r} is neither a number nor a "
                                  "CSV file")
        inputs[name] = read_samples(path)
    return inputs


def read_samples(path):
    """(times, values) from a CSV file of two columns time,value (s, N): finite numbers, the
    times increasing from 0 or later; SimulationError naming the row otherwise."""
    try:
        lines = [line for line in Path(path).read_text().splitlines() if line.strip()]
        if lines and not _is_number(lines[0].split(",")[0]):
            lines = lines[1:]
        rows = np.array([[float(v) for v in line.split(",")[:2]] for line in lines])
    except OSError as error:
        raise SimulationError(f"{path}: cannot read: {error.strerror}") from None
    except (ValueError, IndexError) as error:  # UnicodeDecodeError is a ValueError
        raise SimulationError(f"{path}: expected two numeric columns time,value: "
                              f"{error}") from None
    if rows.ndim != 2 or rows.shape[0] == 0 or rows.shape[1] != 2:
        raise SimulationError(f"{path}: expected rows time,value")
    bad = np.flatnonzero(~np.all(np.isfinite(rows), axis=1))
    if bad.size:
        raise SimulationError(f"{path}: row {bad[0] + 1} of the samples: expected finite "
                              f"numbers, got {rows[bad[0]].tolist()}")
    if rows[0, 0] < 0.0:  # a simulation starts at t = 0: an earlier sample is a mistake
        raise SimulationError(f"{path}: row 1 of the samples: time {rows[0, 0]:g} s is before "
                              "the simulation's start at 0 s")
    back = np.flatnonzero(np.diff(rows[:, 0]) <= 0)
    if back.size:
        raise SimulationError(f"{path}: row {back[0] + 2} of the samples: expected a time after "
                              f"{rows[back[0], 0]:g} s, got {rows[back[0] + 1, 0]:g} s (times "
                              "must increase)")
    return rows[:, 0], rows[:, 1]


def _is_number(text):
    try:
        float(text)
        return True
    except ValueError:
        return False


def run(args):
    from ..analysis.pictures import animate, require_drawable
    from ..scene.building import load_scene
    from ..simulation.dof_csv import write_dof_csv
    from ..simulation.simulation import simulate

    # --max-order above the method's largest order: refused by sundials.make_solver, before
    # the run
    outputs = [("--out", args.out), ("--dofs", args.dofs), ("--plot", args.plot),
               ("--animate", args.animate)]
    distinct_outputs(*outputs)
    if args.max_step is not None and args.t_end / args.max_step > MAX_STEPS:
        raise UsageError(f"--max-step {args.max_step:g} s with --t-end {args.t_end:g} s means "
                         f"at least {args.t_end / args.max_step:.3g} steps (more than "
                         f"{MAX_STEPS:.0e}): raise --max-step or shorten --t-end")
    model = load_scene(args.scene, overrides=args.set)
    if args.animate:
        require_drawable(model, "--animate")  # before the run, not after it
    if args.motion_duration is not None and not model.kinematic_inputs:
        raise UsageError(f"--motion-duration {args.motion_duration:g}: {model.name!r} has no "
                         "kinematic input ([inputs.NAME] kind = \"motion\") to move")
    inputs = parse_inputs(args.input)
    refuse_overwriting_inputs(outputs, [model.source, *_input_files(args.input)])
    output_times = (np.linspace(0.0, args.t_end, args.samples + 1) if args.samples else None)
    result = simulate(model, args.t_end, inputs=inputs, method=args.method, rtol=args.rtol,
                      atol=args.atol, max_step=args.max_step, output_times=output_times,
                      max_order=args.max_order, motion_duration=args.motion_duration,
                      progress=Progress(f"flexure simulate {model.name}", after=1.0))
    print(render(result))
    return write_outputs("flexure simulate", [
        ("--out", args.out, result.to_csv),
        ("--dofs", args.dofs, lambda path: write_dof_csv(path, model, result.times, result.q)),
        ("--plot", args.plot, result.plot),
        ("--animate", args.animate, lambda path: animate(model, result, path))])


def _input_files(specs):
    """The files named by NAME=FILE inputs."""
    return [spec.partition("=")[2] for spec in specs
            if not _is_number(spec.partition("=")[2])]


def render(result):
    """A summary: final outputs and solver statistics."""
    values = result.output_array
    rows = [(name, f"{values[-1, i]:.9g}", unit, f"{values[:, i].min():.6g}",
             f"{values[:, i].max():.6g}")
            for i, (name, unit) in enumerate(zip(result.output_names, result.output_units,
                                                 strict=True))]
    stats = result.statistics
    lines = [f"simulated {result.model_name} to t = {result.times[-1]:g} s with {result.method} "
             f"(rtol {result.rtol:g})",
             format_table(["output", "final", "unit", "min", "max"], rows),
             f"steps {stats['steps']}, rhs evaluations {stats['rhs_evaluations']}, Jacobians "
             f"{stats['jacobian_evaluations']}, wall time {stats['wall_time_s']:.3f} s"]
    lines += [f"warning: {message}" for message in result.warnings]
    return "\n".join(lines)
