"""Running the `flexure` command in the test process, as a user's shell would, and a stub of
the results it reports."""

import json
import math
import sys
from pathlib import Path

import children
import numpy as np

from flexure.core.cli import main


def warm_command_modules(arguments, selected, cwd):
    """(exit code, stdout, the modules `selected` picks) of a warm run of `flexure ARGUMENTS`
    in a child process: a run that did not import numba (so compiled nothing and loaded
    nothing through it: every entry came as object code). A run that imported numba may have
    compiled, or loaded the compiled code through numba (which writes the object code), and
    either imports what a warm run must not: the command then runs again, and that second run
    is reported. (A warm first run is not run twice: it leaves the cache as it found it.)
    `selected` is a Python expression of a module's name `m` (True: report it)."""
    probe = ("import json, sys\nfrom flexure.core.cli import main\n"
             f"code = main({[str(a) for a in arguments]!r})\n"
             f"print(json.dumps([code, sorted(m for m in sys.modules if {selected}), "
             "'numba' in sys.modules]))")
    for _ in range(2):
        completed = children.run([sys.executable, "-c", probe], capture_output=True,
                                 text=True, check=True, cwd=cwd)
        code, loaded, numba_imported = json.loads(completed.stdout.splitlines()[-1])
        if not numba_imported:
            break
    return code, completed.stdout, loaded


def run(capsys, *argv):
    """(exit code, stdout, stderr) of `flexure ARGV` in this process; never a traceback."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as stop:  # argparse: exit 2 with its message
        code = stop.code
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


class StubResult:
    """What a stubbed simulation, work-precision study or loop returns to the CLI (a few
    samples, all ok), for tests of the command line around them."""

    model_name, method, rtol = "truss_1dof_x", "cvode-bdf", 1e-8
    times = np.array([0.0, 0.1])
    output_names, output_units = ["x"], ["m"]
    output_array = np.array([[0.1], [0.2]])
    statistics = {"steps": 1, "rhs_evaluations": 2, "jacobian_evaluations": 1,
                  "wall_time_s": 0.0}
    rows = [{"method": "ida", "rtol": 1e-3, "status": "ok"}]
    warnings = []

    def to_csv(self, path):
        Path(path).write_text("time,x\n0,0.1\n")

    def plot(self, path, **kwargs):
        Path(path).write_bytes(b"png")

    def text(self):
        return "table"

    def markdown(self):
        return "| table |"

    def summary(self):
        keys = ("stroke", "duration", "sample_rate_hz", "crossover_rad_s", "phase_margin_deg",
                "modulus_margin", "max_abs_error", "error_ratio", "target", "wall_time_s")
        return {**dict.fromkeys(keys, 1e-3), "scene": "truss_1dof_x", "plant": "inprocess",
                "feedforward": True, "feedforward_kind": "modal", "passed": True,
                "gain_margin": math.inf, "units": {"position": "m", "force": "N"},
                "per_loop": [{"loop": "F -> x", "stroke": 1e-3, "max_abs_error": 1e-9,
                              "error_ratio": 1e-6, "passed": True}]}
