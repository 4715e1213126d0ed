"""The benchmark script runs: its start-up and loop rows, flexure's side (Exudyn, the peer,
is an optional extra that the default test run does not install)."""

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.slow  # 45 s: the slow tier, which .ci/run runs after the default one
def test_compare_prints_the_startup_and_loop_rows(tmp_path):
    table = tmp_path / "table.md"
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / "benchmarks" / "compare.py"), "--only", "startup,loop",
         "--repeat", "1", "--markdown", str(table)],
        capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    text = table.read_text()
    assert "import flexure.core" in text and "flexure analyze truss_1dof_x" in text
    assert "flexure loop" in text
    # the loop's tracking error row: measured, and within the 1e-7 of the stroke it targets
    row = next(line for line in text.splitlines() if "error" in line and "stroke" in line)
    assert "| yes |" in row, row
