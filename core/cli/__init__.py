"""The `flexure` command: a dispatcher over subcommands.

Subcommands register themselves through the entry-point group "flexure.commands" of
flexure's own distribution (pyproject.toml; read from its entry_points.txt, `entry_points_of`): each
entry is a function `register(subparsers)` that adds one parser and sets
`run=function(args) -> exit code`. That keeps `core` free of imports of `fmu` and
`controllers`, whose commands live beside their code.

A FlexureError (a user's mistake or a failed computation) is printed as one clear message and
exit code 2, never as a traceback.
"""

import argparse
import contextlib
import importlib
import math
import os
import sys
import tempfile
from pathlib import Path

from ..errors import FlexureError, OutputError, UsageError


def build_parser(argv=None):
    """The argument parser with the installed subcommands.

    When `argv` names a subcommand, only that one is registered: importing every command's
    module (the loop's pulls in scipy.interpolate and the co-simulation) would cost a
    short command such as `flexure analyze` half its run time. Without one (help, a
    mistyped name) every subcommand is registered, so argparse lists them all.
    """
    parser = argparse.ArgumentParser(
        prog="flexure",
        description="Flexible multibody models of compliant mechanisms (SPACAR style).",
    )
    from .. import __version__

    parser.add_argument("--version", action="version", version=f"flexure {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    entries = entry_points_of("flexure.commands")
    named = next((word for word in (argv or []) if not word.startswith("-")), None)
    chosen = [entry for entry in entries if entry[0] == named] or entries
    for _, value in sorted(chosen):
        module, _, attribute = value.partition(":")
        getattr(importlib.import_module(module), attribute)(subparsers)
    return parser


def entry_points_of(group):
    """(name, "module:attribute") of the entry points of `group` that flexure's distribution
    declares: read from its metadata's entry_points.txt, the first copy on sys.path (as the
    import system finds the package), else through importlib.metadata (which imports email,
    zipfile and csv: 0.03 to 0.04 s of CPU, a tenth of a short command)."""
    for folder in sys.path:
        try:
            names = sorted(os.listdir(folder or "."))
        except OSError:
            continue
        for name in names:
            lowered = name.lower()
            if lowered == "flexure.egg-info" or (lowered.startswith("flexure-")
                                                 and lowered.endswith(".dist-info")):
                try:
                    with open(os.path.join(folder or ".", name, "entry_points.txt")) as handle:
                        return entry_points_section(handle.read(), group)
                except OSError:
                    continue
    import importlib.metadata

    return [(entry.name, entry.value) for entry in importlib.metadata.entry_points(group=group)]


def entry_points_section(text, group):
    """The (name, value) lines of the section [group] of an entry_points.txt (INI)."""
    found, inside = [], False
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("["):
            inside = line == f"[{group}]"
        elif inside and "=" in line and not line.startswith(("#", ";")):
            name, value = line.split("=", 1)
            found.append((name.strip(), value.strip()))
    return found


def main(argv=None):
    """Run the `flexure` command line; returns the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    if not getattr(args, "run", None):
        parser.print_help()
        return 1
    try:
        return args.run(args) or 0
    except FlexureError as error:
        print(f"flexure {args.command}: error: {error}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `flexure analyze ... | head`
        sys.stderr.close()
        return 0
    except KeyboardInterrupt:
        print(f"flexure {args.command}: interrupted", file=sys.stderr)
        return 130


# -- option values: argparse `type=` validators with messages that say what is expected -------

def number(low=None, high=None, *, low_open=True, high_open=True, integer=False):
    """An argparse type: a finite number (an int when `integer`) in the given range.

    `low`/`high` bound it (None: unbounded), open or closed: number(0, 1) is (0, 1),
    number(1, integer=True, low_open=False) an integer >= 1.
    """
    kind = "an integer" if integer else "a number"
    bounds = []
    if low is not None:
        bounds.append(f"{'>' if low_open else '>='} {low:g}")
    if high is not None:
        bounds.append(f"{'<' if high_open else '<='} {high:g}")
    if low is not None and high is not None:
        expected = (f"{kind} in {'(' if low_open else '['}{low:g}, {high:g}"
                    f"{')' if high_open else ']'}")
    else:
        expected = f"{kind} {bounds[0]}" if bounds else f"a finite {kind[2:].strip()}"

    def parse(text):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        if low is not None and (value < low or (low_open and value == low)):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        if high is not None and (value > high or (high_open and value == high)):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        return value

    parse.__name__ = expected  # argparse names the type in some messages
    return parse


positive = number(0.0)
nonnegative = number(0.0, low_open=False)
fraction = number(0.0, 1.0)  # a relative tolerance: in (0, 1)
count = number(1, integer=True, low_open=False)  # a count: an integer >= 1

PLOT_SUFFIXES = (".png", ".pdf", ".svg")


class _SetOption(argparse.Action):
    """`--set KEY=VALUE`, repeatable: collects {key: value} (`overrides.parse_assignment`),
    refusing a key given twice (which value was meant?)."""

    def __call__(self, parser, namespace, text, option_string=None):
        from ..scene.overrides import parse_assignment

        try:
            key, value = parse_assignment(text)
        except ValueError as error:
            raise argparse.ArgumentError(self, str(error)) from None
        overrides = dict(getattr(namespace, self.dest) or {})  # never the shared default
        if key in overrides:
            raise argparse.ArgumentError(self, f"{key} is given twice; give each key once")
        overrides[key] = value
        setattr(namespace, self.dest, overrides)


def add_scene_arguments(parser, *, default=None):
    """Add what a command that works on a scene takes: the positional SCENE (a scene file or a
    built-in scene's name; optional when a `default` name is given) and `--set KEY=VALUE`
    (repeatable).

    `args.set` is then {dotted scene key: value} for `load_scene(..., overrides=args.set)`
    (flexure.core.scene.overrides): VALUE is read as TOML (0.3e-3, [0, 1], "text", true), else taken
    as a string."""
    if default is None:
        parser.add_argument("scene", help="scene file or built-in scene name")
    else:
        parser.add_argument("scene", nargs="?", default=default,
                            help=f"scene file or built-in scene name (default {default})")
    parser.add_argument("--set", action=_SetOption, default={}, metavar="KEY=VALUE",
                        help="set a scene value before the scene is built and checked, e.g. "
                             "--set sections.leaf.height=0.3e-3 --set nodes.3.mass=0.2 "
                             "(repeatable; VALUE is TOML, SI units)")


def output_file(suffixes=None):
    """An argparse type: a file to write, checked now (see `check_output`), as a Path."""
    def parse(text):
        try:
            return check_output(text, suffixes=suffixes)
        except UsageError as error:
            raise argparse.ArgumentTypeError(str(error)) from None

    parse.__name__ = "output file"
    return parse


def check_output(path, *, suffixes=None, option=None):
    """The Path `path` if a result can be written there; UsageError saying why not.

    Checked before any long run: the folder exists and is a writable directory (and its
    file system is not full), the path is not a folder or a device, and, for `suffixes`,
    it ends in one of them (matplotlib would otherwise add its own, and write a file of
    another name).
    """
    where = f"{option} {path}" if option else str(path)
    path = Path(path)
    if not str(path) or path.name in ("", ".", ".."):
        raise UsageError(f"{where}: expected a file name")
    if path.is_dir():
        raise UsageError(f"{where}: is a folder; expected a file name")
    if path.exists() and not path.is_file():
        raise UsageError(f"{where}: exists and is not a regular file (a device or a pipe); "
                         "expected a file name")
    if suffixes and path.suffix.lower() not in suffixes:
        found = f"not {path.suffix!r}" if path.suffix else "it has none"
        raise UsageError(f"{where}: expected a file name ending in {' or '.join(suffixes)} "
                         f"({found}; no extension is added or changed)")
    folder = path.parent
    if not folder.is_dir():
        blocker = _first_file(folder)
        if blocker is not None:
            raise UsageError(f"{where}: {blocker} is a file, not a folder")
        raise UsageError(f"{where}: the folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError(f"{where}: the folder {folder} is not writable")
    try:
        if os.statvfs(folder).f_bavail == 0:
            raise UsageError(f"{where}: the file system of {folder} is full")
    except (AttributeError, OSError):  # no statvfs (Windows), or a file system without it
        pass
    return path


def _first_file(folder):
    """The first part of `folder` that is a file (why a path under it cannot exist)."""
    for part in reversed([folder, *folder.parents]):
        if part.exists() and not part.is_dir():
            return part
    return None


def distinct_outputs(*pairs):
    """UsageError if two options name the same output file: pairs (option, path or None)."""
    seen = {}
    for option, path in pairs:
        if path is None:
            continue
        key = os.path.realpath(path)
        if key in seen:
            raise UsageError(f"{option} {path}: the same file as {seen[key]}; give each "
                             "output its own file")
        seen[key] = f"{option} {path}"


@contextlib.contextmanager
def atomic_output(path, option=None):
    """Write a result to `path` atomically: yields a temporary path in the same folder (same
    suffix), which replaces `path` only when the block succeeds. An OSError (disk full,
    permissions changed meanwhile) becomes an OutputError naming the file."""
    path = Path(path)
    where = f"{option} {path}" if option else str(path)
    try:
        handle, temporary = tempfile.mkstemp(dir=path.parent or ".", prefix=f".{path.stem}.",
                                             suffix=path.suffix)
        os.close(handle)
    except OSError as error:
        raise OutputError(f"{where}: cannot write: {error.strerror}") from None
    try:
        yield temporary
        os.chmod(temporary, _file_mode(path))
        os.replace(temporary, path)
    except OSError as error:
        raise OutputError(f"{where}: cannot write: {error.strerror or error}") from None
    finally:
        with contextlib.suppress(OSError):
            os.unlink(temporary)


def _file_mode(path):
    """The mode a new file gets (0o666 less the umask), or that of the file it replaces."""
    try:
        return os.stat(path).st_mode & 0o7777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def write_outputs(command, outputs, *, announce=True):
    """Write each result, atomically; returns the exit code (2 if any could not be written).

    `outputs` holds (option, path or None, write(temporary_path)). A file that cannot be
    written is reported and the others are still written, so one bad path loses no more.
    """
    failed = False
    for option, path, write in outputs:
        if path is None:
            continue
        try:
            with atomic_output(path, option) as temporary:
                write(temporary)
        except OutputError as error:
            print(f"{command}: error: {error}", file=sys.stderr)
            failed = True
        else:
            if announce:
                print(f"wrote {path}")
    return 2 if failed else 0


def refuse_overwriting_inputs(outputs, inputs):
    """UsageError if an output (option, path) would overwrite an input file (scene, CSV)."""
    for option, path in outputs:
        if path is None or not Path(path).exists():
            continue
        for source in inputs:
            with contextlib.suppress(OSError):
                if source is not None and os.path.samefile(path, source):
                    raise UsageError(f"{option} {path}: is an input of this run ({source}); "
                                     "write the result to another file")


def write_text(path, text, option=None):
    """Write `text` to `path` atomically (see `atomic_output`)."""
    with atomic_output(path, option) as temporary:
        Path(temporary).write_text(text)


if __name__ == "__main__":
    sys.exit(main())
