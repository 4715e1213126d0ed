"""`flexure fmu build SCENE -o NAME.fmu`, `flexure fmu env`, `check` and `doctor`.

    flexure fmu build stage_planar_3dof -o stage.fmu [--tunable sections.leaf.EdA ...]
    flexure fmu env [--json | --env]      # what a JVM / Rust / C host needs
    flexure fmu check NAME.fmu NAME_in.csv NAME_ref.csv [--update]   # regression test
    flexure fmu doctor NAME.fmu [--native] [--json]   # can this Python host the FMU?
"""

import os
import shutil
import tempfile
from pathlib import Path

from flexure.core import FlexureError
from flexure.core.cli import (
    add_scene_arguments,
    check_output,
    nonnegative,
    number,
    positive,
    refuse_overwriting_inputs,
)
from flexure.core.errors import OutputError, UsageError

from .builder import build_scene_fmu, default_tunable
from .env import fmu_environment, format_environment
from .regression import DEFAULT_ATOL, DEFAULT_INTERVAL, DEFAULT_RTOL, check_fmu, write_reference


def register(subparsers):
    """Add the `fmu` command (entry point of the group "flexure.commands")."""
    parser = subparsers.add_parser(
        "fmu", help="build a scene's FMI 2.0 co-simulation FMU; print a host's environment",
        description="Build FMI 2.0 co-simulation FMUs of scenes (pythonfmu).")
    commands = parser.add_subparsers(dest="fmu_command", metavar="ACTION", required=True)

    build = commands.add_parser("build", help="build the FMU of a scene",
                                description="Build the co-simulation FMU of a scene; its model "
                                            "identifier is the scene name.")
    add_scene_arguments(build)
    build.add_argument("-o", "--output", help="the .fmu to write (default: SCENE_NAME.fmu)")
    build.add_argument("--tunable", action="append", metavar="KEY",
                       help="a dotted scene key to expose as a parameter (repeatable; default: "
                            "the damping EdA/EdI of the sections and the node masses)")
    build.add_argument("--no-tunable", action="store_true",
                       help="expose no scene keys (only the integrator parameters)")
    build.add_argument("--von-mises", action="store_true",
                       help="add the output von_mises_max (Pa): the largest von Mises stress "
                            "at the beam ends (beams and trusses whose section gives its "
                            "dimensions)")
    build.add_argument("--no-validate", action="store_true",
                       help="skip fmpy's validation of the result")
    build.add_argument("--no-engine", action="store_true",
                       help="leave the compiled engine out (a host then compiles it at its "
                            "first instantiation; default: it is compiled for a portable CPU "
                            "target and carried, unless FLEXURE_FMU_ENGINE=0)")
    build.set_defaults(run=run_build)

    env = commands.add_parser("env", help="print the environment a non-Python host needs",
                              description="Print LD_PRELOAD, PYTHONHOME and PYTHONPATH for a "
                                          "JVM, Rust or C host of flexure's FMUs.")
    style = env.add_mutually_exclusive_group()
    style.add_argument("--json", action="store_const", const="json", dest="style")
    style.add_argument("--env", action="store_const", const="env", dest="style",
                       help="one line of NAME=VALUE for `env ... host`")
    env.set_defaults(run=run_env, style="sh")

    check = commands.add_parser(
        "check", help="regression-test an FMU against a reference CSV (FMI cross-check style)",
        description="Simulate FMU with fmpy driven by INPUT_CSV on the grid of REFERENCE_CSV "
                    "and compare: |y - y_ref| <= rtol * range(y_ref) + atol at every sample.")
    check.add_argument("fmu")
    check.add_argument("input_csv")
    check.add_argument("reference_csv")
    check.add_argument("--rtol", type=number(0.0, 1.0, low_open=False), default=DEFAULT_RTOL,
                       help=f"of each signal's range (default {DEFAULT_RTOL:g})")
    check.add_argument("--atol", type=nonnegative, default=DEFAULT_ATOL,
                       help=f"absolute (default {DEFAULT_ATOL:g})")
    check.add_argument("--update", action="store_true",
                       help="write the reference instead of checking against it")
    check.add_argument("--interval", type=positive, default=DEFAULT_INTERVAL,
                       help="communication step of a reference written with --update (s)")
    check.set_defaults(run=run_check)

    doctor = commands.add_parser(
        "doctor", help="check that this Python can host an FMU: its requirements, platform, "
                       "binary",
        description="Check this Python as a host of FMU: its platform among the FMU's "
                    "binaries, the Python version and each package of the FMU's "
                    "requirements (resources/requirements.txt) importable at a version it "
                    "works with, the pythonfmu binary loadable, and what a non-Python host "
                    "needs (flexure fmu env). Prints one row per check and a fix per problem; "
                    "exit code 0 when every check passes, 1 when one fails.")
    doctor.add_argument("fmu")
    doctor.add_argument("--native", action="store_true",
                        help="fail, not warn, when a JVM, Rust or C host could not run it "
                             "(no shared libpython, a package off `flexure fmu env`'s path)")
    doctor.add_argument("--json", action="store_true", help="the rows as JSON")
    doctor.set_defaults(run=run_doctor)


def run_build(args):
    from flexure.core.scene.building import parse_toml, scene_path

    if args.no_tunable and args.tunable:  # which was meant: these keys, or none?
        raise UsageError(f"--no-tunable and --tunable {args.tunable[0]}: give one, --tunable "
                         "KEY for those keys or --no-tunable for none")
    tunable = [] if args.no_tunable else args.tunable
    for key in set(tunable or []):
        if tunable.count(key) > 1:
            raise UsageError(f"--tunable {key}: given {tunable.count(key)} times; give each "
                             "key once")
    output = args.output
    if output is not None and not Path(output).is_dir():
        check_output(output, suffixes=(".fmu",), option="-o")
    folder = Path(output) if output is not None and Path(output).is_dir() else (
        Path(output).parent if output is not None else Path("."))
    if output is None or Path(output).is_dir():
        check_output(folder / "scene.fmu", option="-o" if output else "the current folder")
    source = scene_path(args.scene)
    data = parse_toml(source)  # a SceneError for invalid bytes or TOML, before the build
    outputs = data.get("outputs")
    if args.von_mises and isinstance(outputs, dict) and "von_mises_max" in outputs:
        raise UsageError(f"{source}: outputs.von_mises_max: --von-mises adds an output of that "
                         "name; rename the scene's output")
    refuse_overwriting_inputs([("-o", output)], [source])
    # built in a temporary folder beside the destination, then moved in one step: a failed
    # build or validation leaves no file, and never half of one
    try:
        temporary = tempfile.mkdtemp(dir=folder, prefix=".flexure_fmu_")
    except OSError as error:
        raise OutputError(f"-o {output or '.'}: cannot write in {folder}: "
                          f"{error.strerror}") from None
    try:
        built = build_scene_fmu(source, temporary, tunable=tunable, von_mises=args.von_mises,
                                validate=not args.no_validate, overrides=args.set,
                                engine=False if args.no_engine else None)
        path = (folder / built.name if output is None or Path(output).is_dir()
                else Path(output))
        if path.is_dir():
            raise UsageError(f"-o {output or '.'}: {path} is a folder; expected a file name")
        try:
            os.replace(built, path)
        except OSError as error:
            raise OutputError(f"{path}: cannot write: {error.strerror}") from None
    finally:
        shutil.rmtree(temporary, ignore_errors=True)
    print(path)
    return 0


def run_check(args):
    needed = [args.fmu, args.input_csv] + ([] if args.update else [args.reference_csv])
    for path in needed:
        if not Path(path).is_file():
            raise FlexureError(f"{path}: " + ("not a file" if Path(path).exists()
                                              else "no such file"))
    if args.update:
        check_output(args.reference_csv, option="REFERENCE_CSV")
        refuse_overwriting_inputs([("REFERENCE_CSV", args.reference_csv)],
                                  [args.fmu, args.input_csv])
        path = write_reference(args.fmu, args.input_csv, args.reference_csv,
                               output_interval=args.interval)
        print(f"wrote {path}")
        return 0
    problems = check_fmu(args.fmu, args.input_csv, args.reference_csv, rtol=args.rtol,
                         atol=args.atol)
    for problem in problems:
        print(f"{args.fmu}: {problem}")
    if not problems:
        print(f"{args.fmu}: matches {args.reference_csv}")
    return 1 if problems else 0


def run_doctor(args):
    from flexure.core.reporting.tables import format_table, print_json

    from .doctor import as_dicts, diagnose, failed

    rows = diagnose(args.fmu, native=args.native)
    if args.json:
        print_json({"fmu": args.fmu, "passed": not failed(rows), "checks": as_dicts(rows)},
                   command="flexure fmu doctor")
        return 1 if failed(rows) else 0
    print(format_table(["check", "status", "found"],
                       [(row.check, row.status, row.found) for row in rows]))
    problems = [row for row in rows if row.fix]
    if problems:
        print("\nto fix:")
        for row in problems:
            print(f"  {row.check} ({row.status}): {row.fix}")
    count = sum(row.status not in ("OK", "WARN") for row in rows)
    print(f"\n{args.fmu}: " + (f"{count} of {len(rows)} checks failed" if count else
                                f"every check passed ({len(rows)})"))
    return 1 if failed(rows) else 0


def run_env(args):
    print(format_environment(fmu_environment(), style=args.style))
    return 0


__all__ = ["register", "default_tunable"]
