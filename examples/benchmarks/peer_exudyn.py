"""The peer side of flexure's speed benchmark: the planar leaf-spring stage in Exudyn.

The same work as flexure on stage_planar_3dof (a 1 N step for 1 s, `step_response`,
`work_precision`) and stage_planar_1dof (`flexure loop` with its defaults, `closed_loop`),
modelled with Exudyn's ANCF cable elements and integrated by its generalized-alpha solver.

The model, its checks against flexure's and what is not flexure's model: `exudyn_stage`.

Usage
-----
    python examples/benchmarks/peer_exudyn.py [--n 1,4] [--repeat 3]

prints the frequencies, the work-precision rows for n = 1 and 4, and the closed loop.
Requires exudyn (``pip install flexure[bench]``); `closed_loop` also flexure.controllers.
"""

import sys
import time
from pathlib import Path

import exudyn as exu
import numpy as np

# Run by its path, this file has no package for its relative imports: it joins
# examples.benchmarks, found from the repository's root (PEP 366; see __init__.py).
if not __package__:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    __package__ = "examples.benchmarks"

from .exudyn_stage import Stage, build, natural_frequencies, simulation_settings  # noqa: E402

STEPS = (1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5)  # s, fixed steps of work_precision
REFERENCE_STEP = 1e-3 / 128  # s, the step of `converged_reference`


def step_response(n, h, t_end=1.0, force=1.0, *, newton_tolerance=1e-8, newton_absolute=None,
                  **options):
    """A step of `force` (N) from rest on the bar's left end, in x.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    h : float
        Fixed step (s).
    t_end : float
        Simulated time (s).
    force : float
        The step (N), on from t = 0.
    newton_tolerance, newton_absolute : float
        Newton's relative and absolute (N) tolerances, see `simulation_settings`.
    **options
        stage, reduced_integration: passed to `build`.

    Returns
    -------
    t : array
        Times of the steps (s), from 0.
    x : array
        x position of the bar's left end (m) at those times (0 at rest).
    wall : float
        Wall time (s) of SolveDynamic alone (the model is built before).
    """
    model = build(n, force=force, **options)
    settings = simulation_settings(h, t_end, n=n, newton_tolerance=newton_tolerance,
                                   newton_absolute=newton_absolute)
    start = time.perf_counter()
    model.mbs.SolveDynamic(settings)
    wall = time.perf_counter() - start
    data = model.mbs.GetSensorStoredData(model.sensor)
    return data[:, 0], data[:, 1], wall


def converged_reference(n, t_end=1.0, force=1.0, *, h=REFERENCE_STEP, **options):
    """The step response at a small fixed step, Richardson-checked.

    Runs `h`, 2 `h` and 4 `h` with Newton at a tight tolerance (relative 1e-10, absolute
    1e-9 n^2 N). Generalized-alpha is of second order, so the error of the `h` run is about
    (x_h - x_2h) / 3 (`estimate`), and `observed_order`, log2 of the ratio of the largest
    differences (x_2h - x_4h) / (x_h - x_2h), confirms the order (2 when the runs are in
    the asymptotic range). The default h = 1/128 ms divides every one of `STEPS`, so their
    times are reference times.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    t_end, force : float
        Simulated time (s) and step (N).
    h : float
        The reference step (s).
    **options
        stage, reduced_integration: passed to `build`.

    Returns
    -------
    dict
        t (s), x (m): the `h` run; estimate (m): max |x_h - x_2h| / 3; observed_order;
        h (s); wall_time_s (s) of the three runs.
    """
    tight = {"newton_tolerance": 1e-10, "newton_absolute": 1e-9 * n**2}
    runs = [step_response(n, h * 2**j, t_end, force, **tight, **options) for j in range(3)]
    (t, x, _), (t2, x2, _), (t4, x4, _) = runs
    d1 = np.max(np.abs(np.interp(t4, t, x) - np.interp(t4, t2, x2)))
    d2 = np.max(np.abs(np.interp(t4, t2, x2) - x4))
    return {"t": t, "x": x, "estimate": float(np.max(np.abs(np.interp(t2, t, x) - x2)) / 3),
            "observed_order": float(np.log2(d2 / d1)), "h": h,
            "wall_time_s": sum(r[2] for r in runs)}


def work_precision(n, steps=STEPS, t_end=1.0, force=1.0, *, reference=None, repeat=3,
                   **options):
    """Error against the converged reference and wall time, per fixed step.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    steps : sequence of float
        The fixed steps (s).
    t_end, force : float
        Simulated time (s) and step (N).
    reference : dict, optional
        `converged_reference(n, t_end, force)`, computed when not given.
    repeat : int
        Runs per step; the wall time is the shortest (the machine is shared).
    **options
        stage, reduced_integration: passed to `build`.

    Returns
    -------
    list of tuple
        (h, error / stroke, wall time) per step: h (s); the largest |x - x_ref| over the
        run's step times divided by the stroke, the static deflection F l^3 / (24 EI)
        (1/945 m for 1 N); the wall time of SolveDynamic (s), the best of `repeat`.
    """
    stage = options.get("stage") or Stage.from_scene()
    reference = reference or converged_reference(n, t_end, force, **options)
    stroke = abs(force) / stage.stiffness
    rows = []
    for h in steps:
        runs = [step_response(n, h, t_end, force, **options) for _ in range(repeat)]
        (t, x, _), wall = runs[0], min(r[2] for r in runs)
        error = np.max(np.abs(x - np.interp(t, reference["t"], reference["x"])))
        rows.append((float(h), float(error / stroke), wall))
    return rows


def closed_loop(n=4, *, scene="stage_planar_1dof", stroke=1e-3, duration=1.0, fs=4000.0,
                crossover=300.0, settle=0.25, substeps=1, repeat=1, **options):
    """`flexure loop` with its defaults, on the Exudyn stage: the same controller, sampled.

    flexure designs the loop (`flexure.controllers.build_loop` on the scene's linear model:
    the PID-like feedback for `crossover` at `fs`, the modal feedforward m a + c v + k x of
    the third-order move, the reference per sample); its `LoopController` is then stepped in
    Exudyn's PreStepUserFunction with flexure's timing (controllers/runner.py): at t_k the
    force u_k, computed at t_(k-1), is applied over [t_k, t_(k+1)), y_k is measured and
    u_(k+1) = C(z) e_k + u_ff,(k+1) computed; u_0 = u_ff,0. Exudyn calls the function with
    t = the end of the step, the state still at its start.

    Parameters
    ----------
    n : int
        Elements per leaf spring.
    scene : str
        The scene whose linear model flexure designs the controller on.
    stroke, duration : float
        The move (m, s).
    fs : float
        Sample rate (Hz) of the controller.
    crossover : float
        The cross-over of the feedback (rad/s).
    settle : float
        Time simulated after the move (s).
    substeps : int
        Generalized-alpha steps per sample (h = 1 / (substeps fs)); 1 is the benchmark.
    repeat : int
        Runs (each on a new model, the same results); the wall time is the shortest.
    **options
        stage (default: the sections of `scene`), reduced_integration: passed to `build`.

    Returns
    -------
    dict
        max_abs_error (m): max_k |r_k - y_k| over the N + 1 samples, as `flexure loop`;
        max_abs_error_during_move (m): the same for t_k <= duration; error_ratio: the first
        over the stroke; wall_time_s (s): SolveDynamic alone; samples: N; t (s),
        reference (m), position (m), force (N): arrays over the samples.
    """
    from flexure.controllers import build_loop
    from flexure.core import load_scene

    controller, _ = build_loop(load_scene(scene), stroke=stroke, duration=duration, fs=fs,
                               crossover=crossover, feedforward=True, settle=settle)
    options.setdefault("stage", Stage.from_scene(scene))
    runs = [run_loop(controller, n, substeps, **options) for _ in range(max(1, repeat))]
    t, position, force, _ = runs[0]
    error = np.abs(controller.reference[: t.size, 0] - position)
    return {"max_abs_error": float(error.max()), "error_ratio": float(error.max() / abs(stroke)),
            "max_abs_error_during_move": float(error[t <= duration].max()),
            "wall_time_s": min(r[3] for r in runs), "samples": t.size - 1, "t": t,
            "reference": controller.reference[: t.size, 0].copy(), "position": position,
            "force": force}


def run_loop(controller, n, substeps, **options):
    """One closed-loop run: t (s), position (m), force (N) per sample and the wall time.

    `controller` steps as flexure's `LoopController`: reset(), fs (Hz), samples,
    initial_output() -> u_0 (N), step(k, [y_k]) -> (u_k+1, e_k)."""
    controller.reset()
    fs = controller.fs
    model = build(n, **options)
    mbs, node, load = model.mbs, model.output_node, model.load
    N, rate = controller.samples, fs * substeps
    position, force = np.empty(N + 1), np.empty(N + 1)
    pending = [float(controller.initial_output()[0])]  # u_k, the force of the next sample
    position_type = exu.OutputVariableType.Position

    def pre_step(mbs, t):
        k, sub = divmod(int(round(t * rate)) - 1, substeps)  # the step starts at t_k + sub h
        if sub == 0:
            y = mbs.GetNodeOutput(node, position_type)[0]
            u = pending[0]
            mbs.SetLoadParameter(load, "loadVector", [u, 0.0, 0.0])
            position[k], force[k] = y, u
            pending[0] = float(controller.step(k, [y])[0][0])
        return True

    mbs.SetPreStepUserFunction(pre_step)
    settings = simulation_settings(1.0 / rate, N / fs, n=n)
    settings.solution.sensors.writePeriod = 1e3  # no sensor output needed
    start = time.perf_counter()
    mbs.SolveDynamic(settings)
    wall = time.perf_counter() - start
    position[N] = mbs.GetNodeOutput(node, position_type)[0]
    force[N] = force[N - 1]
    return np.arange(N + 1) / fs, position, force, wall


def _table(headers, rows):
    widths = [max(len(str(c)) for c in column) for column in zip(headers, *rows, strict=True)]
    lines = ["  ".join(f"{c:>{w}}" for c, w in zip(row, widths, strict=True))
             for row in (headers, *rows)]
    return "\n".join([lines[0], "  ".join("-" * w for w in widths), *lines[1:]])


def main(argv=None):
    """Print the natural frequencies, the step-response work-precision and the loop."""
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", default="1,4", help="elements per spring of the work-precision "
                        "study, comma separated (default 1,4)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per timing (best taken)")
    args = parser.parse_args(argv)
    ns = [int(v) for v in args.n.split(",")]
    print(f"Exudyn {exu.__version__}: planar leaf-spring stage, ANCF cables, generalized-alpha")
    rows = [(n, *(f"{f:.4f}" for f in natural_frequencies(n, 3))) for n in (1, 2, 4, 8, 16)]
    print("\nnatural frequencies (Hz), flexure stage_planar_3dof: 10.645, 2129, 3585")
    print(_table(["n", "f1", "f2", "f3"], rows))
    for n in ns:
        reference = converged_reference(n)
        print(f"\nstep of 1 N for 1 s, n = {n}: reference h = {reference['h']:.3g} s, "
              f"Richardson error estimate {reference['estimate']:.2g} m, observed order "
              f"{reference['observed_order']:.2f}")
        rows = [(f"{h:.4g}", f"{e:.3e}", f"{w:.3f}")
                for h, e, w in work_precision(n, reference=reference, repeat=args.repeat)]
        print(_table(["h (s)", "max |x - x_ref| / stroke", "wall (s)"], rows))
    print("\nclosed loop, flexure loop's defaults (1 mm in 1 s + 0.25 s, 4 kHz, one step per "
          "sample)")
    rows = []
    for n, reduced in ((1, False), (1, True), (4, False)):
        r = closed_loop(n, reduced_integration=reduced, repeat=args.repeat)
        rows.append((n, "reduced" if reduced else "full", f"{r['max_abs_error']:.3e}",
                     f"{r['error_ratio']:.3e}", f"{r['wall_time_s']:.3f}"))
    print(_table(["n", "integration", "max |error| (m)", "error / stroke", "wall (s)"], rows))


if __name__ == "__main__":
    main()
