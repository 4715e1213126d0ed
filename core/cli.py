"""The `flexure` command: a dispatcher over subcommands.

Subcommands register themselves through the entry-point group "flexure.commands" (see
pyproject.toml): each entry is a function `register(subparsers)` that adds one parser and
sets `run=function(args) -> exit code`. That keeps `core` free of imports of `fmu` and
`controllers`, whose commands live beside their code.

A FlexureError (a user's mistake or a failed computation) is printed as one clear message and
exit code 2, never as a traceback.
"""

import argparse
import importlib.metadata
import sys

from .errors import FlexureError


def build_parser():
    """The argument parser with every installed subcommand."""
    parser = argparse.ArgumentParser(
        prog="flexure",
        description="Flexible multibody models of compliant mechanisms (SPACAR style).",
    )
    from . import __version__

    parser.add_argument("--version", action="version", version=f"flexure {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    entries = importlib.metadata.entry_points(group="flexure.commands")
    for entry in sorted(entries, key=lambda e: e.name):
        entry.load()(subparsers)
    return parser


def main(argv=None):
    """Run the `flexure` command line; returns the exit code."""
    parser = build_parser()
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


if __name__ == "__main__":
    sys.exit(main())
