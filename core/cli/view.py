"""`flexure view SCENE`: an interactive 3-D view of a scene in one self-contained HTML file.

    flexure view manipulator --modes 10              # the ten lowest modes, animated
    flexure view stage_planar_3dof --static -o stage.html
    flexure simulate stage_planar_3dof --t-end 0.5 --input F=1 --dofs run.csv
    flexure view stage_planar_3dof --simulation run.csv

The page (`reporting.html_view`) opens offline in any browser: the model's centre lines,
its nodes (names on hover), the fixed coordinates marked, each mode animated, the static
deformed shape, a simulated motion with a time slider, and a magnification slider.
"""

from pathlib import Path

from ..errors import UsageError
from . import add_scene_arguments, check_output, count, write_text

DEFAULT_MODES = 6  # the modes shown when no option says what to show


def register(subparsers):
    """Add the `view` subcommand."""
    parser = subparsers.add_parser(
        "view", help="an interactive 3-D view in the browser: modes, static shape, motion",
        description="Write one self-contained HTML page (it opens offline) of a scene: the "
                    "elements' centre lines, the nodes (names on hover), the fixed "
                    "coordinates, and the shapes asked for, each with a magnification "
                    "slider. Without --modes, --static or --simulation: --static and the "
                    f"lowest {DEFAULT_MODES} modes.")
    add_scene_arguments(parser)
    parser.add_argument("--modes", type=count, metavar="N",
                        help="animate the lowest N mode shapes (at the static equilibrium "
                             "under the scene's loads, as `flexure analyze --modes`)")
    parser.add_argument("--static", action="store_true",
                        help="the deformed shape of the static equilibrium under the loads")
    parser.add_argument("--simulation", metavar="CSV", type=Path,
                        help="a simulated motion with a time slider: the CSV of the DOFs over "
                             "time that `flexure simulate ... --dofs CSV` writes")
    parser.add_argument("-o", "--output", metavar="HTML",
                        help="the page to write (default: the scene's name .html, here)")
    parser.set_defaults(run=run)


def run(args):
    """Run `flexure view` on `args`; returns the exit code."""
    from ..analysis.pictures import require_drawable
    from ..analysis.view_data import view_data
    from ..reporting.html_view import view_page
    from ..scene.building import load_scene
    from ..simulation.dof_csv import read_dof_csv

    output = args.output or f"{Path(args.scene).stem}.html"
    check_output(output, suffixes=(".html", ".htm"), option="-o")
    if args.simulation is not None and not args.simulation.is_file():
        raise UsageError(f"--simulation {args.simulation}: no such file")
    model = load_scene(args.scene, overrides=args.set)
    require_drawable(model, "view")
    static, modes = args.static, args.modes
    if not (static or modes or args.simulation):
        # as `flexure analyze`: a kinematic model (no mass, no load) has no shape but its own
        from .analyze import is_kinematic

        static, modes = (False, None) if is_kinematic(model) else (True, DEFAULT_MODES)
    times = q = None
    if args.simulation is not None:  # the file is checked before any analysis runs
        times, q = read_dof_csv(args.simulation, model)
    data = view_data(model, modes=modes, static=static, times=times, q=q,
                     source=str(args.simulation or ""))
    page = view_page(data)
    write_text(output, page, "-o")
    shown = ", ".join(shape.label for shape in data.shapes) or "the undeformed model"
    print(f"wrote {output} ({len(page.encode()) / 1e6:.1f} MB; {shown}): open it in a browser")
    return 0
