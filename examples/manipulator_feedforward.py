"""The manipulator's feedforward from the nonlinear inverse dynamics against the linear one
(the chapter's Fig. 3.8: the end effector deviated more than linearly with the stroke).

    python examples/manipulator_feedforward.py            # 1 and 4 mm x, 6 mm xy
    python examples/manipulator_feedforward.py --moves "2 mm x,6 mm x"   # others
    python examples/manipulator_feedforward.py --quick    # 1 mm x in 0.1 s, coarser (tests)
    python examples/manipulator_feedforward.py --check    # + the forward check below
    python examples/manipulator_feedforward.py --check --halved  # + its half-step columns
    python examples/manipulator_feedforward.py --kinds dynamic   # one feedforward's rows

For each move of the end effector E (its x and y moved along a third-order profile in
`duration`, its height and tilts held: manipulator_loop.targets), the six PID-like loops of
manipulator_loop.py (300 rad/s, 4 kHz) on the nonlinear control model (manipulator_control,
75 DOFs) run with three feedforwards:

- **linear**: the loops' strokes from the statics linearised at rest (`move_path(...,
  kind="linear")`) and the forces of the low-frequency model, m y'' + c y' + k y: what the
  chapter computed its actuator set-points from;
- **static**: the strokes and static forces of the nonlinear inverse statics
  (`move_path(..., kind="nonlinear")`) plus m y'' + c y' of the low-frequency model;
- **dynamic**: the strokes and forces of the nonlinear inverse dynamics with the 69 other DOFs
  free (`flexure.controllers.dynamic_feedforward`, Radau IIA at `step`, 5 ms).

The forces the loop applied are then replayed on the model in `simulate` (esdirk3, rtol 1e-8:
tighter than the loop's own esdirk2 at 1e-5) to record E, and E's deviation from its intended
path (its start plus the move, rotations zero) is taken over the move and the settling after
it: position (nm) and the three rotations about the global axes (nrad).

`--check` (the forward check): the inverse dynamics' forces alone, without the loop, drive
the model in `simulate` along the 4 mm x move in 1 s and 0.25 s after it (CVODE BDF; the
forces the piecewise cubic through each step's nodes, `FreeInverseDynamics.force_polynomial`),
at steps of 5 and 2.5 ms. Per step: E's largest deviation from the path at rtol 1e-8 and at
1e-11, and the run's own error at 1e-8 (its difference from the run at 1e-11). At 1e-11
what is left is the inverse dynamics' own error: the test
(tests/test_manipulator_feedforward.py) takes its estimate from the inverse dynamics at half
the step (`forward_check(..., halved=True)`), as the 1e-8 run's error depends on how CVODE's
steps fall. With `--quick` the check takes the move's first 0.2 s at 5 ms (the test's).
"""

import argparse
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

# Run by its path (as docs/manipulator.md gives it), this file's folder is on sys.path but not
# the repository's root, from which `examples.manipulator_loop` is found.
if not __package__:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from examples.manipulator_loop import CONTROL, design_loops, targets  # noqa: E402
from flexure.controllers.dynamic_feedforward import dynamic_feedforward, move_inverse_dynamics
from flexure.controllers.move_path import move_path
from flexure.controllers.profiles import ThirdOrderProfile
from flexure.controllers.runner import run_loop
from flexure.core import build_model, output_value, position_port, scene_path, simulate

FIGURES = Path(__file__).resolve().parent / "figures"
MOVES = {"1 mm x": (1e-3, 0.0), "2 mm x": (2e-3, 0.0), "4 mm x": (4e-3, 0.0),
         "6 mm x": (6e-3, 0.0), "6 mm xy": (6e-3 / np.sqrt(2), 6e-3 / np.sqrt(2))}
KINDS = ("linear", "static", "dynamic")
EFFECTOR = ("E.x", "E.y", "E.z", "E_r.rx", "E_r.ry", "E_r.rz")  # m, m, m, rad, rad, rad


def log(text):
    print(text, file=sys.stderr, flush=True)


def control_model():
    """manipulator_control with E's position and angles as outputs E_x ... E_rz (m, rad)."""
    data = tomllib.loads(scene_path(CONTROL).read_text())
    for axis in "xyz":
        data["outputs"][f"E_{axis}"] = {"node": "E", "coordinate": axis}
    return build_model(data, source=f"{CONTROL} + the end effector's position as outputs")


def effector_start(model):
    """E's position (m) and angles (rad) at rest: the intended path's start."""
    from flexure.core import static_equilibrium

    rest = static_equilibrium(model)
    return np.array([output_value(model, position_port(model, name), rest.x)
                     for name in EFFECTOR])


def replay(model, result, *, rtol=1e-8):
    """E (n, 6) at the loop's samples under the forces the loop applied (zero-order hold),
    and the largest difference of the replayed encoders from the loop's (m)."""
    t, force = result.t, result.force
    inputs = {port.name: (t, force[:, j]) for j, port in enumerate(model.inputs)}
    run = simulate(model, float(t[-1]), inputs=inputs, method="esdirk3", rtol=rtol,
                   output_times=t)
    outputs = run.outputs
    encoders = np.column_stack([outputs[f"x{j + 1}"] for j in range(6)])
    names = ("E_x", "E_y", "E_z", "E_rx", "E_ry", "E_rz")
    return np.column_stack([outputs[name] for name in names]), float(
        np.max(np.abs(encoders - result.position)))


def deviation(model, start, move, t, effector, duration):
    """E's deviation (n, 6) from the intended path: start + s(t) (dx, dy, 0), no rotation."""
    s = ThirdOrderProfile(1.0, duration).position(t)
    intended = start + np.outer(s, [move[0], move[1], 0.0, 0.0, 0.0, 0.0])
    return effector - intended


def run_move(model, design, label, move, *, duration, settle, fs, step, kinds=KINDS):
    """{kind: {"deviation": (n, 6), "t": (n,), "replay": m, "loop": max error / stroke}}."""
    wanted = targets(*move)
    start = effector_start(model)
    rows = {}
    for kind in kinds:
        begin = time.perf_counter()
        if kind == "dynamic":
            ff = dynamic_feedforward(model, wanted, duration=duration, settle=settle, fs=fs,
                                     step=step)
            result = run_loop(model, reference=ff.reference, feedforward_forces=ff.forces,
                              design=design, fs=fs)
        else:
            path = move_path(model, wanted, kind="linear" if kind == "linear" else "nonlinear")
            result = run_loop(model, path=path, design=design, duration=duration,
                              settle=settle, fs=fs)
        effector, replayed = replay(model, result)
        rows[kind] = {"t": result.t, "replay": replayed,
                      "deviation": deviation(model, start, move, result.t, effector, duration),
                      "loop": max(loop["error_ratio"] for loop in result.per_loop())}
        log(f"  {label}, {kind}: {time.perf_counter() - begin:.0f} s")
    return rows


def summary(rows):
    """Per kind: the largest |deviation| of E's x, y, z (um) and rx, ry, rz (urad)."""
    return {kind: np.max(np.abs(row["deviation"]), axis=0) * 1e6 for kind, row in rows.items()}


def print_table(results, file=None):
    print("| move | stroke (mm) | feedforward | E dx | dy | dz (nm) | E rx | ry | rz (nrad) | "
          "loops' error / stroke | replay - loop (nm) |", file=file)
    print("| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
          file=file)
    for label, (move, rows) in results.items():
        stroke = np.hypot(*move) * 1e3
        for kind, values in summary(rows).items():
            print(f"| {label} | {stroke:.0f} | {kind} | "
                  + " | ".join(f"{v * 1e3:.1f}" for v in values)
                  + f" | {rows[kind]['loop']:.1e} | {rows[kind]['replay'] * 1e9:.2f} |",
                  file=file)


def plot(results, path):
    """E's largest position and rotation deviation against the stroke, per feedforward."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for kind, marker in zip(KINDS, "osd", strict=True):
        x_moves = [(np.hypot(*move) * 1e3, summary(rows)[kind])
                   for label, (move, rows) in results.items() if label.endswith(" x")]
        xy = [(np.hypot(*move) * 1e3, summary(rows)[kind])
              for label, (move, rows) in results.items() if label.endswith("xy")]
        for ax, part in zip(axes, (slice(0, 3), slice(3, 6)), strict=True):
            if x_moves:
                ax.loglog([s for s, _ in x_moves], [np.max(v[part]) for _, v in x_moves],
                          marker=marker, label=f"{kind}, x moves")
            if xy:
                ax.loglog([s for s, _ in xy], [np.max(v[part]) for _, v in xy], marker=marker,
                          linestyle="none", markerfacecolor="none", label=f"{kind}, xy move")
    axes[0].set_ylabel("largest position deviation of E (um)")
    axes[1].set_ylabel("largest rotation of E (urad)")
    for ax in axes:
        ax.set_xlabel("stroke (mm)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("manipulator_control, six loops: the end effector's deviation from its path")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def forward_check(model, move, *, duration, window, steps, rtol=1e-8, tight=1e-11,
                  halved=False):
    """The forward check: the inverse dynamics' forces alone in `simulate` (CVODE BDF), the
    piecewise cubic through each step's nodes, over [0, window] (s) of the move in
    `duration`. Per step (s): E's largest deviation from its path at `rtol` ("path") and at
    `tight` ("tight"), and the run's own error at `rtol` ("own", its largest difference from
    the run at `tight`), each as (position m, rotation rad); "seconds" the inverse
    dynamics' wall time. With `halved`, also the inverse dynamics at half the step, run at
    `tight`: its deviation from the path ("half"), and the largest difference of E between
    the two runs at `tight` ("inverse"), the estimate of the step's inverse dynamics' own
    error (the half step's is 2^-p of it at the method's order p)."""
    start = effector_start(model)
    t = np.linspace(0.0, window, 501)

    def forward(step, tolerances):
        """E (501, 6) per tolerance under the forces of the inverse dynamics at `step`, and
        that inverse dynamics' wall time (s)."""
        begin = time.perf_counter()
        inverse = move_inverse_dynamics(model, targets(*move), duration=duration, end=window,
                                        step=step, tolerance=1e-14)
        seconds = time.perf_counter() - begin
        polynomial = inverse.force_polynomial()
        inputs = {name: (lambda s, j=j, polynomial=polynomial: float(polynomial(s)[j]))
                  for j, name in enumerate(inverse.input_names)}
        effector = {}
        for tolerance in tolerances:
            run = simulate(model, float(t[-1]), inputs=inputs, method="cvode-bdf",
                           rtol=tolerance, output_times=t)
            effector[tolerance] = np.column_stack([run.outputs[name] for name in (
                "E_x", "E_y", "E_z", "E_rx", "E_ry", "E_rz")])
        return effector, seconds

    def largest(values):
        return float(np.max(values[:, :3])), float(np.max(values[:, 3:]))

    def off_path(effector):
        return largest(np.abs(deviation(model, start, move, t, effector, duration)))

    rows = {}
    for step in steps:
        begin = time.perf_counter()
        effector, seconds = forward(step, (rtol, tight))
        rows[step] = {"path": off_path(effector[rtol]), "tight": off_path(effector[tight]),
                      "own": largest(np.abs(effector[rtol] - effector[tight])),
                      "seconds": seconds}
        if halved:
            half, _ = forward(step / 2, (tight,))
            rows[step]["half"] = off_path(half[tight])
            rows[step]["inverse"] = largest(np.abs(effector[tight] - half[tight]))
        log(f"  forward check, step {step * 1e3:g} ms: {time.perf_counter() - begin:.0f} s")
    return rows


def print_check(checks, rtol=1e-8, tight=1e-11):
    """The forward check's table (nm, nrad); with `forward_check(..., halved=True)`'s rows,
    also the deviation at half the step and the two steps' difference (both at `tight`),
    what tests/test_manipulator_feedforward.py asserts on."""
    halved = all("half" in row for row in checks.values())
    keys = ("path", "tight", "own") + (("half", "inverse") if halved else ())
    extra = " | at half the step | the two steps' difference" if halved else ""
    print(f"\n| step (ms) | E position off the path at rtol {rtol:g} (nm) | at {tight:g} | "
          f"the run's own error at {rtol:g}{extra} | rotation off the path at {rtol:g} (nrad) "
          f"| at {tight:g} | own error{extra} |")
    print("| ---: " * (1 + 2 * len(keys)) + "|")
    for step, row in checks.items():
        values = [row[key][part] * 1e9 for part in (0, 1) for key in keys]
        print(f"| {step * 1e3:g} | " + " | ".join(f"{v:.3f}" for v in values) + " |")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="1 mm x in 0.1 s, step 2.5 ms, and the forward check on the "
                        "first 0.2 s only: a short run (the tests')")
    parser.add_argument("--check", action="store_true",
                        help="the forward check of the dynamic feedforward's forces")
    parser.add_argument("--halved", action="store_true",
                        help="with --check: also the inverse dynamics at half each step (at "
                        "rtol 1e-11), the estimate of their own error that the test uses")
    parser.add_argument("--no-figure", action="store_true", help="write no PNG")
    parser.add_argument("--kinds", default=",".join(KINDS),
                        help="the feedforwards, comma-separated (default %(default)s; the "
                        "figure needs all three)")
    parser.add_argument("--moves", default="1 mm x,4 mm x,6 mm xy",
                        help=f"the moves, comma-separated, of: {', '.join(MOVES)} (default "
                        "%(default)s; empty: none)")
    args = parser.parse_args(argv)
    duration, settle, step = (0.1, 0.02, 2.5e-3) if args.quick else (1.0, 0.25, 5e-3)
    labels = [label.strip() for label in args.moves.split(",") if label.strip()]
    unknown = [label for label in labels if label not in MOVES]
    if unknown:
        parser.error(f"--moves: unknown {', '.join(unknown)}; expected of {', '.join(MOVES)}")
    kinds = tuple(kind.strip() for kind in args.kinds.split(",") if kind.strip())
    if not kinds or set(kinds) - set(KINDS):
        parser.error(f"--kinds: expected some of {', '.join(KINDS)}, got {args.kinds!r}")
    moves = {"1 mm x": MOVES["1 mm x"]} if args.quick else {label: MOVES[label]
                                                             for label in labels}
    model = control_model()
    design, _ = design_loops(model) if moves else (None, None)
    results = {}
    for label, move in moves.items():
        log(f"{label}:")
        results[label] = (move, run_move(model, design, label, move, duration=duration,
                                         settle=settle, fs=4000.0, step=step,
                                         kinds=kinds))
        print_table({label: results[label]}, file=sys.stderr)  # each move as it ends
    print_table(results)
    if results and not args.no_figure and not args.quick and kinds == KINDS:
        plot(results, FIGURES / "manipulator_feedforward.png")
    checks = None
    if args.check:  # the 4 mm x move in 1 s, its first 0.2 s with --quick
        window, steps = (0.2, (5e-3,)) if args.quick else (1.25, (5e-3, 2.5e-3))
        checks = forward_check(model, MOVES["4 mm x"], duration=1.0, window=window,
                               steps=steps, halved=args.halved)
        print_check(checks)
    return results, checks


if __name__ == "__main__":
    main()
