"""`flexure sweep SCENE --param KEY=START:STOP:N ...`: a design sweep, on Dask, to a table.

    flexure sweep stage_planar_1dof --param sections.leaf.height=0.3e-3:0.8e-3:6 \
        --param nodes.3.mass=0,0.2 --analyses static,modes,buckling --out sweep.csv
    flexure sweep stage_planar_1dof --param nodes.3.mass=0,0.2 --analyses simulate,loop \
        --simulate-t-end 0.05 --loop-duration 0.1

The options of the registered analyses (simulate; loop, registered by flexure.controllers:
`flexure.core.sweep.analyses`) are added as --ANALYSIS-OPTION, from the registry.

Every point of the grid (the Cartesian product of the --param values) is one scene with those
overrides, analysed by `flexure.core.sweep.grid.evaluate_point`, on a dask.distributed
LocalCluster of this machine's cores, on an existing cluster (--scheduler), or in this process
(--serial). The table (`flexure.core.sweep.table`) goes to CSV, to Parquet when pyarrow
is importable, and its quantities to a plot beside it.
"""

import argparse
import time

from ..errors import FlexureError, UsageError
from ..reporting.progress import Progress
from ..reporting.tables import format_table
from ..sweep import analyses as registry
from ..sweep.grid import (
    DEFAULT_MODES,
    analysis_names,
    columns,
    default_workers,
    grid,
    parse_parameter,
    run_sweep,
)
from ..sweep.stroke import PREFIX as STROKE
from ..sweep.stroke import check_strokes
from ..sweep.table import SweepTable
from ..sweep.ties import parse_tie, tie_points
from . import (
    PLOT_SUFFIXES,
    add_scene_arguments,
    atomic_output,
    check_output,
    count,
    number,
    output_file,
    refuse_overwriting_inputs,
    write_outputs,
)


def parameter(text):
    """argparse type of --param: (KEY, values) (`sweep.parse_parameter`)."""
    try:
        return parse_parameter(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def name_list(text):
    """argparse type of --stroke-inputs: names separated by commas, each once."""
    names = [name.strip() for name in text.split(",")]
    if not all(names) or len(set(names)) != len(names):
        raise argparse.ArgumentTypeError(f"expected input names separated by commas, each "
                                         f"once, got {text!r}")
    return names


def analysis_list(text):
    """argparse type of --analyses: known analyses, each once, in the order of
    `analysis_names` (static, modes, buckling, then the registered ones)."""
    known = analysis_names()
    names = [name.strip() for name in text.split(",")]
    for name in names:
        if name not in known:
            raise argparse.ArgumentTypeError(f"unknown analysis {name!r}; expected some of "
                                             f"{', '.join(known)} separated by commas")
        if names.count(name) > 1:
            raise argparse.ArgumentTypeError(f"{name!r} is listed {names.count(name)} times")
    return tuple(name for name in known if name in names)


def option_type(option):
    """argparse type of an analysis option: its parser, its ValueError as the message."""
    def parse(text):
        try:
            return option.parse(text)
        except ValueError as error:
            raise argparse.ArgumentTypeError(str(error)) from None

    parse.__name__ = option.name
    return parse


def add_analysis_options(parser):
    """--ANALYSIS-OPTION for every option of every registered analysis (default None: the
    analysis's own default)."""
    for analysis in registry.available().values():
        group = parser.add_argument_group(f"options of --analyses {analysis.name}")
        for option in analysis.options:
            default = "" if option.default in ("", None) else f" (default {option.default})"
            group.add_argument(f"--{analysis.name}-{option.name.replace('_', '-')}",
                               type=option_type(option), metavar=option.metavar,
                               dest=f"{analysis.name}:{option.name}",
                               help=f"{option.help}{default}")


def analysis_settings(args):
    """{analysis: {option: value}} of the --ANALYSIS-OPTION given; UsageError for one whose
    analysis is not in --analyses."""
    settings = {}
    for dest, value in vars(args).items():
        name, sep, option = dest.partition(":")
        if not sep or value is None:
            continue
        if name not in args.analyses:
            raise UsageError(f"--{name}-{option.replace('_', '-')}: {name} is not among "
                             f"--analyses {','.join(args.analyses)}")
        settings.setdefault(name, {})[option] = value
    return settings


def register(subparsers):
    """Add the `sweep` subcommand."""
    parser = subparsers.add_parser(
        "sweep", help="a design sweep: analyses over a grid of scene values, on Dask",
        description="Evaluate the analyses of a scene at every point of a grid of scene "
                    "values (the Cartesian product of the --param values) on dask.distributed "
                    "(a local cluster of this machine's cores, or --scheduler), and write one "
                    "row per point to CSV (and Parquet when pyarrow is importable) with a plot "
                    "of each quantity. A point that fails gives its reason in the status "
                    "column; the others go on.")
    add_scene_arguments(parser)
    parser.add_argument("--param", type=parameter, action="append", required=True,
                        metavar="KEY=START:STOP:N|KEY=V1,V2,...",
                        help="a dotted scene key and its values: N linearly spaced from START "
                             "to STOP, or a list (repeatable; the grid is the product)")
    parser.add_argument("--tie", action="append", default=[], metavar="KEY=EXPRESSION",
                        help="set KEY at every point from --param keys: another key "
                             "(elements.wire2.segments=elements.wire1.segments) or arithmetic "
                             "of them and numbers with + - * / and brackets "
                             "(sections.leaf.width=36*sections.leaf.height); repeatable")
    parser.add_argument("--stroke-inputs", type=name_list, metavar="NAME[,NAME...]",
                        help="the inputs that drive the stroke.NODE.AXIS parameters, as many "
                             "(default: the scene's inputs)")
    parser.add_argument("--analyses", type=analysis_list, default=("static", "modes"),
                        metavar="LIST",
                        help=f"some of {','.join(analysis_names())} (default static,modes)")
    parser.add_argument("--modes", type=count, default=DEFAULT_MODES, metavar="N",
                        help=f"the lowest N natural frequencies (default {DEFAULT_MODES})")
    parser.add_argument("--out", type=output_file((".csv",)), metavar="CSV",
                        help="the table (default: SCENE_NAME_sweep.csv here); the Parquet "
                             "file and the plot get its name with .parquet and .png")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=number(0, integer=True, low_open=False), metavar="N",
                       help=f"processes of the local Dask cluster (default: the cores, here "
                            f"{default_workers()}); 0 runs in this process")
    where.add_argument("--serial", action="store_const", const=0, dest="workers",
                       help="run in this process, one point after the other (--workers 0)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on the workers of this Dask scheduler (e.g. "
                            "tcp://host:8786), which need flexure installed")
    parser.add_argument("--resume", action="store_true",
                        help="keep the rows the --out table has, and compute only the other "
                             "points")
    parser.add_argument("--no-plot", action="store_true", help="write no plot")
    add_analysis_options(parser)
    parser.set_defaults(run=run)


def run(args):
    from ..scene.building import build_model, parse_toml, scene_path

    keys = [key for key, _ in args.param]
    for key in keys:
        if keys.count(key) > 1:
            raise UsageError(f"--param {key}: given {keys.count(key)} times; give each key once")
        if key in args.set:
            raise UsageError(f"--param {key}: also given to --set; a key is either swept or "
                             "set")
    ties = [parse_tie(text, keys) for text in args.tie]
    tied = [tie.key for tie in ties]
    for key in tied:
        if tied.count(key) > 1:
            raise UsageError(f"--tie {key}: given {tied.count(key)} times; tie each key once")
        if key in args.set:
            raise UsageError(f"--tie {key}: also given to --set; a key is either tied or set")
    path = scene_path(args.scene)
    data = parse_toml(path)
    # the scene and its fixed overrides must stand on their own: a mistake there is one
    # error now, not the same failure in every row
    model = build_model(data, overrides=args.set, source=str(path), default_name=path.stem)
    out = args.out or output_file((".csv",))(f"{model.name}_sweep.csv")
    parquet = _parquet_path(out)
    plot = None if args.no_plot else check_output(out.with_suffix(".png"),
                                                  suffixes=PLOT_SUFFIXES, option="the plot")
    refuse_overwriting_inputs([("--out", out), ("the Parquet file", parquet),
                               ("the plot", plot)], [path])
    settings = analysis_settings(args)
    strokes = [key.removeprefix(STROKE) for key in keys if key.startswith(STROKE)]
    if strokes:
        check_strokes(model, strokes, args.stroke_inputs)
    elif args.stroke_inputs:
        raise UsageError("--stroke-inputs: no --param stroke.NODE.AXIS to drive")
    table = SweepTable(keys + tied, columns(model, args.analyses, args.modes, settings,
                                            strokes, args.stroke_inputs),
                       units={key: parameter_unit(key, model) for key in keys + tied})
    points = tie_points(grid(args.param), ties)
    earlier, unreadable = table.read(out) if args.resume and out.exists() else ({}, 0)
    todo = [i for i, point in enumerate(points) if table.key(point) not in earlier]
    finished = {}
    progress = Progress("flexure sweep", after=1.0)
    start = time.perf_counter()
    # the rows kept so far, then each new one as it comes: an interrupted sweep loses no point
    # it finished, and --resume takes it from there. The file is touched at the first new row
    # only, so a run that fails to start (an unreachable --scheduler) leaves it as it was.
    appending = []

    def on_row(index, row):
        if not appending:
            with atomic_output(out, "--out") as temporary:
                table.write_csv(temporary, list(earlier.values()))
            appending.append(open(out, "a", newline=""))  # closed after the run
        point = points[todo[index]]
        finished[table.key(point)] = table.cells(point, row)
        table.append(appending[0], finished[table.key(point)])
        progress(len(finished) / len(todo))

    try:
        run_sweep(data, [points[i] for i in todo], overrides=args.set, analyses=args.analyses,
                  modes=args.modes, source=str(path), default_name=path.stem,
                  workers=args.workers, scheduler=args.scheduler, on_row=on_row,
                  settings=settings, stroke_inputs=args.stroke_inputs)
    finally:
        for handle in appending:
            handle.close()
    wall = time.perf_counter() - start
    every = {**earlier, **finished}
    in_grid = [table.key(point) for point in points]
    outside = set(earlier) - set(in_grid)  # kept, after the grid's rows
    rows = [every[key] for key in in_grid] + [earlier[key] for key in earlier if key in outside]
    outputs = [("--out", out, lambda t: table.write_csv(t, rows))]
    if parquet is not None:
        outputs.append(("the Parquet file", parquet, lambda t: table.write_parquet(t, rows)))
    if plot is not None:
        outputs.append(("the plot", plot, lambda t: table.plot(t, rows, _title(model, args))))
    print(render(table, rows, points=len(points), computed=len(todo), unreadable=unreadable,
                 wall=wall, where=_where(args)))
    code = write_outputs("flexure sweep", outputs)
    failed = [row for row in rows if row[-1] != "ok"]
    if rows and len(failed) == len(rows):
        raise FlexureError(f"sweep {model.name}: every point failed ({len(rows)}); first: "
                           f"{failed[0][-1]}")
    return code


def parameter_unit(key, model):
    """The SI unit of a swept or tied scene key ("" where the scene format gives none: a
    type, a name)."""
    from ..analysis.sensitivity import LIST_UNITS
    from ..scene.building import scene_key

    if key.startswith(STROKE):  # a displacement of a coordinate or a global angle
        from ..mechanics.ports import position_port

        try:
            return position_port(model, key.removeprefix(STROKE)).unit
        except KeyError:
            return ""
    schema = scene_key(key, model)
    if schema is not None:
        return schema.unit
    return LIST_UNITS.get(key.rpartition(".")[2], "")


def _parquet_path(out):
    """Where the Parquet table goes, or None without pyarrow."""
    try:
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        return None
    return check_output(out.with_suffix(".parquet"), option="the Parquet file")


def _where(args):
    if args.scheduler is not None:
        return f"the Dask scheduler {args.scheduler}"
    if args.workers == 0:
        return "this process"
    workers = args.workers or default_workers()
    return f"a local Dask cluster of {workers} process{'es' if workers > 1 else ''}"


def _title(model, args):
    return model.name + "".join(f"  {key}={value}" for key, value in args.set.items())


def render(table, rows, *, points, computed, unreadable, wall, where):
    """What was done, and the failed points with their reasons (the first ten)."""
    failed = [row for row in rows if row[-1] != "ok"]
    summary = [("points", points), ("computed now", computed),
               ("kept from the table", points - computed), ("ok", len(rows) - len(failed)),
               ("failed", len(failed)), ("run on", where), ("wall time (s)", f"{wall:.3g}")]
    if unreadable:
        summary.insert(3, ("unreadable rows computed again", unreadable))
    parts = [format_table(["sweep", "value"], summary)]
    if failed:
        n = len(table.parameters)
        parts.append(format_table(
            [*table.parameters, "status"],
            [[*row[:n], row[-1]] for row in failed[:10]],
            title="\nfailed points" + (f" (the first 10 of {len(failed)})"
                                       if len(failed) > 10 else "")))
    return "\n".join(parts)
