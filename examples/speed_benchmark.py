"""Speed of the nonlinear simulation: wall time per simulated second for the planar scenes.

For each scene: 1 s (by default) of a 1 N step on the input F from rest, CVODE BDF at
rtol 1e-6 with the model Jacobian; for stage_planar_3dof also BDF limited to order 2, CVODE
Adams, IDA and IDA limited to order 2. Printed: steps, right-hand-side (rhs) and Jacobian
evaluations, wall and CPU time per simulated second, time per rhs evaluation and the
real-time factor (simulated over wall time; the target for stage_planar_3dof is 10).
With --profile, the cProfile of the stage_planar_3dof run: what dominates.

    python examples/speed_benchmark.py [--t-end 1] [--rtol 1e-6] [--profile]
"""

import argparse
import cProfile
import io
import pstats
import time

from flexure.core import load_scene, simulate
from flexure.core.reporting.tables import format_table

SCENES = ("truss_1dof_x", "truss_1dof_e", "stage_planar_1dof", "stage_planar_3dof")


def measure(scene, *, t_end=1.0, rtol=1e-6, method="cvode-bdf", max_order=None):
    """One run: a dict of the figures of the table."""
    model = load_scene(scene)
    inputs = {"F": 1.0} if any(p.name == "F" for p in model.inputs) else None
    cpu, wall = time.process_time(), time.perf_counter()
    result = simulate(model, t_end, inputs=inputs, method=method, rtol=rtol,
                      max_order=max_order)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    stats = result.statistics
    return {"scene": scene, "method": method if max_order is None else
            f"{method} (order <= {max_order})", "steps": stats["steps"],
            "rhs": stats["rhs_evaluations"], "jacobians": stats["jacobian_evaluations"],
            "wall_per_s": wall / t_end, "cpu_per_s": cpu / t_end,
            "us_per_rhs": 1e6 * stats["wall_time_s"] / max(1, stats["rhs_evaluations"]),
            "realtime": t_end / wall}


def table(rows):
    return format_table(
        ["scene", "method", "steps", "rhs evals", "Jacobians", "wall s / sim s",
         "CPU s / sim s", "us / rhs", "x real time"],
        [(r["scene"], r["method"], r["steps"], r["rhs"], r["jacobians"], r["wall_per_s"],
          r["cpu_per_s"], r["us_per_rhs"], r["realtime"]) for r in rows])


def profile(scene="stage_planar_3dof", *, t_end=1.0, rtol=1e-6, top=15):
    """The cProfile table (by own time) of one run, as text."""
    profiler = cProfile.Profile()
    profiler.enable()
    measure(scene, t_end=t_end, rtol=rtol)
    profiler.disable()
    stream = io.StringIO()
    pstats.Stats(profiler, stream=stream).sort_stats("tottime").print_stats(top)
    return stream.getvalue()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=1.0)
    parser.add_argument("--rtol", type=float, default=1e-6)
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args(argv)
    rows = [measure(s, t_end=args.t_end, rtol=args.rtol) for s in args.scenes.split(",")]
    if "stage_planar_3dof" in args.scenes:
        for method, max_order in (("cvode-bdf", 2), ("cvode-adams", None), ("ida", None),
                                  ("ida", 2)):
            rows.append(measure("stage_planar_3dof", t_end=args.t_end, rtol=args.rtol,
                                method=method, max_order=max_order))
    print(f"{args.t_end:g} s of a 1 N step at rtol {args.rtol:g}")
    print(table(rows))
    if args.profile:
        print(profile(t_end=args.t_end, rtol=args.rtol))
    return rows


if __name__ == "__main__":
    main()
