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
          from compiled code (`compiled_master`, as libcosim does); the median over the
          runs. For information: the floor (a bare pythonfmu slave around the same
          simulator); the C functions called from a Python loop (the master's ctypes calls
          included); FMU2Slave's Python methods, split into flexure's slave in Python
          beyond the engine (the slave's time inside do_step less its simulator's) and the
          rest: fmpy's Python and ctypes calls and pythonfmu's binary (setReal, doStep,
          getReal). Also the latency of the first instantiate + initialise + doStep in a
          fresh process, with an empty FLEXURE_CACHE_DIR (the
          engine compiles) and with the warm cache.
manipulator
          The chapter's 6 mm xy move (`manipulator.py`) on the reduced model's linearisation
          (507 DOFs, stepped exactly): >= 1 x real time; the same move on the nonlinear
          75-DOF control model: >= 1 x real time (issue 35, item 4); on the nonlinear 507-DOF
          reduced model, a shorter move once: >= 0.2 x real time by the loop's CPU. The
          manipulator's analyses as whole commands in CPU seconds (`manipulator_analyses.py`,
          issue 35):
          the 816-DOF model's ten lowest modes <= 3 s, `flexure reduce manipulator_e1 --keep 7
          --tol 1` <= 5 s, `examples/manipulator_report.py` <= 20 s.
spatial   Issue 35, item 4 (`spatial.py`): one rhs of manipulator_control per DOF against the
          refined planar stage's (n = 16, 93 DOFs): <= 3; its Jacobian <= 20 rhs (one mass
          matrix beside it); a spatial cantilever of 16 and 64 BEAMs (96, 384 DOFs): one
          implicit step (esdirk, rtol 1e-6) at 384 DOFs <= Exudyn's (measured alternating
          where exudyn is installed, else the issue's 3.4 ms), growing at most as n^1.2;
          and both codes' CPU per simulated ms at an equal tip error, 1e-3 of the
          deflection (`cantilever_precision.py`; --plot FILE writes error against CPU).
statics   Issue 35, item 1 (`statics.py`): one static solve through the compiled engine over
          the numpy reference (CPU, alternating): at most 1 where the engine is the statics'
          default (manipulator_control); cantilevers of 96, 192, 384 DOFs and
          manipulator_reduced for information.
startup   Whole processes as a user starts them, warm cache, in CPU seconds (user + system):
          `python -c "import flexure.core"` (<= 0.5 s), `flexure analyze truss_1dof_x`
          (<= 0.5 s), `flexure loop --no-plot` (<= 1.5 s) beside Exudyn's whole process for
          the same loop (`exudyn_loop_process.py`: the controller's numbers from flexure's
          design, saved beforehand), `flexure loop` writing its plot (for information),
          `flexure simulate stage_planar_3dof --t-end 0.01 --input F=1` (<= 2 x Exudyn's
          process for the same 10 ms step); and, but with --quick, the first `flexure loop`
          with an empty FLEXURE_CACHE_DIR (<= 30 s of CPU: it compiles).
portable  The engine compiled for the portable CPU target an FMU carries (NUMBA_CPU_NAME=
          generic) against this machine's target: CPU seconds of the same work in child
          processes of either target, alternating, the median of the pairs' ratios (1000
          advances of 1 ms of stage_planar_3dof as an FMU steps it, and a 1 s step with
          `simulate`). The FMU's first instantiate + initialise + doStep in a host without
          flexure (FLEXURE_FMU_OWN_COPY=1) with an empty cache, with the engine it carries
          (<= 5 s of CPU) and, once, compiling instead; what the engine adds to the FMU.

Before any timing one warm-up run loads the compiled engine (compiling it when the on-disk
cache is empty); its latency is the table's first row, not part of any other figure.

Usage
-----
    python examples/benchmarks/compare.py [--quick] [--repeat N] [--only loop,step]
                                          [--markdown FILE] [--plot FILE]

The row groups live in this folder's modules (loops, step_scan, refined, fmu_overhead,
manipulator, spatial, statics, latency, portable), the shared machinery in measure, table and
stage_models.

Requires flexure and, for the peer columns, exudyn (``pip install ".[bench]"``); without
exudyn the flexure side and the limits are still measured.
"""

import argparse
import os
import sys
from pathlib import Path

# Run by its path, this file has no package for its relative imports: it joins
# examples.benchmarks, found from the repository's root (PEP 366; see __init__.py).
if not __package__:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    __package__ = "examples.benchmarks"

from .fmu_overhead import fmu  # noqa: E402
from .latency import startup, warmup  # noqa: E402
from .loops import loop, realtime  # noqa: E402
from .manipulator import manipulator  # noqa: E402
from .measure import log  # noqa: E402
from .portable import portable  # noqa: E402
from .refined import refined  # noqa: E402
from .spatial import spatial  # noqa: E402
from .statics import statics  # noqa: E402
from .step_scan import step  # noqa: E402
from .table import environment, markdown, text_table  # noqa: E402

GROUPS = ("loop", "realtime", "step", "refined", "fmu", "manipulator", "spatial", "statics",
          "startup", "portable")
FUNCTIONS = {"loop": loop, "realtime": realtime, "step": step, "refined": refined, "fmu": fmu,
             "manipulator": manipulator, "spatial": spatial, "statics": statics,
             "startup": startup, "portable": portable}


def run(groups=GROUPS, *, repeat=5, quick=False, plot=None):
    """Measure `groups`; returns the rows (the warm-up's first). `plot`: where the spatial
    group writes the cantilever's work-precision plot (PNG), or None."""
    rows = warmup(repeat=repeat, quick=quick) if set(groups) - {"startup"} else []
    for name in groups:
        log(f"== {name}")
        extra = {"plot": plot} if name == "spatial" else {}
        rows.extend(FUNCTIONS[name](repeat=repeat, quick=quick, **extra))
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="a short run: fewer tolerances and steps, no cold-cache latency")
    parser.add_argument("--repeat", type=int, default=5,
                        help="timed runs per figure, the median reported (default 5)")
    parser.add_argument("--only", default=None,
                        help=f"comma-separated row groups among {', '.join(GROUPS)}")
    parser.add_argument("--markdown", metavar="FILE", help="also write the table as markdown")
    parser.add_argument("--plot", metavar="FILE",
                        help="the spatial group: write the cantilever's work-precision plot "
                             "(PNG: tip error against CPU per simulated ms, both codes)")
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
    rows = run(groups, repeat=args.repeat, quick=args.quick, plot=args.plot)
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
