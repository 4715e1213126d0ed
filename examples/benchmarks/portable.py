"""The portable row group: the engine compiled for a portable CPU target (what an FMU carries,
NUMBA_CPU_NAME=generic) against this machine's own target (what flexure compiles for
in-process use), and an FMU's first instantiate in a host without flexure, with the engine it
carries and compiling instead. CPU seconds (user + sys of the process), not wall: the machine
is shared."""

import json
import os
import statistics
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from .fmu_overhead import FIRST_INSTANTIATE
from .measure import log
from .table import Row

# The same work in a child process of either target, each timed three times after a warm-up
# (CPU seconds, the median): stage_planar_3dof advanced 1 ms at a time for 1 s with F = 1 N,
# as an FMU steps it (esdirk at rtol 1e-6, the FMU's defaults); a 1 s step response with
# `simulate` (the same defaults); and one evaluation of the engine's right-hand side on the
# stage with 4 PLBEAMs per spring (21 DOFs), 20 000 calls from Python less as many calls of
# an operation the engine does not know (the call's own cost). With the integrators' counts,
# which show that both targets did the same work.
SPEED = r"""
import json, statistics, time
import numpy as np
from flexure.core import Simulator, load_scene, simulate
from flexure.core.engine import engine
from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS
from examples.benchmarks.stage_models import refined_stage
model = load_scene("stage_planar_3dof")
counts = {}

def advances():
    simulator = Simulator(model, method=METHODS[0], rtol=DEFAULT_RTOL)
    start = time.process_time()
    for k in range(1000):
        simulator.set_inputs([1.0])
        simulator.advance_to((k + 1) * 1e-3)
    counts["advances"] = simulator.statistics["rhs_evaluations"]
    return time.process_time() - start

def step():
    start = time.process_time()
    result = simulate(model, 1.0, inputs={"F": 1.0}, method=METHODS[0], rtol=DEFAULT_RTOL)
    counts["step"] = result.statistics["rhs_evaluations"]
    return time.process_time() - start

simulator = Simulator(refined_stage(4), rtol=1e-6)
simulator.set_inputs([1.0])
simulator.advance_to(0.01)
y = np.ascontiguousarray(simulator.state, dtype=float)
ydot = np.empty_like(y)
simulator.derivative(0.0, y)

def rhs(op=engine.OP_RHS, count=20000):
    start = time.process_time()
    for _ in range(count):
        engine.call(simulator.data, op, y, ydot)
    return (time.process_time() - start) / count

def evaluation():
    return rhs() - rhs(op=1000)

advances(), step(), evaluation()
print(json.dumps({"advances": statistics.median(advances() for _ in range(3)),
                  "step": statistics.median(step() for _ in range(3)),
                  "rhs": statistics.median(evaluation() for _ in range(3)),
                  "counts": counts}))
"""



def _child(script, args=(), **env):
    root = str(Path(__file__).resolve().parents[2])  # for examples.benchmarks in the child
    done = subprocess.run([sys.executable, "-c", script, *map(str, args)], cwd=root,
                          env={**os.environ, **env}, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"a child run failed: {done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def speed(*, repeat=5):
    """Pairs of child runs, this machine's target then the portable one: {work: (host s,
    generic s, the median of the pairs' generic / host ratios, whether both targets did the
    same work: the same counts of evaluations)}."""
    from flexure.fmu.portable_engine import PORTABLE_TARGET, staging_folder

    staging = staging_folder() or Path(tempfile.mkdtemp(prefix="flexure_portable_cache_"))
    generic = {**PORTABLE_TARGET, "FLEXURE_CACHE_DIR": str(staging)}
    log("portable: warm-up runs (the first of each target may compile)")
    _child(SPEED)
    _child(SPEED, **generic)
    runs = []
    for i in range(repeat):
        log(f"portable: speed pair {i + 1}/{repeat}")
        runs.append((_child(SPEED), _child(SPEED, **generic)))
    return {work: (statistics.median(h[work] for h, _ in runs),
                   statistics.median(g[work] for _, g in runs),
                   statistics.median(g[work] / h[work] for h, g in runs),
                   all(h["counts"] == g["counts"] for h, g in runs))
            for work in ("advances", "step", "rhs")}


def first_instantiates(carried, bare, *, repeat=3, quick=False):
    """The first instantiate in a host without flexure (FLEXURE_FMU_OWN_COPY=1) and an
    empty cache: {"carried": [runs], "compiling": [runs]} of the FMU with its engine and
    without (the latter once, and not with --quick: it compiles for a minute)."""
    runs = {"carried": [], "compiling": []}
    for i in range(repeat):
        with tempfile.TemporaryDirectory(prefix="flexure_empty_cache_") as cache:
            log(f"portable: first instantiate with the carried engine {i + 1}/{repeat}")
            runs["carried"].append(_child(FIRST_INSTANTIATE, [carried], FLEXURE_CACHE_DIR=cache,
                                          FLEXURE_FMU_OWN_COPY="1"))
    if not quick:
        with tempfile.TemporaryDirectory(prefix="flexure_empty_cache_") as cache:
            log("portable: first instantiate compiling its engine")
            runs["compiling"].append(_child(FIRST_INSTANTIATE, [bare], FLEXURE_CACHE_DIR=cache,
                                            FLEXURE_FMU_OWN_COPY="1"))
    return runs


def portable(*, repeat=5, quick=False):
    """The portable target's speed against this machine's, and the FMU's first
    instantiate with its engine carried."""
    from flexure.fmu import build_scene_fmu

    rows = []
    ratios = speed(repeat=2 if quick else repeat)
    for work, what, unit in (
            ("advances", "stage_planar_3dof advanced 1 ms at a time for 1 s (as an FMU steps "
                         "it; esdirk, rtol 1e-6)", "s"),
            ("step", "a 1 s step of stage_planar_3dof with simulate (esdirk, rtol 1e-6)", "s"),
            ("rhs", "one evaluation of the right-hand side, 4 PLBEAMs per spring (21 DOFs)",
             "us")):
        host, generic, ratio, same = ratios[work]
        scale = 1e6 if unit == "us" else 1.0
        rows.append(Row(f"engine compiled for the portable CPU target (NUMBA_CPU_NAME="
                        f"generic, an FMU's) against this machine's: {what}",
                        f"{scale * generic:.3f} {unit} of CPU against {scale * host:.3f} {unit}"
                        f": ratio {ratio:.3f} (median of the alternating pairs' ratios"
                        f"{'' if same or work == 'rhs' else '; NOT the same evaluations'})",
                        "(information: in-process use compiles for this machine)"))
    with tempfile.TemporaryDirectory(prefix="flexure_portable_") as temp:
        log("portable: building stage_planar_3dof.fmu with and without its engine")
        bare = build_scene_fmu("stage_planar_3dof", Path(temp) / "bare" / "s.fmu",
                               engine=False)
        carried = build_scene_fmu("stage_planar_3dof", Path(temp) / "carried" / "s.fmu",
                                  engine=True)
        with zipfile.ZipFile(carried) as archive:
            manifest = json.loads(archive.read("resources/flexure-engine/manifest.json"))
        growth = carried.stat().st_size - bare.stat().st_size
        runs = first_instantiates(carried, bare, repeat=2 if quick else 3, quick=quick)
    first = statistics.median(r["first_cpu_s"] for r in runs["carried"])
    process = statistics.median(r["process_cpu_s"] for r in runs["carried"])
    compiling = (f"{runs['compiling'][0]['first_cpu_s']:.1f} s (process "
                 f"{runs['compiling'][0]['process_cpu_s']:.1f} s)" if runs["compiling"]
                 else "not measured (--quick)")
    rows.append(Row("FMU's first instantiate + initialise + doStep in a host without flexure "
                    "(its own copy), empty cache, with the engine it carries: <= 5 s of CPU",
                    f"{first:.2f} s of CPU (process {process:.2f} s); compiling instead: "
                    f"{compiling}", "<= 5 s", first / 5.0, first <= 5.0))
    rows.append(Row("what the engine adds to the FMU (stage_planar_3dof)",
                    f"{growth / 1e6:.1f} MB ({manifest['functions']} functions, "
                    f"{manifest['bytes'] / 1e6:.1f} MB unpacked)", "(information)"))
    return rows
