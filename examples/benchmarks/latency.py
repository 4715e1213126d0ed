"""Latencies: the first simulation in this process (`warmup`, the table's first row), and the
whole processes a user starts, warm and cold, beside Exudyn's (the startup row group)."""

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .measure import alternate, command_cpu, log, peer
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


def user_environment():
    """os.environ as a user's shell has it: without PYTHONDONTWRITEBYTECODE. `pip install`
    writes the bytecode of an installed flexure, but an editable install in an environment
    that sets it (this project's machines do) compiles flexure's sources in every process:
    0.1 to 0.15 s of CPU a user does not pay. One unmeasured round writes the bytecode."""
    return {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def startup(*, repeat=5, quick=False):
    """Whole processes as a user starts them (`user_environment`), warm cache, CPU seconds
    (user + system: the shared machine's other load inflates walls far more), side by side
    with Exudyn's whole process for the same work where there is one, alternating, after one
    unmeasured round; and the cold first use."""
    flexure = flexure_command()
    python = [sys.executable, "-c"]
    env = user_environment()

    def cpu(command):
        return command_cpu(command, env=env)

    with tempfile.TemporaryDirectory(prefix="flexure_startup_") as folder:
        exu = peer()
        exudyn_loop = exudyn_step = None
        if exu is not None:
            from .exudyn_loop_process import save_controller

            numbers = Path(folder) / "controller.npz"
            save_controller(numbers, _default_loop_controller())
            here = Path(__file__).resolve().parent
            exudyn_loop = [sys.executable, str(here / "exudyn_loop_process.py"), str(numbers)]
            exudyn_step = [*python, EXUDYN_STEP.format(root=str(here.parents[1]))]
        cases = {
            "pass": lambda: cpu([*python, "pass"]),
            "import": lambda: cpu([*python, "import flexure.core"]),
            "analyze": lambda: cpu([*flexure, "analyze", "truss_1dof_x"]),
            "loop": lambda: cpu([*flexure, "loop", "--no-plot"]),
            "loop+plot": lambda: cpu([*flexure, "loop", "--plot", folder + "/loop.png"]),
            "exudyn loop": exudyn_loop and (lambda: cpu(exudyn_loop)),
            "simulate": lambda: cpu([*flexure, "simulate", "stage_planar_3dof",
                                     "--t-end", "0.01", "--input", "F=1"]),
            "exudyn step": exudyn_step and (lambda: cpu(exudyn_step)),
        }
        alternate(cases, 1, "startup, unmeasured round (CPU s)")
        t = alternate(cases, repeat, "startup (CPU s)")
    scale = f"python -c pass: {t['pass'].text()}"
    rows = [Row('python -c "import flexure.core" (CPU): <= 0.5 s', t["import"].text(),
                f"<= 0.5 s ({scale})", t["import"].median / 0.5, t["import"].median <= 0.5),
            Row("flexure analyze truss_1dof_x (CPU): <= 0.5 s", t["analyze"].text(),
                "<= 0.5 s", t["analyze"].median / 0.5, t["analyze"].median <= 0.5)]
    loop = t["loop"].median
    if "exudyn loop" in t:
        peer_loop = t["exudyn loop"].median
        rows.append(Row("flexure loop --no-plot (CPU): <= 1.5 s, against Exudyn's process "
                        "for the same loop (exudyn_loop_process.py)", t["loop"].text(),
                        f"Exudyn {t['exudyn loop'].text()}", loop / peer_loop, loop <= 1.5))
    else:
        rows.append(Row("flexure loop --no-plot (CPU): <= 1.5 s", t["loop"].text(), "<= 1.5 s",
                        loop / 1.5, loop <= 1.5))
    rows.append(Row("flexure loop, writing loop.png (CPU)", t["loop+plot"].text(),
                    "(for information)"))
    target = ("flexure simulate stage_planar_3dof --t-end 0.01 (CPU): <= 2 x Exudyn's "
              "process for a 10 ms step")
    if "exudyn step" in t:
        ratio = t["simulate"].median / t["exudyn step"].median
        rows.append(Row(target, t["simulate"].text(), f"Exudyn {t['exudyn step'].text()}",
                        ratio, ratio <= 2.0))
    else:
        rows.append(Row(target, t["simulate"].text(), "(exudyn not installed)"))
    if not quick:
        rows.append(_cold_loop(flexure))
    return rows


def flexure_command():
    """The `flexure` command of this Python (its script, or the module's main)."""
    script = Path(sys.executable).with_name("flexure")
    return ([str(script)] if script.exists() else
            [sys.executable, "-c", "import sys; from flexure.core.cli import main; "
             "sys.exit(main())"])


def _default_loop_controller():
    """The LoopController of `flexure loop`'s defaults (its design, done once here)."""
    from flexure.controllers import build_loop
    from flexure.core import load_scene

    controller, _ = build_loop(load_scene("stage_planar_1dof"), stroke=1e-3, duration=1.0,
                               fs=4000.0, crossover=300.0, feedforward=True, settle=0.25)
    return controller


# Exudyn's whole process for a 10 ms, 1 N step of the stage (n = 4 cables per spring, h =
# 0.1 ms): the work of `flexure simulate stage_planar_3dof --t-end 0.01 --input F=1`
EXUDYN_STEP = """import sys
sys.path.insert(0, {root!r})
from examples.benchmarks.peer_exudyn import step_response
step_response(4, 1e-4, t_end=0.01)
"""


def _cold_loop(flexure):
    """The first `flexure loop --no-plot` on a machine: an empty FLEXURE_CACHE_DIR, so the
    engine compiles; one run (it takes a minute or more)."""
    log("startup: flexure loop with an empty FLEXURE_CACHE_DIR (compiles)")
    with tempfile.TemporaryDirectory(prefix="flexure_cold_cache_") as cold:
        cpu, wall = command_cpu([*flexure, "loop", "--no-plot"],
                                env=dict(user_environment(), FLEXURE_CACHE_DIR=cold))
    return Row("first flexure loop --no-plot on an empty cache (CPU): <= 30 s",
               f"{cpu:.1f} s (wall {wall:.1f} s)", "<= 30 s", cpu / 30.0, cpu <= 30.0)
