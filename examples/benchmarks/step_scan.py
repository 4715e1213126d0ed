"""The step row group: the work-precision scan of a 1 N step for 1 s, flexure's integrator
settings against Exudyn's fixed steps at equal error, and x real time at rtol 1e-6; the
timed step runs (`flexure_step`, `capped_step`) serve the refined group too."""

import time
from dataclasses import dataclass

import numpy as np

from .measure import alternate, log, peer
from .stage_models import refined_stage, step_stroke
from .table import Row

LEVELS = (1e-3, 1e-5, 1e-7)  # error levels of the step, fractions of the stroke
SCAN_METHODS = (("esdirk", None), ("esdirk3", None), ("esdirk2", None), ("cvode-bdf", None),
                ("cvode-bdf", 2), ("cvode-adams", None), ("ida", None))
STEP_METHOD = "esdirk"  # the integrator of the 3-DOF step at rtol 1e-6
SCAN_RTOLS = tuple(10.0 ** -k for k in range(3, 11))
QUICK_RTOLS = (1e-3, 1e-4, 1e-5, 1e-6)
PEER_STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5, 1.5625e-5)
QUICK_PEER_STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4)
STEP_TIMES = np.linspace(0.0, 1.0, 1001)
PROBE = 0.1  # s, the simulated time of a probe run (see flexure_step)


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
