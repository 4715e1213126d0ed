"""`flexure loop [SCENE]`: the closed loop on a scene, its tracking error against 0.1 %.

    flexure loop                                   # stage_planar_1dof, 1 mm in 1 s, 4 kHz
    flexure loop stage_planar_3dof --stroke 0.01 --plant libcosim --json
    flexure loop --quantum 1e-8 --disturbance 0.01@50   # 10 nm encoders, 10 mN of mains
    flexure loop manipulator_control --move E.x=0.004 --move E.y=0 --move E_M1.x=0.004 \
        --move E.z=0 --move E_M1.z=0 --move E_M2.z=0    # every loop along the end effector's
                                                        # move, by the nonlinear inverse statics
"""

import argparse
import os
import sys
from pathlib import Path

from flexure.core.cli import (
    PLOT_SUFFIXES,
    add_scene_arguments,
    check_output,
    fraction,
    nonnegative,
    number,
    positive,
    write_outputs,
)
from flexure.core.errors import UsageError
from flexure.core.reporting.progress import Progress
from flexure.core.reporting.tables import format_table, print_json
from flexure.core.simulation.methods import LOOP_METHOD, LOOP_RTOL
from flexure.core.simulation.methods import METHODS as LOOP_METHODS

from .disturbances import MAINS_HZ
from .runner import PLANTS, run_loop

_finite = number()


def stroke(text):
    """argparse type of --stroke: a finite length (m) or angle (rad), not zero."""
    value = _finite(text)
    if value == 0:
        raise argparse.ArgumentTypeError(f"expected a nonzero length (m), got {text!r}")
    return value


def move(text):
    """argparse type of --move: COORDINATE=DISPLACEMENT (m or rad)."""
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"expected COORDINATE=DISPLACEMENT, got {text!r}")
    return name.strip(), _finite(value)


def quantum(text):
    """argparse type of --quantum: Q, one for every loop, or Q1,Q2,... one per loop (m or
    rad), each positive."""
    try:
        values = [positive(part) for part in text.split(",")]
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"expected a positive quantum (m or rad), or one per loop separated by commas, "
            f"got {text!r}") from None
    return values[0] if len(values) == 1 else values


def disturbance(text):
    """argparse type of --disturbance: AMPLITUDE[@HZ], a positive force (N or N m) and a
    positive frequency (Hz, default 50)."""
    amplitude, sep, hz = text.partition("@")
    try:
        return positive(amplitude), positive(hz) if sep else MAINS_HZ
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(
            f"expected AMPLITUDE[@HZ], a positive force (N or N m) and a positive frequency "
            f"(Hz, default {MAINS_HZ:g}), got {text!r}") from None


def register(subparsers):
    """Add the `loop` subcommand."""
    parser = subparsers.add_parser(
        "loop", help="closed-loop tracking of a third-order move (PID + feedforward)",
        description="Design a PID-like controller for the requested cross-over on the "
                    "scene's linear model, add the feedforward of its low-frequency model, "
                    "and track a third-order move on the nonlinear plant (or its "
                    "linearisation). Reports the largest tracking error against the target "
                    "of 0.1 % of the stroke.")
    add_scene_arguments(parser, default="stage_planar_1dof")
    parser.add_argument("--stroke", type=stroke, default=1e-3, metavar="S",
                        help="stroke of the move in m, or in rad on an angle (default 0.001)")
    parser.add_argument("--duration", type=positive, default=1.0, metavar="T",
                        help="duration of the move in s (default 1)")
    parser.add_argument("--fs", type=positive, default=4000.0, metavar="HZ",
                        help="sample rate of the controller in Hz (default 4000)")
    parser.add_argument("--crossover", type=positive, default=300.0, metavar="RAD_S",
                        help="cross-over of the feedback in rad/s (default 300)")
    parser.add_argument("--settle", type=nonnegative, default=0.25, metavar="T",
                        help="time simulated after the move in s (default 0.25)")
    parser.add_argument("--no-feedforward", action="store_true",
                        help="feedback alone")
    parser.add_argument("--feedforward", choices=("modal", "inverse"), default="modal",
                        help="modal: m a + c v + k x of the low-frequency model (default); "
                             "inverse: the stable approximate inverse (ZPETC) of the full "
                             "sampled linear model")
    parser.add_argument("--loop", action="append", metavar="INPUT:OUTPUT", dest="loops",
                        help="an input and the position output that close a loop (repeatable; "
                             "default: every input with its colocated output); the other "
                             "inputs stay open, at zero force")
    parser.add_argument("--move", type=move, action="append", metavar="COORD=D",
                        help="move the coordinate COORD (e.g. E.x) by D (m or rad) while every "
                             "loop follows; one per loop, D = 0 holds it (repeatable; replaces "
                             "--stroke)")
    parser.add_argument("--path", choices=("nonlinear", "linear"), default=None,
                        help="how --move becomes the loops' references: the nonlinear inverse "
                             "statics or the linearised statics (default: the plant's own, "
                             "linear on --plant linear, nonlinear otherwise)")
    parser.add_argument("--quantum", type=quantum, default=None, metavar="Q",
                        help="encoder quantum in m (rad on an angle): the controller sees the "
                             "positions rounded to it; Q1,Q2,... gives one per loop")
    parser.add_argument("--disturbance", type=disturbance, default=None, metavar="A[@HZ]",
                        help="a sinusoidal force of amplitude A in N (N m on an angle) at "
                             f"every actuator, at HZ Hz (default {MAINS_HZ:g}: the mains)")
    parser.add_argument("--motion-duration", type=positive, default=None, metavar="T",
                        help="on a scene with kinematic inputs: the time in s each takes "
                             "along the scene's move from its start to its value, from t = 0 "
                             "(default --duration); the loop rides on it (--plant inprocess)")
    parser.add_argument("--plant", choices=PLANTS, default="inprocess",
                        help="in-process simulation, the linearised model stepped exactly, the "
                             "scene FMU under fmpy, or the controller and scene FMUs in "
                             "libcosim (default inprocess)")
    parser.add_argument("--method", choices=LOOP_METHODS, default=LOOP_METHOD,
                        help=f"the plant's integrator (default {LOOP_METHOD}: one-step, no restart "
                             "when the force changes at a sample)")
    parser.add_argument("--rtol", type=fraction, default=LOOP_RTOL, metavar="R",
                        help="relative tolerance of the plant's integrator (default "
                             f"{LOOP_RTOL:g}: the sample period bounds its step)")
    parser.add_argument("--plot", default="loop.png", metavar="PNG",
                        help="write reference, position, error and force (default loop.png)")
    parser.add_argument("--no-plot", action="store_true", help="write no plot")
    parser.add_argument("--workdir", default=None,
                        help="folder for the FMUs, kept for the next run: the scene's FMU is "
                             "built again when the scene, --set or flexure changed (default: a "
                             "temporary folder)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(run=run)


def run(args):
    feedforward = False if args.no_feedforward else args.feedforward
    plot = None if args.no_plot or not args.plot else check_output(
        args.plot, suffixes=PLOT_SUFFIXES, option="--plot")
    if args.workdir is not None:
        check_workdir(args.workdir)
    scene, overrides, path = args.scene, args.set, None
    said = set()

    def warn(message):  # on stderr as soon as found, once
        if message not in said:
            said.add(message)
            print(f"flexure loop: warning: {message}", file=sys.stderr, flush=True)

    if args.move and args.loops:
        raise UsageError("--loop: a --move path is planned on every input's colocated loop; "
                         "choose the loops without --move")
    if args.move:
        model, path = move_path_of(args, warn)
        if args.plant in ("inprocess", "linear"):  # the FMU plants build from the scene file
            scene, overrides = model, None  # loaded with --set once, not twice
    amplitude, hz = args.disturbance if args.disturbance is not None else (None, MAINS_HZ)
    result = run_loop(scene, stroke=args.stroke, duration=args.duration, fs=args.fs,
                      crossover=args.crossover, feedforward=feedforward, plant=args.plant,
                      settle=args.settle, method=args.method, rtol=args.rtol,
                      workdir=args.workdir, overrides=overrides, path=path,
                      quantum=args.quantum, disturbance=amplitude, disturbance_hz=hz,
                      progress=Progress(f"flexure loop ({args.plant})", after=1.0), warn=warn,
                      motion_duration=args.motion_duration,
                      **({"loops": args.loops} if args.loops else {}))
    summary = result.summary()
    code = write_outputs("flexure loop", [("--plot", plot, result.plot)],
                         announce=False) if plot else 0
    if plot and code == 0:
        summary["plot"] = str(plot)
    if args.json:
        print_json(summary, command="flexure loop")
    else:
        print(render(summary))
    return code


def move_path_of(args, warn):
    """The scene's model (with --set) and the loops' path for the --move coordinates
    (UsageError for a repeated one); `warn` gets the targets beyond the range of validity
    before the path is computed."""
    from flexure.core import load_scene

    from .move_path import move_path
    from .validity import motion_warnings

    targets = {}
    for name, value in args.move:
        if name in targets:
            raise UsageError(f"--move {name}: given twice")
        targets[name] = value
    if args.feedforward == "inverse" and not args.no_feedforward:
        raise UsageError("--move takes the modal feedforward or none, not --feedforward inverse")
    kind = args.path or ("linear" if args.plant == "linear" else "nonlinear")
    model = load_scene(args.scene, overrides=args.set)
    for message in motion_warnings(model, targets):
        warn(message)
    return model, move_path(model, targets, kind=kind,
                            progress=Progress(f"flexure loop: {kind} move path", after=1.0))


def _per_loop_table(s):
    """Each loop's stroke and error, the unit in the header, or in each cell where the loops'
    units differ (a force loop beside a moment loop)."""
    rows = s["per_loop"]
    units = [row.get("units", s["units"])["position"] for row in rows]
    mixed = len(set(units)) > 1

    def cell(value, unit):
        return f"{value:.6g} {unit}" if mixed else value

    header = "" if mixed else f" ({units[0]})"
    note = ""
    if any(row.get("held") for row in rows):
        note = ("\nheld: a loop that holds its position, its error over the moving stroke (an "
                "angle's through the mechanism's size)")
    return format_table(
        ["loop", f"stroke{header}", f"max |error|{header}", "error / stroke", "within 0.1 %"],
        [(row["loop"], "held" if row.get("held") else cell(row["stroke"], unit),
          cell(row["max_abs_error"], unit), row["error_ratio"], "yes" if row["passed"] else "NO")
         for row, unit in zip(rows, units, strict=True)]) + note


def _plugged_rows(s):
    """The table's rows for a reference, a controller or disturbances of one's own."""
    position = s["units"]["position"]
    force = "N m" if position == "rad" else "N"
    rows = []
    if s.get("reference_kind") in ("samples", "callable"):
        rows.append(("reference", "given as samples" if s["reference_kind"] == "samples"
                     else "given as r(t)"))
    if not s.get("robustness_checked", True):
        rows.append(("robustness", "not checked: a callable has no linear model"))
    if "quantum" in s:
        rows.append((f"encoder quantum ({position})", _one_or_all(s["quantum"])))
    if "disturbance" in s:
        d = s["disturbance"]
        rows.append((f"disturbance ({force}, at {d['frequency_hz']:g} Hz)",
                     _one_or_all(d["amplitude"])))
    return rows


def _motion_rows(s):
    """The table's rows for a scene's kinematic inputs: each one's move and its effort at the
    end."""
    rows = []
    for name, motion in s.get("kinematic_inputs", {}).items():
        rows.append((f"kinematic input {name}", f"{motion['start']:.6g} to {motion['value']:.6g}"
                     f" in {motion['motion_duration']:g} s"))
        rows.append((f"{name}.effort at the end", motion["effort_end"]))
    return rows


def _one_or_all(values):
    """One number when every loop has the same, else all of them."""
    return values[0] if len(set(values)) == 1 else ", ".join(f"{v:g}" for v in values)


def check_workdir(workdir):
    """UsageError unless `workdir` is (or can be made as) a writable folder."""
    path = Path(workdir)
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise UsageError(f"--workdir {workdir}: {existing} is not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise UsageError(f"--workdir {workdir}: the folder {existing} is not writable")


def render(s):
    """The summary as a short table and a verdict."""
    feedback = {"state space": "your discrete system", "callable": "your callable"}.get(
        s.get("controller_kind"), "feedback")
    rows = [
        ("scene", s["scene"]), ("plant", s["plant"]),
        ("controller", f"{feedback} + {s['feedforward_kind']} feedforward" if s["feedforward"]
         else f"{feedback} alone"),
        *_plugged_rows(s), *_motion_rows(s),
        (f"stroke ({s['units']['position']})", s["stroke"]), ("duration (s)", s["duration"]),
        ("sample rate (Hz)", s["sample_rate_hz"]),
        ("cross-over (rad/s)", s["crossover_rad_s"]),
        ("phase margin (deg)" if len(s["per_loop"]) < 2 else
         "phase margin, other loops open (deg)", s["phase_margin_deg"]),
        ("gain margin", s["gain_margin"]),
        ("modulus margin", s["modulus_margin"]),
        *([("phase margin, other loops closed (deg)", s["phase_margin_others_closed_deg"]),
           ("modulus margin, other loops closed", s["modulus_margin_others_closed"]),
           ("sensitivity peak (all loops)", s["sensitivity_peak"])]
          if "phase_margin_others_closed_deg" in s else []),
        (f"max |error| ({s['units']['position']})", s["max_abs_error"]),
        ("error / stroke", s["error_ratio"]), ("target", s["target"]),
        ("wall time (s)", s["wall_time_s"]),
    ]
    verdict = (f"tracking error {100 * s['error_ratio']:.3g} % of the stroke against the "
               f"target {100 * s['target']:g} %: {'PASSED' if s['passed'] else 'FAILED'}")
    text = format_table(["quantity", "value"], rows)
    if len(s["per_loop"]) > 1:
        text += "\n\n" + _per_loop_table(s)
    text += "\n" + verdict
    text += "".join(f"\nwarning: {message}" for message in s.get("warnings", []))
    if "plot" in s:
        text += f"\nplot written to {s['plot']}"
    return text


