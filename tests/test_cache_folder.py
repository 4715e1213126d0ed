"""Where the compiled-code cache lives (flexure.core.numerics.jit.cache_root): a relative
FLEXURE_CACHE_DIR names one folder for this process and every child it starts, whatever the
child's working folder."""

import os
import sys

import children

CHILD = "from flexure.core.numerics.jit import cache_root; print(cache_root())"


def test_a_relative_cache_folder_is_the_same_folder_for_a_child_in_another_folder(tmp_path):
    work, elsewhere = tmp_path / "work", tmp_path / "elsewhere"
    work.mkdir()
    elsewhere.mkdir()
    parent = children.run(
        [sys.executable, "-c",
         "import os, subprocess, sys\n"
         f"{CHILD}\n"
         f"print(subprocess.run([sys.executable, '-c', {CHILD!r}], cwd={str(elsewhere)!r},"
         " capture_output=True, text=True, check=True).stdout.strip())\n"
         "print(os.environ['FLEXURE_CACHE_DIR'])"],
        cwd=work, env={**os.environ, "FLEXURE_CACHE_DIR": "cache"},
        capture_output=True, text=True, check=True)
    own, child, exported = parent.stdout.split()
    assert own == str(work / "cache")
    assert child == own
    assert exported == own
    assert not (elsewhere / "cache").exists()
