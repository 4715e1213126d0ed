"""The compiled engine's warm speed: the loop's own wall time on three stages, medians.

Runs `run_loop` (the loop of `flexure loop`) on stage_planar_1dof, stage_planar_3dof and
stage_spatial_19dof in this process, the scenes in turn for `--repeat` rounds after one
warm-up round (which compiles, or loads the compiled code from the cache), and prints per
scene the median and the smallest of the loop's own wall time (`LoopResult.wall_time_s`, s).
A tool for comparing two builds of the engine (another optimisation level, another layout
of the compiled code): run it for each, alternating, on the same machine.

    python -m examples.benchmarks.engine_speed --repeat 7
"""

import argparse
import statistics

SCENES = ("stage_planar_1dof", "stage_planar_3dof", "stage_spatial_19dof")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="timed rounds")
    parser.add_argument("--scenes", default=",".join(SCENES), help="comma-separated scenes")
    args = parser.parse_args(argv)
    from flexure.controllers.runner import run_loop

    scenes = args.scenes.split(",")
    walls = {scene: [] for scene in scenes}
    for round_ in range(args.repeat + 1):
        for scene in scenes:
            wall = run_loop(scene).wall_time_s
            if round_:  # the first round compiles or loads: not timed
                walls[scene].append(wall)
    print(f"{'scene':22s} {'median (s)':>11s} {'min (s)':>9s}")
    for scene in scenes:
        print(f"{scene:22s} {statistics.median(walls[scene]):11.4f} {min(walls[scene]):9.4f}")


if __name__ == "__main__":
    main()
