"""flexure against Exudyn and the speed targets, side by side in one run.

Every figure is measured in this one process run, flexure's and Exudyn's runs alternating
(flexure, Exudyn, flexure, ...) so that both see the same machine load; a time is the median
of `--repeat` runs (the minimum is shown with it). The table has one row per target:

    target | flexure | peer / limit | ratio | met

where "peer / limit" is Exudyn's figure for the same work when the target compares with it
(ratio = flexure / Exudyn) and the target's limit otherwise (ratio = flexure / limit). For a
time or a cost a ratio <= 1 (or the target's factor, 0.5 for the loop) meets the target; for
a speed (times real time) a ratio >= 1 does.

The row groups (one function each; `--only` picks some):

loop      `flexure loop` with its defaults (`flexure.controllers.runner.run_loop` on
          stage_planar_1dof: 1 mm in 1 s, 0.25 s settling, 4 kHz, esdirk2 at rtol 1e-5), its
          `LoopResult.wall_time_s` (the compiled loop, the controller design excluded) against
          `peer_exudyn.closed_loop(4)`, the same controller stepped in Exudyn (SolveDynamic
          alone). Exudyn's n = 4 cables per spring, not 1: with its full Gauss integration one
          cable per spring is membrane-locked (6 % too stiff at 1 mm, 9e-4 of the stroke of
          tracking error), which is not the stage's model; n = 4 is converged (945.6 N/m
          against flexure's 945.0) and is the cheapest Exudyn model equivalent to flexure's.
          Target: wall <= 0.5 x Exudyn's; max |error| / stroke <= 1e-7.
realtime  The loop on stage_planar_3dof and stage_spatial_19dof (the same defaults): simulated
          time (1.25 s) / wall; targets >= 10 and >= 2 times real time. The plant's accuracy
          beside it: max |y - y_ref| / stroke of the measured positions against the same loop
          at rtol 1e-10.
step      A 1 N step for 1 s on stage_planar_3dof (one PLBEAM per spring) and on the stage
          with 4 PLBEAMs per spring (`refined_stage`). The error is max |x - x_ref| / stroke
          (the stroke: the static deflection 1 N / (24 EI / l^3) = 1.058 mm) against each
          code's own converged reference of the same model: flexure's at rtol 1e-11
          (cvode-adams; cvode-bdf at 1e-11 gives its uncertainty), Exudyn's the h = 1/128 ms
          generalized-alpha run (`peer_exudyn.converged_reference`, its Richardson estimate
          about 1.6e-6 of the stroke). For each error level 1e-3, 1e-5, 1e-7 the fastest
          setting that reaches it is found by a scan (flexure: rtol 1e-3 ... 1e-10 with
          esdirk, esdirk3, esdirk2, cvode-bdf, cvode-bdf of order <= 2, cvode-adams, ida; Exudyn:
          fixed steps h), and
          the two chosen settings are then timed alternately. A method's scan stops at the
          first rtol that reaches 1e-7 or whose 0.1 s probe shows a run longer than a cap
          (20 s; 5 s with --quick). Exudyn cannot reach a level
          within the reference's own error (1e-7 here): its time there is extrapolated from
          its finest verified step at its order 2 (error ~ h^2, wall ~ 1 / h; the observed
          order is 2.0) and marked "extrap.". flexure's wall is the whole `simulate` call
          (the Simulator built inside), Exudyn's SolveDynamic alone (the model built before).
          Target: faster than Exudyn at each level; x real time >= 10 at rtol 1e-6 (esdirk).
refined   The 4-PLBEAMs-per-spring stage undamped (EdA = EdI = 0), 1 s step at rtol 1e-6
          (esdirk3; its error against esdirk at rtol 1e-9 is shown):
          wall <= 2 s. The cost of one right-hand-side evaluation for n = 1, 2, 4, 8, 16
          PLBEAMs per spring (6 n - 3 DOFs, 2 n + 1 elements): the engine's RHS operation
          called in a loop at a deformed state (a ~1 us ctypes call included), and, for
          comparison, a short run's integrator wall time / rhs evaluations (which includes
          the Jacobians and the linear solves). Targets: linear growth with the element count
          (us per element at n = 16 within 1.5 x of n = 4's); <= 100 us at 93 DOFs.
fmu       stage_planar_3dof's FMU (`flexure.fmu.build_scene_fmu`, its default integrator
          and rtol) stepped by fmpy's FMU2Slave at 1 ms for 1 s with F = 1 N: 1 s / wall
          >= 10, with its error against a CVODE run at rtol 1e-11; the FMU's overhead =
          1 - engine / FMU wall <= 10 %, the engine time being the FMU's own simulator's time
          inside `advance` in the same run, and the master calling the FMU's C functions
          directly (fmpy's ctypes handles, as a compiled master does); the median over the
          runs. The same through FMU2Slave's Python methods, for information, split into
          flexure's slave in Python beyond the engine (the slave's time inside do_step less
          its simulator's) and the rest: fmpy's Python and ctypes calls and pythonfmu's
          binary (setReal, doStep, getReal). Also
          the latency of the first instantiate +
          initialise + doStep in a fresh process, with an empty FLEXURE_CACHE_DIR (the
          engine compiles) and with the warm cache.
startup   Whole-process wall of `python -c "import flexure.core"` (<= 0.5 s) and `flexure
          analyze truss_1dof_x` (<= 1 s), with `python -c pass` for scale.

Before any timing one warm-up run loads the compiled engine (compiling it when the on-disk
cache is empty); its latency is the table's first row, not part of any other figure.

Usage
-----
    python examples/benchmarks/compare.py [--quick] [--repeat N] [--only loop,step]
                                          [--markdown FILE]

Requires flexure and, for the peer columns, exudyn (``pip install ".[bench]"``); without
exudyn the flexure side and the limits are still measured.
"""

import argparse
import copy
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SCENES = HERE.parent / "scenes"
LEAF_LENGTH = 0.1  # m
LEVELS = (1e-3, 1e-5, 1e-7)  # error levels of the step, fractions of the stroke
SCAN_METHODS = (("esdirk", None), ("esdirk3", None), ("esdirk2", None), ("cvode-bdf", None),
                ("cvode-bdf", 2), ("cvode-adams", None), ("ida", None))
STEP_METHOD = "esdirk"  # the integrator of the 3-DOF step at rtol 1e-6
REFINED_METHOD = "esdirk3"  # of the refined undamped stage at rtol 1e-6 (esdirk: 3 x the time)
SCAN_RTOLS = tuple(10.0 ** -k for k in range(3, 11))
QUICK_RTOLS = (1e-3, 1e-4, 1e-5, 1e-6)
PEER_STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5, 1.5625e-5)
QUICK_PEER_STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4)
STEP_TIMES = np.linspace(0.0, 1.0, 1001)
PROBE = 0.1  # s, the simulated time of a probe run (see flexure_step)
GROUPS = ("loop", "realtime", "step", "refined", "fmu", "startup")
HEADERS = ["target", "flexure", "peer / limit", "ratio", "met"]

_START = time.perf_counter()


def log(message):
    """Progress on stderr, with the seconds since the start."""
    print(f"[{time.perf_counter() - _START:7.1f} s] {message}", file=sys.stderr, flush=True)


@dataclass
class Row:
    """One line of the table; `ratio` and `met` are None where they do not apply."""

    target: str
    flexure: str
    peer: str
    ratio: float | None = None
    met: bool | None = None

    def cells(self):
        ratio = "" if self.ratio is None else f"{self.ratio:.3g}"
        met = "" if self.met is None else ("yes" if self.met else "NO")
        return [self.target, self.flexure, self.peer, ratio, met]


@dataclass
class Timing:
    """Wall times (s) of repeated runs and what the last run returned."""

    walls: list
    info: object = None

    @property
    def median(self):
        return statistics.median(self.walls)

    @property
    def best(self):
        return min(self.walls)

    def text(self, unit="s"):
        if unit == "ms":
            return f"{1e3 * self.median:.1f} ms (min {1e3 * self.best:.1f})"
        return f"{self.median:.3f} s (min {self.best:.3f})"


def alternate(cases, repeat, label="", *, budget=120.0):
    """Run the callables of `cases` ({name: f() -> (wall, info)}) in turn, `repeat` rounds.

    Returns {name: Timing}; the runs of different cases interleave so that they share the
    machine's load. No further round starts once the runs took `budget` seconds (a run of
    a minute is timed once)."""
    timings = {name: Timing([]) for name in cases}
    spent = 0.0
    for i in range(repeat):
        if spent > budget:
            log(f"{label}: {i} round(s) of {repeat}, the budget of {budget:g} s is spent")
            break
        for name, run in cases.items():
            if run is None:
                continue
            log(f"{label} {name}: run {i + 1}/{repeat}")
            start = time.perf_counter()
            wall, info = run()
            spent += time.perf_counter() - start
            timings[name].walls.append(wall)
            timings[name].info = info
    return {name: t for name, t in timings.items() if t.walls}


def peer():
    """The Exudyn side (peer_exudyn), or None when exudyn is not installed."""
    try:
        from . import peer_exudyn
    except ImportError:
        try:
            sys.path.insert(0, str(HERE))
            import peer_exudyn
        except ImportError as error:
            log(f"exudyn not available ({error}): the peer columns stay empty")
            return None
    return peer_exudyn


# -- the models ------------------------------------------------------------------------------
def scene_data(name="stage_planar_3dof"):
    with open(SCENES / f"{name}.toml", "rb") as handle:
        return tomllib.load(handle)


def step_stroke(force=1.0):
    """The stroke of the step (m): the linear static deflection F l^3 / (24 EI)."""
    leaf = scene_data()["sections"]["leaf"]
    EI = leaf["E"] * leaf["width"] * leaf["height"] ** 3 / 12
    return abs(force) * LEAF_LENGTH**3 / (24 * EI)


def refined_stage(n, *, damped=True):
    """stage_planar_3dof with each leaf spring split into `n` PLBEAMs (6 n - 3 DOFs).

    Every leaf element keeps the scene's released e1, e2, e3; the n - 1 intermediate nodes
    of a spring carry x, y and phi as DOFs. n = 1 is the scene itself. `damped=False` sets
    the leaves' EdA and EdI to 0."""
    from flexure.core import build_model

    data = copy.deepcopy(scene_data())
    data["scene"]["name"] = f"stage_planar_3dof_x{n}" + ("" if damped else "_undamped")
    data["scene"].pop("tunable", None)
    if not damped:
        data["sections"]["leaf"].update(EdA=0.0, EdI=0.0)
    elements = data["elements"]
    for side, bottom, top, x in (("left", ("1", "2"), ("3", "4"), 0.0),
                                 ("right", ("7", "8"), ("5", "6"), LEAF_LENGTH)):
        leaf = elements.pop(f"leaf_{side}")
        chain = [bottom]
        for j in range(1, n):
            t, r = f"{side}_{j}", f"{side}_{j}r"
            data["nodes"][t] = {"position": [x, LEAF_LENGTH * j / n], "dof": ["x", "y"]}
            data["nodes"][r] = {"angle": 0.0, "dof": ["phi"]}
            chain.append((t, r))
        chain.append(top)
        for j in range(n):
            elements[f"leaf_{side}_{j}"] = {**leaf, "nodes": [*chain[j], *chain[j + 1]]}
    return build_model(data, source=f"refined_stage({n})")


# -- warm-up ---------------------------------------------------------------------------------
def warmup(*, repeat=5, quick=False):
    """The first flexure simulation in this process (and Exudyn's first run): the latency a
    user sees once, before any of the timed runs."""
    log("warm-up: first flexure simulation in this process")
    start = time.perf_counter()
    from flexure.core import load_scene, simulate

    simulate(load_scene("stage_planar_3dof"), 0.01, inputs={"F": 1.0}, rtol=1e-6)
    first = time.perf_counter() - start
    from flexure.controllers.runner import run_loop

    start = time.perf_counter()
    run_loop("stage_planar_1dof", duration=0.01, settle=0.0)
    first_loop = time.perf_counter() - start
    rows = [Row("first call in this process: import + engine load (compiled once into "
                "~/.cache/flexure; ~30-40 s when that cache is empty) + a 10 ms simulation",
                f"{first:.2f} s; then a first short loop {first_loop:.2f} s", "(latency, "
                "not in any figure below)")]
    exu = peer()
    if exu is not None:
        start = time.perf_counter()
        exu.step_response(1, 1e-3, t_end=0.01)
        rows[0].peer += f"; Exudyn's first 10 ms run {time.perf_counter() - start:.3f} s"
    return rows


# -- 1. the loop -------------------------------------------------------------------------
def loop(*, repeat=5, quick=False):
    """`flexure loop` defaults against Exudyn's n = 4 stage under the same controller."""
    from flexure.controllers.runner import run_loop

    exu = peer()

    def ours():
        result = run_loop("stage_planar_1dof")
        return result.wall_time_s, result.max_abs_error / abs(result.stroke)

    def theirs():
        result = exu.closed_loop(4)
        return result["wall_time_s"], result["error_ratio"]

    t = alternate({"flexure": ours, "exudyn": theirs if exu else None}, repeat, "loop")
    f = t["flexure"]
    rows = []
    if "exudyn" in t:
        e = t["exudyn"]
        ratio = f.median / e.median
        rows.append(Row("flexure loop defaults (stage_planar_1dof, 1.25 s at 4 kHz): wall "
                        "<= 0.5 x Exudyn's (n = 4 cables per spring)", f.text(),
                        e.text(), ratio, ratio <= 0.5))
        peer_error = f"limit 1e-7 (Exudyn n = 4: {e.info:.2e}, model difference)"
    else:
        rows.append(Row("flexure loop defaults: wall <= 0.5 x Exudyn's", f.text(),
                        "exudyn not installed"))
        peer_error = "limit 1e-7"
    rows.append(Row("flexure loop defaults: max |error| / stroke <= 1e-7", f"{f.info:.2e}",
                    peer_error, f.info / 1e-7, f.info <= 1e-7))
    return rows


# -- 2. real time loops ------------------------------------------------------------------
def realtime(*, repeat=5, quick=False):
    """The loop's defaults on the 3-DOF and the 19-DOF stage: simulated time / wall, and the
    plant's deviation from the same loop at rtol 1e-10."""
    from flexure.controllers.runner import run_loop

    limits = {"stage_planar_3dof": 10.0, "stage_spatial_19dof": 2.0}

    def case(scene):
        def run():
            result = run_loop(scene)
            return result.wall_time_s, result
        return run

    t = alternate({scene: case(scene) for scene in limits}, repeat, "realtime")
    rows = []
    for scene, limit in limits.items():
        timing = t[scene]
        result = timing.info
        log(f"realtime: {scene} at rtol 1e-10 (the accuracy reference)")
        reference = run_loop(scene, rtol=1e-10)
        stroke = abs(result.stroke)
        deviation = np.max(np.abs(result.position - reference.position)) / stroke
        speed = result.t[-1] / timing.median
        rows.append(Row(f"loop on {scene} (1 mm in 1 s + 0.25 s, 4 kHz): >= {limit:g} x real "
                        "time", f"{speed:.2f} x ({timing.text()}; tracking error "
                        f"{result.max_abs_error / stroke:.1e}, plant {deviation:.0e} from rtol "
                        f"1e-10, both of the stroke; rtol {result.settings['rtol']:g})",
                        f">= {limit:g} x", speed / limit, speed >= limit))
    return rows


# -- 3. the step: work-precision ---------------------------------------------------------
@dataclass
class Setting:
    """One flexure integrator setting of the scan and what it gave."""

    method: str
    max_order: int | None
    rtol: float
    error: float = np.inf
    wall: float = np.inf

    def label(self):
        order = "" if self.max_order is None else f":{self.max_order}"
        return f"{self.method}{order} rtol {self.rtol:.0e}"


class TooSlow(Exception):
    """A run stopped at its time cap: `wall` (s) spent, `fraction` of the 1 s simulated."""

    def __init__(self, wall, fraction):
        super().__init__(f"{wall:.1f} s for the first {fraction:.3f} s: about "
                         f"{wall / fraction:.0f} s for 1 s")
        self.wall, self.fraction = wall, fraction

    @property
    def estimate(self):
        """The whole run's wall (s), extrapolated linearly in simulated time."""
        return self.wall / max(self.fraction, 1e-6)


def flexure_step(model, method="cvode-bdf", rtol=1e-6, max_order=None, cap=None):
    """A 1 N step for 1 s from rest: (wall of the simulate call, x at STEP_TIMES, stats).

    `cap` (s): first a probe over the first PROBE s; when it shows that the whole run would
    take longer than `cap`, raise TooSlow instead of running it. (A deadline would make the
    simulator return to Python after every step, which changes the time measured.)"""
    from flexure.core import simulate

    if cap is not None:
        start = time.perf_counter()
        simulate(model, PROBE, inputs={"F": 1.0}, rtol=rtol, method=method,
                 max_order=max_order, output_times=STEP_TIMES[STEP_TIMES <= PROBE])
        probe = time.perf_counter() - start
        if probe / PROBE > cap:
            raise TooSlow(probe, PROBE)
    start = time.perf_counter()
    result = simulate(model, 1.0, inputs={"F": 1.0}, rtol=rtol, method=method,
                      max_order=max_order, output_times=STEP_TIMES)
    wall = time.perf_counter() - start
    return wall, result.outputs["x"], result.statistics


def capped_step(model, method="cvode-bdf", rtol=1e-6, cap=None):
    """flexure_step for `alternate`: (wall, stats); a capped run gives its extrapolated wall
    and stats {"extrapolated": TooSlow}."""
    try:
        return flexure_step(model, method, rtol, cap=cap)[0::2]
    except TooSlow as slow:
        log(f"  {slow}: the whole run extrapolated to {slow.estimate:.1f} s")
        return slow.estimate, {"extrapolated": slow}


def step_stats_text(timing):
    stats = timing.info
    if "extrapolated" in stats:
        slow = stats["extrapolated"]
        return (f"~{timing.median:.1f} s extrap. (not run: {slow.wall:.2f} s for the first "
                f"{slow.fraction:.2g} s)")
    return (f"{timing.text()}; {stats['steps']} steps, {stats['rhs_evaluations']} rhs")


def flexure_scan(model, rtols, stroke, cap):
    """Error against a rtol 1e-11 reference and wall time of the scanned settings.

    A method's scan stops at the first rtol that reaches the finest level (tighter ones are
    only slower) or that runs longer than `cap` seconds; `slowest` is the longest wall
    (s) a stopped run reached."""
    _, reference, _ = flexure_step(model, "cvode-adams", 1e-11)
    _, check, _ = flexure_step(model, "cvode-bdf", 1e-11)
    uncertainty = float(np.max(np.abs(check - reference)) / stroke)
    settings, capped = [], []
    for method, max_order in SCAN_METHODS:
        for rtol in rtols:
            s = Setting(method, max_order, rtol)
            try:
                s.wall, x, _ = flexure_step(model, method, rtol, max_order, cap=cap)
                s.error = float(np.max(np.abs(x - reference)) / stroke)
            except TooSlow as slow:
                log(f"  {model.name} {s.label()}: {slow}; tighter rtols not run")
                capped.append((s, slow))
                break
            except Exception as error:  # a failed setting reaches no level
                log(f"  {model.name} {s.label()}: failed ({error})")
            settings.append(s)
            log(f"  {model.name} {s.label()}: error {s.error:.2e}, {s.wall:.3f} s")
            if s.error <= min(LEVELS):
                break
    return settings, uncertainty, capped


def peer_step(exu, n, h):
    """Exudyn's 1 N step for 1 s at the fixed step h: (wall of SolveDynamic, None)."""
    return exu.step_response(n, h)[2], None


def peer_scan(exu, n, steps, reference_step):
    """Exudyn's (h, error / stroke, wall) rows and its reference's error / stroke."""
    reference = exu.converged_reference(n, h=reference_step)
    stage = exu.Stage.from_scene()
    floor = reference["estimate"] / (1.0 / stage.stiffness)
    rows = exu.work_precision(n, steps, reference=reference, repeat=1)
    for h, error, wall in rows:
        log(f"  Exudyn n = {n} h {h:.4g}: error {error:.2e}, {wall:.3f} s")
    return rows, floor, reference["observed_order"]


def peer_choice(rows, floor, level):
    """Exudyn's largest step verified to reach `level` (None if no run reaches it above
    3 x the reference's error), else the finest verified step to extrapolate from."""
    verified = [r for r in rows if r[1] > 3 * floor]
    good = [r for r in verified if r[1] <= level and level > 3 * floor]
    if good:
        return max(good, key=lambda r: r[0]), False
    return min(verified, key=lambda r: r[0]), True


def step(*, repeat=5, quick=False):
    """Work-precision of the 1 N step against Exudyn at equal error, and x real time."""
    from flexure.core import load_scene

    exu = peer()
    stroke = step_stroke()
    rtols = QUICK_RTOLS if quick else SCAN_RTOLS
    cap = 5.0 if quick else 20.0  # s, the longest scanned flexure run
    rows = []
    plain = None
    for n in (1, 4):
        model = load_scene("stage_planar_3dof") if n == 1 else refined_stage(n)
        log(f"step: flexure scan on {model.name} ({model.declared_dof_count} DOFs)")
        settings, uncertainty, capped = flexure_scan(model, rtols, stroke, cap)
        log(f"  flexure reference: cvode-adams vs cvode-bdf at 1e-11 differ by "
            f"{uncertainty:.1e} of the stroke")
        peer_rows = floor = None
        if exu is not None:
            log(f"step: Exudyn scan, n = {n}")
            steps = QUICK_PEER_STEPS if quick else PEER_STEPS
            peer_rows, floor, order = peer_scan(exu, n, steps, 1e-3 / (32 if quick else 128))
            log(f"  Exudyn reference error {floor:.1e} of the stroke, observed order "
                f"{order:.2f}")
        for level in LEVELS:
            reached = [s for s in settings if s.error <= level]
            ours = min(reached, key=lambda s: s.wall) if reached else None
            cases = {}
            if ours is not None:
                cases["flexure"] = (lambda s=ours, m=model: flexure_step(
                    m, s.method, s.rtol, s.max_order)[0::2])
            choice = None
            if peer_rows:
                choice, extrapolated = peer_choice(peer_rows, floor, level)
                cases["exudyn"] = lambda h=choice[0], n=n: peer_step(exu, n, h)
            t = alternate(cases, repeat, f"step n = {n}, level {level:g}")
            target = (f"1 N step, 1 s, {n} element(s) per spring ({model.declared_dof_count} "
                      f"DOFs): error <= {level:g} stroke faster than Exudyn")
            if ours is None:
                best = min((s.error for s in settings), default=np.inf)
                flexure_text = (f"not reached within {cap:g} s per run (best error "
                                f"{best:.1e}; capped: "
                                + ", ".join(f"{s.label()} ~{slow.estimate:.0f} s"
                                            for s, slow in capped) + ")")
            else:  # the scan's error: the runs are deterministic
                flexure_text = (f"{t['flexure'].text()} [{ours.label()}, error "
                                f"{ours.error:.1e}]")
            if choice is None:
                rows.append(Row(target, flexure_text, "exudyn not run"))
                continue
            h, peer_error = choice[0], choice[1]
            peer_wall = t["exudyn"].median
            if extrapolated:
                h_needed = h * (level / peer_error) ** 0.5
                peer_wall *= h / h_needed
                peer_text = (f"~{peer_wall:.2f} s extrap. (h ~ {h_needed:.2g} s from "
                             f"h {h:.3g} s: error {peer_error:.1e}, {t['exudyn'].median:.3f} s;"
                             f" reference floor {floor:.0e})")
            else:
                peer_text = f"{t['exudyn'].text()} [h {h:.4g} s, error {peer_error:.1e}]"
            if ours is None:
                rows.append(Row(target, flexure_text, peer_text, cap / peer_wall, False))
                continue
            ratio = t["flexure"].median / peer_wall
            rows.append(Row(target, flexure_text, peer_text, ratio, ratio < 1))
        if n == 1:
            log(f"step: stage_planar_3dof at rtol 1e-6, {STEP_METHOD}")
            plain = alternate({"flexure": lambda m=model: capped_step(m, STEP_METHOD, 1e-6,
                                                                      cap)},
                              repeat, "step rtol 1e-6")["flexure"]
    speed = 1.0 / plain.median
    rows.append(Row(f"1 N step, 1 s, stage_planar_3dof at rtol 1e-6 ({STEP_METHOD}): >= 10 x real "
                    "time", f"{speed:.2f} x ({step_stats_text(plain)})", ">= 10 x", speed / 10,
                    speed >= 10))
    return rows


# -- 4. the refined stage and the cost of an evaluation --------------------------------------
def rhs_cost(model, *, seconds=0.2):
    """Seconds per engine RHS evaluation at a deformed state, and a short run's integrator
    seconds per rhs evaluation.

    The engine's RHS operation is called from Python in a loop; the same call with an
    operation code the engine does not know (it returns at once) is timed alike and
    subtracted: the cost of the ctypes call and of unpacking the model (about 8 us), which
    the integrator's C callbacks do not pay in the same way. Returns (net s, call s, run s)."""
    from flexure.core import Simulator

    sim = Simulator(model, rtol=1e-6)
    sim.set_inputs([1.0])
    sim.advance(0.01)
    run_cost = sim.statistics["wall_time_s"] / sim.statistics["rhs_evaluations"]
    y = np.ascontiguousarray(sim.state, dtype=float)
    sim.derivative(0.0, y)  # prepares the engine's inputs and reference state
    try:
        from flexure.core.engine import data as engine_data
        from flexure.core.engine import engine

        ydot = np.empty_like(y)
        data, call = sim.data, engine.call
        assert call(data, engine.OP_RHS, y, ydot) == engine_data.OK
        null_op = 1000  # no operation: the entry returns -1 after unpacking the model
        assert call(data, null_op, y, ydot) == -1

        def evaluate(count, op=engine.OP_RHS):
            for _ in range(count):
                call(data, op, y, ydot)
    except (ImportError, AttributeError, AssertionError):  # the engine's API moved
        null_op = None

        def evaluate(count, op=None):
            for _ in range(count):
                sim.derivative(0.0, y)
    start = time.perf_counter()
    evaluate(100)
    count = max(100, int(seconds / max((time.perf_counter() - start) / 100, 1e-9)))
    batches, nulls = [], []
    for _ in range(5):  # alternating the two, the median of each
        start = time.perf_counter()
        evaluate(count)
        batches.append((time.perf_counter() - start) / count)
        if null_op is not None:
            start = time.perf_counter()
            evaluate(count, null_op)
            nulls.append((time.perf_counter() - start) / count)
    total = statistics.median(batches)
    overhead = statistics.median(nulls) if nulls else 0.0
    return total - overhead, total, run_cost


def refined(*, repeat=5, quick=False):
    """The undamped 4-PLBEAM stage's 1 s step, and the cost of an evaluation against n."""
    rows = []
    model = refined_stage(4, damped=False)
    cap = 10.0 if quick else None
    t = alternate({"flexure": lambda: capped_step(model, REFINED_METHOD, 1e-6, cap)}, repeat,
                  "refined undamped step", budget=20.0 if quick else 30.0)["flexure"]
    accuracy = ""
    if not quick and "extrapolated" not in t.info:
        log("refined: its error against esdirk at rtol 1e-9")
        _, x, _ = flexure_step(model, REFINED_METHOD, 1e-6)
        _, reference, _ = flexure_step(model, "esdirk", 1e-9)
        error = np.max(np.abs(x - reference)) / step_stroke()
        accuracy = f"; max |x - x_ref| / stroke {error:.1e} (reference: esdirk at rtol 1e-9)"
    rows.append(Row(f"refined stage, 4 PLBEAMs per spring ({model.declared_dof_count} DOFs), "
                    f"undamped 1 s step at rtol 1e-6 ({REFINED_METHOD}): wall <= 2 s",
                    step_stats_text(t) + accuracy, "<= 2 s", t.median / 2.0, t.median <= 2.0))
    per_element = {}
    for n in (1, 2, 4, 8, 16):
        model = refined_stage(n)
        log(f"refined: rhs cost, n = {n} ({model.declared_dof_count} DOFs)")
        cost, call_cost, run_cost = rhs_cost(model, seconds=0.05 if quick else 0.2)
        elements = 2 * n + 1
        per_element[n] = cost / elements
        dofs = model.declared_dof_count
        text = (f"{1e6 * cost:.2f} us/eval, {1e6 * cost / elements:.2f} us/element "
                f"(the call from Python {1e6 * call_cost:.1f} us; in a run "
                f"{1e6 * run_cost:.1f} us per rhs incl. Jacobians, solves)")
        if dofs == 93:
            rows.append(Row(f"one rhs evaluation, n = {n} per spring ({dofs} DOFs, {elements} "
                            "elements): <= 100 us", text, "<= 100 us", 1e6 * cost / 100,
                            cost <= 100e-6))
        else:
            rows.append(Row(f"one rhs evaluation, n = {n} per spring ({dofs} DOFs, {elements} "
                            "elements)", text, ""))
    growth = per_element[16] / per_element[4]
    rows.append(Row("rhs cost grows linearly with the element count: us/element at n = 16 "
                    "<= 1.5 x that at n = 4", f"{1e6 * per_element[16]:.2f} vs "
                    f"{1e6 * per_element[4]:.2f} us/element", "<= 1.5", growth / 1.5,
                    growth <= 1.5))
    return rows


# -- 5. the FMU ------------------------------------------------------------------------------
FMU_STEP = 1e-3  # s
FIRST_INSTANTIATE = r"""
import json, sys, time
start = time.perf_counter()
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
md = read_model_description(sys.argv[1])
vr = {v.name: v.valueReference for v in md.modelVariables}
folder = extract(sys.argv[1])
ready = time.perf_counter()
fmu = FMU2Slave(guid=md.guid, unzipDirectory=folder,
                modelIdentifier=md.coSimulation.modelIdentifier, instanceName="first")
fmu.instantiate()
fmu.setupExperiment(startTime=0.0)
fmu.enterInitializationMode()
fmu.exitInitializationMode()
fmu.setReal([vr["F"]], [1.0])
fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-3)
x = fmu.getReal([vr["x"]])[0]
done = time.perf_counter()
fmu.terminate()
fmu.freeInstance()
print(json.dumps({"first_step_s": done - ready, "x": x}))
"""


class FmuMaster:
    """An extracted FMU, instantiated and initialised by fmpy's FMU2Slave per `run`."""

    def __init__(self, path):
        from fmpy import extract, read_model_description

        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.folder = extract(str(path))

    def run(self, steps, force=1.0, *, direct=False):
        """Wall (s) of `steps` setReal / doStep / getReal at FMU_STEP (after initialise), and
        (x, (the slave's simulator time inside `advance`, its time inside do_step) or None).

        Through FMU2Slave's Python methods, or with `direct` through the FMU's C functions
        themselves (fmpy's ctypes handles, value arrays allocated once), as a compiled master
        such as libcosim calls them: the FMU's cost without the Python master's own."""
        import gc
        from ctypes import c_double, c_uint

        from fmpy.fmi2 import FMU2Slave, fmi2True

        def slaves():  # the Python slaves of this FMU alive in this process (pythonfmu)
            return {id(o): o for o in gc.get_objects()
                    if type(o).__name__ == self.md.coSimulation.modelIdentifier
                    and hasattr(o, "simulator")}

        before = slaves()
        fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.folder,
                        modelIdentifier=self.md.coSimulation.modelIdentifier,
                        instanceName="bench")
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        inputs, outputs = [self.vr["F"]], [self.vr["x"]]
        new = [o for key, o in slaves().items() if key not in before]
        if direct:
            set_real, do_step, get_real = (getattr(fmu.dll, name) for name in (
                "fmi2SetReal", "fmi2DoStep", "fmi2GetReal"))
            component = fmu.component
            vr_in, vr_out = (c_uint * 1)(*inputs), (c_uint * 1)(*outputs)
            value, y = (c_double * 1)(force), (c_double * 1)()
            start = time.perf_counter()
            for k in range(steps):
                if set_real(component, vr_in, 1, value) or do_step(
                        component, k * FMU_STEP, FMU_STEP, fmi2True) or get_real(
                        component, vr_out, 1, y):
                    raise RuntimeError(f"the FMU answered an error status at step {k}")
            wall = time.perf_counter() - start
            x = y[0]
        else:
            start = time.perf_counter()
            for k in range(steps):
                fmu.setReal(inputs, [force])
                fmu.doStep(currentCommunicationPoint=k * FMU_STEP,
                           communicationStepSize=FMU_STEP)
                x = fmu.getReal(outputs)[0]
            wall = time.perf_counter() - start
        inside = None
        if len(new) == 1:  # (its simulator's time inside advance, its time inside do_step)
            inside = (new[0].simulator.statistics["wall_time_s"], new[0].step_seconds)
        fmu.terminate()
        fmu.freeInstance()
        return wall, (x, inside)

    def close(self):
        shutil.rmtree(self.folder, ignore_errors=True)


def in_process_steps(model, steps, force=1.0, *, method=None, rtol=None):
    """The same 1 ms advances on a Simulator, with the FMU's defaults unless given: (wall,
    (engine s, x)), the engine time being the simulator's own time inside `advance`."""
    from flexure.core import Simulator
    from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS

    sim = Simulator(model, method=method or METHODS[0], rtol=rtol or DEFAULT_RTOL)
    start = time.perf_counter()
    for k in range(steps):
        sim.set_inputs([force])
        sim.advance((k + 1) * FMU_STEP)
        x = sim.outputs()[0]
    return time.perf_counter() - start, (sim.statistics["wall_time_s"], x)


def first_instantiate(path, cache_dir=None):
    """(whole process s, first instantiate + initialise + doStep s) in a fresh process."""
    import json

    env = dict(os.environ)
    if cache_dir is not None:
        env["FLEXURE_CACHE_DIR"] = str(cache_dir)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", FIRST_INSTANTIATE, str(path)], env=env,
                          capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"the FMU's first instantiate failed: {done.stderr[-2000:]}")
    return wall, json.loads(done.stdout.strip().splitlines()[-1])["first_step_s"]


def fmu(*, repeat=5, quick=False):
    """stage_planar_3dof's FMU stepped by fmpy at 1 ms: x real time, overhead, latency."""
    from flexure.core import load_scene
    from flexure.fmu import build_scene_fmu
    from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS

    steps = int(round(1.0 / FMU_STEP))
    rows = []
    with tempfile.TemporaryDirectory(prefix="flexure_compare_") as temp:
        temp = Path(temp)
        log("fmu: building stage_planar_3dof.fmu")
        path = build_scene_fmu("stage_planar_3dof", temp / "stage_planar_3dof.fmu")
        master = FmuMaster(path)
        model = load_scene("stage_planar_3dof")
        engine_times = []

        def ours():
            wall, (engine, x) = in_process_steps(model, steps)
            engine_times.append(engine)
            return wall, x

        try:
            master.run(10)  # loads the slave into this process
            beyond = {"fmu": [], "fmu direct": []}  # per run: 1 - its simulator's time / wall

            def fmu_run(direct):
                wall, (x, inside) = master.run(steps, direct=direct)
                if inside is not None:
                    beyond["fmu direct" if direct else "fmu"].append(1.0 - inside[0] / wall)
                return wall, (x, inside)

            t = alternate({"fmu": lambda: fmu_run(False), "fmu direct": lambda: fmu_run(True),
                           "in-process": ours}, repeat, "fmu")
        finally:
            master.close()
        f, d, p = t["fmu"], t["fmu direct"], t["in-process"]
        log("fmu: the accuracy reference (CVODE BDF at rtol 1e-11, in process)")
        exact = in_process_steps(model, steps, method="cvode-bdf", rtol=1e-11)[1][1]
        motion = abs(exact - model.initial_coordinates[model.outputs[0].coordinate])
        engine = statistics.median(engine_times)
        speed = 1.0 / f.median
        # of the FMU, for a compiled master's calls: each run's wall against the time of the
        # FMU's own simulator inside advance in that run (robust to the machine's load
        # changing between runs), the median over the runs
        overhead = statistics.median(beyond["fmu direct"])
        overhead_python_master = statistics.median(beyond["fmu"])
        same = abs(f.info[0] - p.info)
        split = ""
        if f.info[1] is not None:  # from the last FMU run
            simulator, slave = f.info[1]
            last = f.walls[-1]
            split = (f"; of the last run's wall {last:.3f} s: the slave's simulator inside "
                     f"advance {simulator:.3f} s, flexure's slave in Python beyond it "
                     f"{100 * (slave - simulator) / last:.1f} %, fmpy and pythonfmu's binary "
                     f"{100 * (last - slave) / last:.1f} %")
        rows.append(Row(f"FMU of stage_planar_3dof by fmpy, 1 ms steps for 1 s ({METHODS[0]}, "
                        f"rtol {DEFAULT_RTOL:g}, its defaults): >= 10 x real time",
                        f"{speed:.2f} x ({f.text()}; x after 1 s "
                        f"{abs(f.info[0] - exact) / motion:.1e} of its motion from CVODE at "
                        "rtol 1e-11)", ">= 10 x", speed / 10,
                        speed >= 10))
        rows.append(Row("FMU overhead beyond the engine (1 - engine / FMU wall) <= 10 %, "
                        "the master calling the FMU's C functions directly (as a compiled "
                        "master does)",
                        f"{100 * overhead:.1f} % (median of each run's 1 - its simulator's "
                        f"time / its wall; FMU {d.text()}; the in-process loop {p.text()}, "
                        f"its engine {engine:.3f} s; |x_FMU - x| = {same:.0e} m)", "<= 10 %",
                        overhead / 0.10, overhead <= 0.10))
        rows.append(Row("the same through fmpy's FMU2Slave methods (the master's Python "
                        "wrapper included)",
                        f"{100 * overhead_python_master:.1f} % (FMU {f.text()}{split})",
                        "(information)"))
        log("fmu: first instantiate in fresh processes")
        warm = [first_instantiate(path) for _ in range(max(1, min(repeat, 3)))]
        warm_text = (f"warm cache: {statistics.median(w[1] for w in warm):.2f} s "
                     f"(process {statistics.median(w[0] for w in warm):.2f} s)")
        if quick:
            cold_text = "cold cache: not measured (--quick)"
        else:
            with tempfile.TemporaryDirectory(prefix="flexure_cold_cache_") as cold:
                log("fmu: first instantiate with an empty FLEXURE_CACHE_DIR (compiles)")
                process, first = first_instantiate(path, cold)
            cold_text = f"empty cache: {first:.1f} s (process {process:.1f} s)"
        rows.append(Row("FMU's first instantiate + initialise + doStep in a fresh process",
                        f"{warm_text}; {cold_text}", "(latency, no target)"))
    return rows


# -- 6. start-up -----------------------------------------------------------------------------
def command_wall(command):
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed: {done.stderr[-2000:]}")
    return wall, None


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


FUNCTIONS = {"loop": loop, "realtime": realtime, "step": step, "refined": refined, "fmu": fmu,
             "startup": startup}


def environment():
    """One line on the machine and the versions."""
    import numba

    import flexure.core

    parts = [f"flexure {flexure.core.__version__}", f"Python {platform.python_version()}",
             f"numpy {np.__version__}", f"numba {numba.__version__}"]
    try:
        import exudyn

        parts.append(f"Exudyn {exudyn.__version__}")
    except ImportError:
        parts.append("Exudyn not installed")
    parts.append(f"{platform.machine()} {os.cpu_count()} CPUs")
    if hasattr(os, "getloadavg"):
        parts.append(f"load average {os.getloadavg()[0]:.2f}")
    return ", ".join(parts)


def run(groups=GROUPS, *, repeat=5, quick=False):
    """Measure `groups`; returns the rows (the warm-up's first)."""
    rows = warmup(repeat=repeat, quick=quick) if set(groups) - {"startup"} else []
    for name in groups:
        log(f"== {name}")
        rows.extend(FUNCTIONS[name](repeat=repeat, quick=quick))
    return rows


def text_table(rows, title):
    from flexure.core.reporting.tables import format_table

    return format_table(HEADERS, [r.cells() for r in rows], title=title)


def markdown(rows, title):
    from flexure.core.reporting.tables import markdown_table

    return f"{title}\n\n" + markdown_table(HEADERS, [[c.replace("|", "\\|") for c in r.cells()]
                                                     for r in rows]) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="a short run: fewer tolerances and steps, no cold-cache latency")
    parser.add_argument("--repeat", type=int, default=5,
                        help="timed runs per figure, the median reported (default 5)")
    parser.add_argument("--only", default=None,
                        help=f"comma-separated row groups among {', '.join(GROUPS)}")
    parser.add_argument("--markdown", metavar="FILE", help="also write the table as markdown")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error("--repeat must be at least 1")
    groups = GROUPS
    if args.only:
        groups = tuple(g.strip() for g in args.only.split(",") if g.strip())
        unknown = [g for g in groups if g not in GROUPS]
        if unknown:
            parser.error(f"unknown group(s) {', '.join(unknown)}; expected {', '.join(GROUPS)}")
    before = environment()
    rows = run(groups, repeat=args.repeat, quick=args.quick)
    load = f", load average at the end {os.getloadavg()[0]:.2f}" if hasattr(
        os, "getloadavg") else ""
    title = (f"flexure vs Exudyn, median of {args.repeat} (min in brackets)"
             f"{' --quick' if args.quick else ''}; {before}{load}")
    print(text_table(rows, title))
    if args.markdown:
        Path(args.markdown).write_text(markdown(rows, title))
        log(f"markdown written to {args.markdown}")
    met = [r.met for r in rows if r.met is not None]
    print(f"\n{sum(met)} of {len(met)} targets met")
    return 0


if __name__ == "__main__":
    sys.exit(main())
