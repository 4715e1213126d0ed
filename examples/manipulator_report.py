"""The six-DOF manipulator's analyses: the chapter's Table 3.1 and Fig. 3.5, and its workspace.

    python examples/manipulator_report.py                  # everything, about 15 s of CPU
    python examples/manipulator_report.py --skip-workspace

1. **Frequencies** (the chapter's Table 3.1 analogue): the lowest ten natural frequencies of the
   full model (`manipulator`, every flexure in three beams, every deformation released), the
   elongation-frozen one (`manipulator_e1`) and the reduced one (`manipulator_reduced`,
   written by `flexure reduce manipulator_e1 --keep 7 --tol 1`), with what moves in each mode.
2. **Principal gains** (Fig. 3.5): the singular values of the 6 x 6 transfer matrix from the
   six actuator forces to the six colocated encoders of the reduced model, against frequency,
   as a PNG (`flexure analyze manipulator_reduced --sigma FILE.png` draws the same).
3. **Workspace**: the reduced model linearised with the end effector moved by the actuators in
   x, y, z, tilted about x and turned about z. For each direction the actuators are given the
   forces that move the carriages by the direction's pattern of strokes in the linear model
   (K_dc^-1 times the strokes); the static equilibrium under those forces is the pose reported
   (its end-effector displacement and rotation), with the lowest seven natural frequencies and
   the largest and smallest singular values of the static gain (the 6 x 6 compliance from
   forces to encoders) there. A table, and a PNG of the frequencies against the stroke.

Frequencies in Hz, displacements in mm, rotations in mrad, gains in mm/N.
"""

import argparse
import functools
import math
import sys
import time
from pathlib import Path

import numpy as np

from flexure.core import (
    linearize,
    load_scene,
    natural_frequencies,
    principal_gains,
    static_equilibrium,
    static_gain,
)
from flexure.core.analysis.modal import describe_mode
from flexure.core.analysis.statespace import (
    frequency_grid,
    plot_principal_gains,
)
from flexure.core.mechanics.mechanics import Mechanics
from flexure.core.numerics.rotations import to_rotation_vector

MODELS = ("manipulator", "manipulator_e1", "manipulator_reduced")
FIGURES = Path(__file__).resolve().parent / "figures"
BODY_ANGLES = (90.0, 210.0, 330.0)  # degrees: the intermediate bodies C1, C2, C3


def log(text):
    print(text, file=sys.stderr, flush=True)


@functools.cache
def at_rest(name):
    """(model, its mechanics, its static equilibrium, its linearisation there) of scene
    `name`: loaded and solved once for the three parts of the report (each load chooses the
    DOFs of 1582 free coordinates, a second or so). The mechanics are shared by every
    analysis of the model: setting them up (S, D, the kinematics' patterns) costs 40 ms, which
    a statics and a linearisation at each of the 21 workspace poses made twice each."""
    model = load_scene(name)
    mech = Mechanics(model)
    solution = static_equilibrium(model, mechanics=mech)
    return model, mech, solution, linearize(model, solution, mechanics=mech)


def frequency_table(count=10):
    """{model: (NDOF, frequencies Hz)} and the descriptions of the full model's modes."""
    rows, descriptions = {}, []
    for name in MODELS:
        start = time.perf_counter()
        model, _, solution, lin = at_rest(name)
        modes = natural_frequencies(model, count, linear_model=lin)
        rows[name] = (model.ndof, modes.frequencies_hz)
        if name == MODELS[0]:
            descriptions = [describe_mode(model, shape, solution.x)
                            for shape in modes.coordinate_shapes.T]
        log(f"{name}: {model.ndof} DOFs, {count} modes in {time.perf_counter() - start:.1f} s")
    return rows, descriptions


def print_frequency_table(rows, descriptions):
    full = rows[MODELS[0]][1]
    heads = [f"{name} ({ndof} DOFs)" for name, (ndof, _) in rows.items()]
    print("| mode | " + " | ".join(heads) + " | reduced - full | what moves most (full model) |")
    print("| ---: | " + " | ".join("---:" for _ in heads) + " | ---: | --- |")
    for k in range(full.size):
        values = " | ".join(f"{f[k]:.2f}" for _, f in rows.values())
        change = (rows[MODELS[-1]][1][k] / full[k] - 1.0) * 100.0
        print(f"| {k + 1} | {values} | {change:+.2f} % | {descriptions[k]} |")


def plot_gains(path):
    """The principal gains of the reduced model's 6 x 6 transfer matrix to `path` (PNG)."""
    model, _, _, lin = at_rest(MODELS[-1])
    natural = natural_frequencies(model, 20, linear_model=lin).frequencies_hz
    grid = frequency_grid(natural)
    gains = principal_gains(model, grid, linear_model=lin)
    plot_principal_gains(model, grid, gains, path, natural_hz=natural)
    log(f"wrote {path}")
    return grid, gains


def stroke_patterns(amplitude):
    """{direction: the six carriage strokes (m)} that move the end effector by about
    `amplitude` (m, or m of radial stroke for the rotations) in each direction. Actuators
    2i-1 and 2i push body Ci along x and y."""
    patterns = {}
    radial = [(math.cos(math.radians(a)), math.sin(math.radians(a))) for a in BODY_ANGLES]
    patterns["x"] = [amplitude, 0.0] * 3
    patterns["y"] = [0.0, amplitude] * 3
    patterns["z"] = [s for c, n in radial for s in (-amplitude * c, -amplitude * n)]
    # tilt about x: the body at +y inward (its leg lifts), the others out by half
    patterns["tilt x"] = [s for c, n in radial for s in (-amplitude * n * c, -amplitude * n * n)]
    patterns["turn z"] = [s for c, n in radial for s in (-amplitude * n, amplitude * c)]
    return {key: np.array(value) for key, value in patterns.items()}


def effector_pose(model, x, x0):
    """The end effector's displacement (m, 3) and rotation vector (rad, 3) from x0 to x."""
    names = model.coordinate_names
    position = [x[names.index(f"E.{a}")] - x0[names.index(f"E.{a}")] for a in "xyz"]
    euler = np.array([x[names.index(f"E_r.lambda{k}")] for k in range(4)])
    return np.array(position), to_rotation_vector(euler)  # from the reference orientation


def workspace(amplitudes):
    """Rows (direction, stroke mm, displacement mm (3), rotation mrad (3), the lowest seven
    frequencies Hz, largest and smallest static gain mm/N) of the reduced model."""
    model, mech, _, lin0 = at_rest(MODELS[-1])
    x0 = model.initial_coordinates
    stiffness = np.linalg.inv(static_gain(model, linear_model=lin0))  # N/m, 6 x 6
    inputs = [port.coordinate for port in model.inputs]
    rows = []
    solved = {}  # {direction: {amplitude: its equilibrium}}: the forces are linear in it
    for amplitude in amplitudes:
        for direction, strokes in stroke_patterns(amplitude).items():
            if amplitude == 0.0 and rows:
                continue
            start = time.perf_counter()
            loads = np.zeros(model.nx)
            loads[inputs] = stiffness @ strokes
            # The direction's smaller poses on the same side lie on this pose's path of
            # loads (at the ratio of their amplitudes): the 6 mm pose's stepping starts at
            # its 3 mm pose, the first half of its load, which it stepped through again
            # before (`static_equilibrium`'s path; the opposite pose's curvature did not
            # help the 3 mm ones). The poses are far from any buckling or snap-through: a
            # 3 mm pose is one load step from rest (5 or 6 Newton iterations, where two
            # steps took 4 and 5 or 6), a 6 mm pose one step of half its load from its 3 mm
            # pose (a step that fails is halved, to 0.75 of the load).
            done = solved.setdefault(direction, {})
            path = [(other / amplitude, found) for other, found in done.items()
                    if amplitude != 0.0 and 0.0 < other / amplitude < 1.0]
            solution = static_equilibrium(model, loads=loads, load_steps=1, path=path,
                                          mechanics=mech)
            if amplitude != 0.0:
                done[amplitude] = solution
            lin = linearize(model, solution, mechanics=mech)
            frequencies = natural_frequencies(model, 7, linear_model=lin).frequencies_hz
            gain = np.linalg.svd(static_gain(model, linear_model=lin), compute_uv=False)
            moved, turned = effector_pose(model, solution.x, x0)
            label = "reference" if amplitude == 0.0 else direction
            rows.append((label, amplitude * 1e3, *(moved * 1e3), *(turned * 1e3), *frequencies,
                         gain[0] * 1e3, gain[-1] * 1e3))
            log(f"workspace: {label} {amplitude * 1e3:+.1f} mm in "
                f"{time.perf_counter() - start:.1f} s")
    return rows


def print_workspace(rows):
    heads = ["direction", "stroke (mm)", "E dx", "dy", "dz (mm)", "E rx", "ry", "rz (mrad)",
             *(f"f{k}" for k in range(1, 7)), "f7 (Hz)", "gain max", "min (mm/N)"]
    print("| " + " | ".join(heads) + " |")
    print("| --- | " + " | ".join("---:" for _ in heads[1:]) + " |")
    for row in rows:
        print(f"| {row[0]} | " + " | ".join(f"{v:.3f}" if abs(v) < 100 else f"{v:.1f}"
                                           for v in row[1:]) + " |")


def plot_workspace(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    reference = next(row for row in rows if row[0] == "reference")
    directions = [d for d in dict.fromkeys(row[0] for row in rows) if d != "reference"]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for direction in directions:
        chosen = sorted([row for row in rows if row[0] == direction] + [
            (direction, 0.0, *reference[2:])], key=lambda row: row[1])
        stroke = [row[1] for row in chosen]
        lines = axes[0].plot(stroke, [row[8:14] for row in chosen], marker="o", ms=3)
        for line in lines[1:]:
            line.set_color(lines[0].get_color())
        lines[0].set_label(direction)
        axes[1].plot(stroke, [row[14] for row in chosen], marker="o", ms=3, label=direction)
    axes[0].set(xlabel="stroke (mm)", ylabel="natural frequency (Hz)",
                title="the six suspension modes across the workspace")
    axes[1].set(xlabel="stroke (mm)", ylabel="natural frequency (Hz)",
                title="the first parasitic mode")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    log(f"wrote {path}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, default=10, help="frequencies in the table")
    parser.add_argument("--strokes", default="-6,-3,0,3,6",
                        help="workspace strokes in mm, comma-separated")
    parser.add_argument("--skip-workspace", action="store_true")
    parser.add_argument("--figures", type=Path, default=FIGURES, help="folder for the PNGs")
    args = parser.parse_args(argv)
    args.figures.mkdir(parents=True, exist_ok=True)
    rows, descriptions = frequency_table(args.modes)
    print("\nThe lowest natural frequencies (Hz)\n")
    print_frequency_table(rows, descriptions)
    grid, gains = plot_gains(args.figures / "manipulator_sigma.png")
    print(f"\nprincipal gains: {grid.size} frequencies from {grid[0]:.3g} to {grid[-1]:.3g} Hz;"
          f" at the lowest, {gains[0, 0] * 1e3:.4g} to {gains[0, -1] * 1e3:.4g} mm/N")
    if not args.skip_workspace:
        strokes = sorted({0.0, *(float(s) * 1e-3 for s in args.strokes.split(","))},
                         key=abs)
        found = workspace(strokes)
        print("\nThe reduced model across the workspace\n")
        print_workspace(found)
        plot_workspace(found, args.figures / "manipulator_workspace.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
