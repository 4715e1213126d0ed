"""The manipulator's analyses as a user runs them (issue 35's targets), whole processes in CPU
seconds (user + system: the shared machine's other load inflates walls far more), medians,
the three commands alternating after one unmeasured round (bytecode, caches):

- the 816-DOF model's ten lowest modes, `flexure analyze manipulator --modes 10` (load, DOF
  choice and check, equilibrium, linearisation, modes with their descriptions, the stability
  check): at most 3 s;
- `flexure reduce manipulator_e1 --keep 7 --tol 1`: at most 5 s;
- `python examples/manipulator_report.py` (the three models' frequencies, the principal
  gains, the 21 workspace poses, two PNGs): at most 20 s.

No peer runs these; the before/after against the commit before the change is measured
alternating by hand and kept in docs/benchmarks.md (2026-11-29).
"""

import sys
import tempfile
from pathlib import Path

from .latency import flexure_command, user_environment
from .measure import alternate, command_cpu, log
from .table import Row

HERE = Path(__file__).resolve().parent
LIMITS = {"modes": 3.0, "reduce": 5.0, "report": 20.0}  # CPU s


def manipulator_analyses(*, repeat=3, quick=False):
    """Rows: each command's CPU seconds against its limit."""
    flexure = flexure_command()
    env = user_environment()
    with tempfile.TemporaryDirectory(prefix="flexure_manipulator_") as folder:
        commands = {
            "modes": [*flexure, "analyze", "manipulator", "--modes", "10"],
            "reduce": [*flexure, "reduce", "manipulator_e1", "--keep", "7", "--tol", "1",
                       "--out", f"{folder}/manipulator_e1_reduced.toml"],
            "report": [sys.executable, str(HERE.parent / "manipulator_report.py"),
                       "--figures", folder],
        }
        cases = {name: (lambda command=command: command_cpu(command, env=env))
                 for name, command in commands.items()}
        if not quick:  # the first runs write the bytecode a user's later runs find
            log("manipulator analyses: one unmeasured round")
            alternate(cases, 1, "manipulator analyses, unmeasured (CPU s)", budget=1e9)
        t = alternate(cases, 1 if quick else repeat, "manipulator analyses (CPU s)",
                      budget=1e9)
    labels = {"modes": "flexure analyze manipulator --modes 10 (816 DOFs, ten lowest modes)",
              "reduce": "flexure reduce manipulator_e1 --keep 7 --tol 1",
              "report": "python examples/manipulator_report.py"}
    rows = []
    for name, label in labels.items():
        timing, limit = t[name], LIMITS[name]
        rows.append(Row(f"{label} (CPU): <= {limit:g} s", timing.text(), f"<= {limit:g} s",
                        timing.median / limit, timing.median <= limit))
    return rows
