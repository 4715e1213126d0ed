"""The README is a front door that works: its commands run, its links resolve, it stays short.

- Every line of the README's shell blocks (```bash, ```sh) is a `flexure ...` or `python ...`
  command, and each is run: `flexure` in-process through the CLI entry point
  (`flexure.core.cli.main`), `python` as a subprocess of this interpreter. The commands of one
  block run in order in one temporary folder (a later command may read what an earlier one
  wrote: `fmu check stage.fmu`); an argument naming a file of the repository
  (`examples/scenes/...`) is given its absolute path. The two set-up lines at the top
  (a new venv and `pip install`) are CI's (.ci/run runs the one ending in `# the tests`); here
  they are only checked to be there, unchanged.
- A shell block of one command followed by a plain block shows that command's output: the
  output must match it (numbers to 1e-3, tracking errors to 10 %, wall times not compared).
- Every ```python block runs, in a temporary folder.
- Every relative link of README.md and docs/*.md points to an existing file (and an anchor to
  a heading of it), and the README links every page of docs/.

The whole file takes about 20 s with the compiled engine cached; after a change of core's
sources the first command compiles the engine again (tens of seconds).
"""

import math
import os
import re
import shlex
import sys
from pathlib import Path

import children
import pytest

from flexure.core.cli import main as flexure_main

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
DOCS = REPO / "docs"
MAX_LINES = 300

# CI evaluates the second line (.ci/run); the first is what a newcomer types first.
SETUP_LINES = (
    "python3 -m venv .venv && .venv/bin/pip install . && .venv/bin/flexure loop"
    "              # the closed-loop demo",
    "python3 -m venv .venv && .venv/bin/pip install \".[test]\" && .venv/bin/pytest -q -n auto"
    " # the tests",
)
SHELL = {"bash", "sh", "shell", "console"}
PYTHON = {"python", "python3"}


def code_blocks(path):
    """The fenced code blocks of a markdown file: (language, first line number, lines)."""
    blocks, current = [], None
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        fence = re.match(r"^\s*```\s*([\w+-]*)\s*$", line)
        if current is None and fence:
            current = (fence.group(1).lower(), number + 1, [])
        elif current is not None and re.match(r"^\s*```\s*$", line):
            blocks.append(current)
            current = None
        elif current is not None:
            current[2].append(line)
    assert current is None, f"{path.name}: a code block opened on line {current[1] - 1} " \
                            "is not closed"
    return blocks


def shell_commands(lines):
    """The command lines of a shell block, continuation lines joined, comments and blanks
    dropped."""
    commands, pending = [], ""
    for line in lines:
        if line.rstrip().endswith("\\"):
            pending += line.rstrip()[:-1] + " "
            continue
        line, pending = pending + line, ""
        if line.strip() and not line.lstrip().startswith("#"):
            commands.append(line.strip())
    return commands


def readme_shell_blocks():
    """(block id, commands, expected output or None) for every README shell block with a
    command to run."""
    blocks = code_blocks(README)
    found = []
    for i, (language, line, lines) in enumerate(blocks):
        if language not in SHELL:
            continue
        commands = [c for c in shell_commands(lines) if c not in SETUP_LINES]
        if not commands:
            continue
        following = blocks[i + 1] if i + 1 < len(blocks) else None
        output = None
        if len(commands) == 1 and following and following[0] == "" and \
                following[1] <= line + len(lines) + 4:  # right after it: its output
            output = following[2]
        found.append((f"README.md:{line}", commands, output))
    return found


def argv_of(command):
    """The words of a command, a path into the repository made absolute."""
    words = shlex.split(command, comments=True)
    return [word if word.startswith("-") or "/" not in word or not (REPO / word).exists()
            else str(REPO / word) for word in words]


def run_command(command, capsys):
    """Run one README command in the current folder; returns its standard output."""
    argv = argv_of(command)
    if argv[0] == "flexure":
        capsys.readouterr()
        try:
            code = flexure_main(argv[1:])
        except SystemExit as exit_:  # argparse's errors and --help
            code = exit_.code
        out, err = capsys.readouterr()
        assert code == 0, f"`{command}` exited with {code}:\n{err[-2000:]}"
        return out
    if argv[0] in PYTHON:
        done = children.run([sys.executable, *argv[1:]], capture_output=True, text=True,
                            timeout=120, env={**os.environ, "MPLBACKEND": "Agg"})
        assert done.returncode == 0, \
            f"`{command}` exited with {done.returncode}:\n{done.stderr[-2000:]}"
        return done.stdout
    raise AssertionError(f"README shell line `{command}`: this test runs only `flexure ...` "
                         "and `python ...` commands; show other commands in docs/")


NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def assert_output_matches(expected_lines, actual, command):
    """Each line shown in the README appears in the output, its words equal and its numbers
    close (1e-3; a line about an error 10 %: integration error, not design); wall times are
    the machine's."""
    actual_lines = [line.rstrip() for line in actual.splitlines() if line.strip()]
    shown = [line.rstrip() for line in expected_lines if line.strip()]
    assert len(actual_lines) == len(shown), \
        f"`{command}` printed {len(actual_lines)} lines, the README shows {len(shown)}:\n{actual}"
    for want, got in zip(shown, actual_lines, strict=True):
        assert NUMBER.sub("#", want).split() == NUMBER.sub("#", got).split(), \
            f"`{command}`: the README shows\n  {want}\nthe command prints\n  {got}"
        if "wall time" in want:
            continue
        tolerance = 0.1 if "error" in want else 1e-3
        for a, b in zip(NUMBER.findall(want), NUMBER.findall(got), strict=True):
            assert math.isclose(float(a), float(b), rel_tol=tolerance, abs_tol=0.0), \
                f"`{command}`: the README shows\n  {want}\nthe command prints\n  {got}"


# -- the commands -------------------------------------------------------------------------------
def test_the_setup_lines_are_there_unchanged():
    lines = README.read_text().splitlines()
    for setup in SETUP_LINES:
        assert setup in lines, f"README.md lost its set-up line:\n{setup}"
    assert sum(line.endswith("# the tests") for line in lines) == 1  # .ci/run's grep


# Blocks with one of these run in the slow tier: the 507-DOF manipulator (7 s), the tour
# that builds an FMU and benchmarks the methods (13 s of CPU; each of its analyses is also run
# by tests/test_cli_analyze.py in the default tier), and the design study on a local Dask
# cluster (5 s; tests/test_sweep.py and tests/test_overrides.py run the sweep on Dask and
# `--set` in the default tier).
SLOW_COMMANDS = ("manipulator_reduced", "flexure fmu build", "flexure bench", "flexure sweep")


def _tiered(blocks):
    """The README's blocks, those with one of SLOW_COMMANDS in the slow tier."""
    return [pytest.param(block, marks=pytest.mark.slow)
            if any(slow in command for command in block[1] for slow in SLOW_COMMANDS)
            else block
            for block in blocks]


@pytest.mark.parametrize("block", _tiered(readme_shell_blocks()), ids=lambda block: block[0])
def test_readme_commands_run(block, tmp_path, monkeypatch, capsys):
    _, commands, output = block
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    for command in commands:
        printed = run_command(command, capsys)
        if output is not None:
            assert_output_matches(output, printed, command)


def test_readme_shows_commands():
    assert sum(len(block[1]) for block in readme_shell_blocks()) >= 5


@pytest.mark.parametrize("block", [b for b in code_blocks(README) if b[0] == "python"],
                         ids=lambda block: f"README.md:{block[1]}")
def test_readme_python_runs(block, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    code = compile("\n".join(block[2]), f"README.md:{block[1]}", "exec")
    exec(code, {"__name__": "readme"})


# -- the shape and the links --------------------------------------------------------------------
def test_readme_is_a_front_door():
    count = len(README.read_text().splitlines())
    assert count <= MAX_LINES, f"README.md has {count} lines; at most {MAX_LINES}: move " \
                               "material into docs/"


def slug(heading):
    """GitHub's anchor of a markdown heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(path):
    """The anchors of a markdown file's headings (outside code blocks)."""
    seen, found, in_code = {}, set(), False
    for line in path.read_text().splitlines():
        if line.lstrip().startswith("```"):
            in_code = not in_code
        heading = re.match(r"^#{1,6}\s+(.*)$", line)
        if heading and not in_code:
            base = slug(heading.group(1))
            n = seen.get(base, 0)
            seen[base] = n + 1
            found.add(base if n == 0 else f"{base}-{n}")
    return found


def links(path):
    """(line number, target) of every markdown link and image outside code blocks."""
    found, in_code = [], False
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if line.lstrip().startswith("```"):
            in_code = not in_code
            continue
        if in_code:
            continue
        line = re.sub(r"`[^`]*`", "", line)  # code spans are not links
        found += [(number, target) for target in re.findall(r"\]\(([^)\s]+)\)", line)]
    return found


MARKDOWN = [README, *sorted(DOCS.glob("*.md"))]


@pytest.mark.parametrize("path", MARKDOWN, ids=lambda p: str(p.relative_to(REPO)))
def test_relative_links_point_to_existing_files(path):
    problems = []
    for number, target in links(path):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # https:, mailto:
            continue
        file, _, anchor = target.partition("#")
        linked = (path.parent / file).resolve() if file else path
        where = f"{path.relative_to(REPO)}:{number}: {target}"
        if not linked.exists():
            problems.append(f"{where}: no such file")
        elif anchor and linked.suffix == ".md" and anchor not in anchors(linked):
            problems.append(f"{where}: no heading with the anchor #{anchor}")
    assert not problems, "\n".join(problems)


def test_readme_links_every_docs_page():
    targets = {(README.parent / t.partition("#")[0]).resolve() for _, t in links(README)}
    missing = [p.name for p in sorted(DOCS.glob("*.md")) if p.resolve() not in targets]
    assert not missing, f"README.md does not link docs/{', docs/'.join(missing)}"
