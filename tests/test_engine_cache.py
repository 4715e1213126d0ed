"""The on-disk cache of compiled code: found again by a copy of the package elsewhere (keyed
by the package's name and its sources' hash, not its folder), and the first compilation
announced alike on a terminal and in a log."""

import io
import json
import os
import shutil
import sys
import tempfile
import textwrap
from pathlib import Path

import children
import pytest

from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from tests.test_engine_status import truss_pendulum

CORE = Path(__file__).resolve().parents[1] / "core"

PROBE = textwrap.dedent("""
    import json, sys
    import numpy as np
    from {package}.core.simulation.sampled_loop import controller_step
    out = np.zeros(1)
    controller_step(np.eye(1), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)),
                    np.zeros(1), np.ones(1), out, np.empty(1))
    stats = controller_step.python_dispatcher.stats  # Python called it: that code's cache
    print(json.dumps({{"hits": sum(stats.cache_hits.values()),
                      "misses": sum(stats.cache_misses.values())}}))
""")


@pytest.mark.slow  # 10 s: it compiles a copy of the package twice
def test_compiled_code_is_found_again_by_a_copy_of_the_package_elsewhere(tmp_path):
    """The cache is keyed by the package's name and a hash of its sources, not by the folder
    (an FMU unpacks its copy of flexure into a new folder every time): a copy of core/ under
    another folder loads the compiled kernel the first copy wrote; a changed source compiles
    afresh."""

    def copy(folder, change=False):
        package = tmp_path / folder / "flexure_cache_probe"
        shutil.copytree(CORE, package / "core",
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        (package / "__init__.py").write_text("")
        if change:
            with open(package / "core" / "reporting" / "tables.py", "a") as handle:
                handle.write("\n# a change\n")
        return tmp_path / folder

    def run(root):
        env = {**os.environ, "FLEXURE_CACHE_DIR": str(tmp_path / "cache"),
               "PYTHONPATH": str(root)}
        done = children.run([sys.executable, "-c",
                             PROBE.format(package="flexure_cache_probe")],
                            capture_output=True, text=True, env=env, cwd=root, check=True)
        return json.loads(done.stdout.strip().splitlines()[-1])

    first = run(copy("first"))
    assert first == {"hits": 0, "misses": 1}
    assert run(copy("second")) == {"hits": 1, "misses": 0}
    assert run(copy("changed", change=True)) == {"hits": 0, "misses": 1}


def test_the_first_compilation_is_announced_on_a_terminal_and_in_a_log_alike(tmp_path):
    """A first run waits about a minute for the compiler: `is_cached` tells a compiled entry
    from one that is not (an empty cache folder, in a fresh process), and the notice is
    written once per process, to a log (a pipe, CI, an FMU host's stderr) as to a terminal
    (tests/test_compile_notice.py: its estimate, progress line and writers)."""
    from flexure.core.numerics.compile_notice import CompileNotice
    from flexure.core.numerics.jit import is_cached

    engine.connect(EngineData(truss_pendulum()), engine.OP_RHS)  # the entry compiled or loaded
    assert is_cached(engine.ENTRIES[engine.OP_RHS].function)
    probe = ("from flexure.core.engine import engine; from flexure.core.numerics import jit; "
             "print(jit.is_cached(engine.ENTRIES[engine.OP_RHS].function))")
    with tempfile.TemporaryDirectory() as empty:
        done = children.run([sys.executable, "-c", probe], capture_output=True, text=True,
                            env={**os.environ, "FLEXURE_CACHE_DIR": empty}, check=True)
    assert done.stdout.split() == ["False"]

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    for stream in (Terminal(), io.StringIO()):
        notice = CompileNotice(str(tmp_path), "sources")
        notice.announce(stream)
        notice.announce(stream)
        notice.close()
        lines = stream.getvalue().splitlines()
        assert len(lines) == 1, lines
        assert lines[0].startswith("flexure: compiling its engine for ")
        assert lines[0].endswith(f"kept in {tmp_path}")
