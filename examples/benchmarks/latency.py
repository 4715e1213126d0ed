"""Latencies: the first simulation in this process (`warmup`, the table's first row) and the
whole-process wall of `import flexure.core` and `flexure analyze` (the startup row group)."""

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .measure import alternate, command_wall, log, peer
from .table import Row


def warmup(*, repeat=5, quick=False):
    """The first flexure simulation in this process (and Exudyn's first run): the latency a
    user sees once, before any of the timed runs."""
    log("warm-up: first flexure simulation in this process")
    start = time.perf_counter()
    from flexure.core import load_scene, simulate
    from flexure.core.engine import engine
    from flexure.core.numerics.jit import is_cached

    # a cache without this copy's engine (a new machine, or sources changed since) makes
    # this first call compile: a latency of another kind, which the row says
    compiled_here = not is_cached(engine.ENTRIES[engine.OP_RHS].function)
    simulate(load_scene("stage_planar_3dof"), 0.01, inputs={"F": 1.0}, rtol=1e-6)
    first = time.perf_counter() - start
    from flexure.controllers.runner import run_loop

    start = time.perf_counter()
    run_loop("stage_planar_1dof", duration=0.01, settle=0.0)
    first_loop = time.perf_counter() - start
    cold = "not measured (--quick)" if quick else f"{_first_call_compiling():.1f} s"
    compiled_note = (" (compiled in this process: the cache held no engine of these "
                     "sources)") if compiled_here else ""
    rows = [Row("first call in this process: import + engine load (compiled once into "
                "~/.cache/flexure) + a 10 ms simulation",
                f"{first:.2f} s{compiled_note}; then a first short loop {first_loop:.2f} s; "
                "in a fresh process "
                f"with an empty cache (compiling) {cold}", "(latency, not in any figure "
                "below)")]
    exu = peer()
    if exu is not None:
        start = time.perf_counter()
        exu.step_response(1, 1e-3, t_end=0.01)
        rows[0].peer += f"; Exudyn's first 10 ms run {time.perf_counter() - start:.3f} s"
    return rows


FIRST_CALL = """import time
start = time.perf_counter()
from flexure.core import load_scene, simulate
simulate(load_scene("stage_planar_3dof"), 0.01, inputs={"F": 1.0}, rtol=1e-6)
print(time.perf_counter() - start)
"""


def _first_call_compiling():
    """Wall (s) of the warm-up's first simulation in a fresh process whose compile cache
    (FLEXURE_CACHE_DIR) is empty: what a new machine's first run waits for."""
    log("warm-up: the first simulation with an empty FLEXURE_CACHE_DIR (compiles)")
    with tempfile.TemporaryDirectory(prefix="flexure_cold_cache_") as cold:
        done = subprocess.run([sys.executable, "-c", FIRST_CALL], capture_output=True,
                              text=True, check=False, env=dict(os.environ,
                                                               FLEXURE_CACHE_DIR=cold))
    if done.returncode != 0:
        raise RuntimeError(f"the first call with an empty cache failed: {done.stderr[-2000:]}")
    return float(done.stdout.split()[-1])


def startup(*, repeat=5, quick=False):
    """Whole-process wall of `import flexure.core` and `flexure analyze truss_1dof_x`."""
    script = Path(sys.executable).with_name("flexure")
    analyze = ([str(script)] if script.exists() else
               [sys.executable, "-c", "import sys; from flexure.core.cli import main; "
                "sys.exit(main())"]) + ["analyze", "truss_1dof_x"]
    python = [sys.executable, "-c"]
    t = alternate({"pass": lambda: command_wall([*python, "pass"]),
                   "import": lambda: command_wall([*python, "import flexure.core"]),
                   "analyze": lambda: command_wall(analyze)}, repeat, "startup")
    scale = f"python -c pass: {1e3 * t['pass'].median:.0f} ms"
    return [Row('python -c "import flexure.core": <= 0.5 s', t["import"].text("ms"),
                f"<= 500 ms ({scale})", t["import"].median / 0.5, t["import"].median <= 0.5),
            Row("flexure analyze truss_1dof_x: <= 1 s", t["analyze"].text("ms"),
                f"<= 1000 ms ({scale})", t["analyze"].median / 1.0,
                t["analyze"].median <= 1.0)]
