"""The six-actuator loop of the manipulator (the chapter's sections 3.3.3 and 3.4) on our model.

    python examples/manipulator_loop.py                      # robustness and moves, a minute
    python examples/manipulator_loop.py --loop               # + the 6 mm xy move, closed loop
    python examples/manipulator_loop.py --loop --moves       # + every move, closed loop
    python examples/manipulator_loop.py --loop --plant libcosim   # + the same loop as FMUs
    python examples/manipulator_loop.py --loop --coils       # the loops through voice coils
    python examples/manipulator_loop.py --loop --coils --plant libcosim   # ... also as FMUs

1. **Design and robust stability.** One PID-like loop per actuator on its colocated encoder,
   its gain set for 300 rad/s on the low-frequency model (the six suspension modes alone,
   `LowFrequencyModel.state_space`), sampled at 4 kHz with one sample of delay. The same
   discrete loops are then closed around the models with their parasitic modes: the control
   model (`manipulator_control`, 75 DOFs) and the reduced model (`manipulator_reduced`, 507
   DOFs). For each: the margins of each loop with the others open and closed, the peak of the
   MIMO sensitivity and the closed-loop spectral radius (flexure.controllers.robustness).
2. **Moves and feedforward.** For 1 mm and 4 mm along x (the chapter's Fig. 3.8), 6 mm along
   x, along y and diagonally in the xy plane, with the end effector's height and rotations held:
   the actuator strokes from the nonlinear inverse statics of the control model and from its
   linearisation, and where the end effector ends up when the actuators follow the linear
   strokes exactly (the forward statics). The chapter saw its end effector deviate more than
   linearly with the stroke because its actuator set-points came from a linear model; the
   nonlinear path puts it where it was asked to within 1e-10 m.
3. **Closed loop** (`--loop`): the 6 mm xy move in 1 s on the nonlinear control model with the
   nonlinear path and its feedforward (`flexure loop manipulator_control --move ...`), each
   actuator's largest error against 0.1 % of its stroke (`--moves`: every move, and where
   the end effector ends up: the forward statics of the actuators' last positions). With
   `--plant libcosim` the same loop runs again as the manipulator's FMU and a controller FMU
   co-simulated in libcosim
   (`--plant fmu`: the manipulator's FMU stepped by fmpy), and each actuator's error / stroke
   is compared with the in-process one (the target: within 1e-6 of the stroke). Without
   `--plant`, the same move again with what the chapter's experiment met (section 3.4:
   "below the desired 0.1 % although the signal is quite noisy ... a 50 Hz disturbance from
   the mains"): 50 nm encoders and 30 mN at 50 Hz on every actuator (`--quantum 5e-8
   --disturbance 0.03@50`), the linear loop's 50 Hz response to it about 2 um per actuator,
   half the target.

4. **Through the voice coils** (`--coils`): the same study on `manipulator_control_vcm`, the
   control model with its six actuators voltage-driven voice coils (examples/manipulator.py's
   `COILS`). The damping ratios of the six suspension modes from the state space's poles
   without and with the coils, against the modal formula (c_i + sum_j Km^2/R g_ij^2) /
   (2 w_i) (unit modal mass, g_ij the mode's displacement at coil j: the back-EMF's damping
   Km^2 / R, N s/m, per mode, where the coil's pole R / L lies far above the mode and the
   modes' damping does not couple them); the loops designed on the low-frequency model with
   the coils' equations (`low_frequency_plant`), now from the drive signals (V), and their
   robustness on the control model with its coils; with `--loop` the 6 mm xy move through
   the coils, the feedforward turned into drive signals by the coils' equations (with
   `--plant`, in process and as FMUs, compared as above).

Lengths in mm, rotations in mrad (the end effector's rotation-vector components), margins in
degrees and ratios.
"""

import argparse
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

from flexure.controllers.feedback import colocated_pairs, design_feedback
from flexure.controllers.feedforward import low_frequency_model, low_frequency_plant
from flexure.controllers.move_path import move_path
from flexure.controllers.robustness import check_robustness
from flexure.controllers.runner import run_loop
from flexure.core import (
    build_model,
    input_columns,
    inverse_statics,
    linearize,
    load_scene,
    natural_frequencies,
    output_value,
    scene_path,
    state_space,
)
from flexure.core.reporting.progress import Progress

CONTROL, REDUCED = "manipulator_control", "manipulator_reduced"
COILS = "manipulator_control_vcm"  # CONTROL with its actuators voltage-driven voice coils
FIGURES = Path(__file__).resolve().parent / "figures"
HELD = ("E.z", "E_M1.z", "E_M2.z")  # the end effector's height and its tilts held
MOVES = {"1 mm x": (1e-3, 0.0), "4 mm x": (4e-3, 0.0), "6 mm x": (6e-3, 0.0),
         "6 mm y": (0.0, 6e-3), "6 mm xy": (6e-3 / np.sqrt(2), 6e-3 / np.sqrt(2))}
# the experiment's noise: 50 nm encoder counts, 30 mN of mains hum at every actuator
DISTURBANCES = {"quantum": 50e-9, "disturbance": 0.03, "disturbance_hz": 50.0}


def log(text):
    print(text, file=sys.stderr, flush=True)


def targets(dx, dy):
    """The end effector translated by (dx, dy) m: E and the attachment point E_M1 (above the
    y axis, so its x follows E's unless E turns about z) move, its height and tilts hold."""
    return {"E.x": dx, "E.y": dy, "E_M1.x": dx} | dict.fromkeys(HELD, 0.0)


def plant_of(model):
    """The continuous state space from the six forces to the six encoders (m/N)."""
    pairs = colocated_pairs(model)
    full = state_space(model)
    return full[[p.output_index for p in pairs], [p.input_index for p in pairs]]


def design_loops(control_model, crossover=300.0, fs=4000.0):
    """The six loops designed on the low-frequency model (with the coils' equations where
    voice coils drive the inputs); returns (design, that model's state space)."""
    lf = low_frequency_plant(low_frequency_model(control_model), control_model)
    return design_feedback(control_model, crossover=crossover, fs=fs, plant=lf), lf


def with_coils(name):
    """The built-in scene `name` with the voice coils of the COILS scene on its inputs."""
    data = tomllib.loads(scene_path(name).read_text())
    data["actuators"] = tomllib.loads(scene_path(COILS).read_text())["actuators"]
    return build_model(data, source=f"{name} + the voice coils of {COILS}")


def robustness(crossover=300.0, fs=4000.0, *, coils=False):
    """The design on the low-frequency model and its robustness on each plant; `coils`: on
    the models whose inputs voice coils drive."""
    control_model = load_scene(COILS if coils else CONTROL)
    design, low = design_loops(control_model, crossover, fs)
    rows = []
    for name, plant in ((f"low-frequency (6 DOFs{', 6 coils' if coils else ''})", low),
                        (f"{control_model.name} ({control_model.ndof} DOFs)",
                         plant_of(control_model)),
                        (f"{REDUCED}", None)):
        start = time.perf_counter()
        if plant is None:
            reduced = with_coils(REDUCED) if coils else load_scene(REDUCED)
            name = f"{REDUCED}{' + coils' if coils else ''} ({reduced.ndof} DOFs)"
            plant = plant_of(reduced)
        rows.append(check_robustness(design, plant, name=name))
        log(f"  robustness on {name}: {time.perf_counter() - start:.1f} s")
    return design, rows


def suspension_modes(model, count=6):
    """The `count` lowest oscillating poles of the model's state space (with its coils'
    currents where it has voice coils): their frequencies |s| / 2 pi (Hz) and damping ratios
    -Re(s) / |s|."""
    poles = np.linalg.eigvals(state_space(model).A)
    poles = poles[poles.imag > 0]
    poles = poles[np.argsort(np.abs(poles))][:count]
    return np.abs(poles) / (2 * np.pi), -poles.real / np.abs(poles)


def modal_damping(model, count=6):
    """The `count` lowest modes' frequencies (Hz, the coils open) and damping ratios by the
    modal formula zeta_i = (c_i + sum_j Km_j^2 / R_j g_ij^2) / (2 w_i): unit modal mass, c_i
    the flexures' modal damping, g_ij the mode's displacement at coil j's port (m per unit
    modal coordinate), Km^2 / R (N s/m) the back-EMF's damping of a voltage-driven coil at
    frequencies far below its pole R / L. It neglects the damping's coupling of the modes."""
    lin = linearize(model)
    modes = natural_frequencies(model, linear_model=lin)
    phi = modes.shapes[:, :count]
    omega = 2 * np.pi * modes.frequencies_hz[:count]
    damping = np.einsum("ji,jk,ki->i", phi, lin.C0, phi)  # N s/m per unit modal mass
    ports = input_columns(model, lin.solution.config.x, model.inputs)
    g = (lin.DF.T @ ports).T @ phi  # (inputs, modes)
    for coil in model.coil_actuators:
        damping = damping + coil.force_constant**2 / coil.resistance * g[coil.input] ** 2
    return modes.frequencies_hz[:count], damping / (2 * omega)


def coil_damping():
    """Per suspension mode: (frequency Hz, damping ratio) without the coils and with them
    (the state spaces' poles), and the modal formula's damping ratio with them."""
    plain, coiled = load_scene(CONTROL), load_scene(COILS)
    (f0, z0), (f1, z1) = suspension_modes(plain), suspension_modes(coiled)
    _, formula = modal_damping(coiled)
    return [{"mode": i + 1, "frequency_hz": f0[i], "zeta": z0[i], "frequency_coils_hz": f1[i],
             "zeta_coils": z1[i], "zeta_formula": formula[i]} for i in range(len(f0))]


def print_coil_damping(rows):
    print("| mode | without coils: f (Hz) | damping ratio | with coils: f (Hz) | damping ratio "
          "| modal formula | formula / state space |")
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        print(f"| {r['mode']} | {r['frequency_hz']:.2f} | {r['zeta']:.4f} | "
              f"{r['frequency_coils_hz']:.2f} | {r['zeta_coils']:.4f} | "
              f"{r['zeta_formula']:.4f} | {r['zeta_formula'] / r['zeta_coils']:.3f} |")


def print_robustness(rows):
    print("| plant | states | stable (spectral radius) | phase margin, others open (deg) | "
          "phase margin, others closed (deg) | gain margin, others closed | "
          "modulus margin, others closed | MIMO sensitivity peak |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        print(f"| {r.plant} | {r.states} | {'yes' if r.stable else 'NO'} "
              f"({r.spectral_radius:.5f}) | {r.open_margins[:, 1].min():.1f} | "
              f"{r.closed_margins[:, 1].min():.1f} | {r.closed_margins[:, 0].min():.2f} | "
              f"{r.closed_margins[:, 2].min():.2f} | {r.sensitivity_peak:.2f} "
              f"({r.peak_frequency_hz:.0f} Hz) |")


def effector(model, x):
    """The end effector's position (mm) and rotation-vector components (mrad) at x."""
    position = [x[model.coordinate_index(f"E.{axis}")] for axis in "xyz"]
    angles = [output_value(model, port, x) for port in model.outputs
              if port.name in ("E_rx", "E_ry", "E_rz")]
    return np.array(position) * 1e3, np.array(angles) * 1e3


def at_rest(model):
    """(the encoders' coordinate names ("g1_H.x", ...), the static solution with the actuators
    at rest, the end effector's position (mm) and rotation (mrad) there)."""
    encoders = [model.outputs[p.output_index] for p in colocated_pairs(model)]
    names = [model.coordinate_names[port.coordinate] for port in encoders]
    rest = inverse_statics(model, {name: model.initial_coordinates[port.coordinate]
                                   for name, port in zip(names, encoders, strict=True)})
    return names, rest, *effector(model, rest.solution.x)


def moves(model):
    """Per move: the actuator strokes of both paths and the end effector under each."""
    names, rest, p0, a0 = at_rest(model)
    rows = []
    for label, (dx, dy) in MOVES.items():
        start = time.perf_counter()
        wanted = targets(dx, dy)
        nonlinear = move_path(model, wanted, kind="nonlinear", points=5)
        linear = move_path(model, wanted, kind="linear")
        end_n, end_l = nonlinear.displacement([1.0])[0], linear.displacement([1.0])[0]
        # the actuators held exactly on the linear strokes: where the end effector goes
        held = {name: rest.solution.x[model.coordinate_index(name)] + d
                for name, d in zip(names, end_l, strict=True)}
        forward = inverse_statics(model, held, start=rest)
        p, a = effector(model, forward.solution.x)
        error = p - p0 - np.array([dx, dy, 0.0]) * 1e3
        rows.append({"move": label, "nonlinear": end_n * 1e3, "linear": end_l * 1e3,
                     "position_error": error, "rotation": a - a0})
        log(f"  {label}: {time.perf_counter() - start:.1f} s")
    return rows


def print_moves(rows):
    print("| move | actuator strokes, nonlinear path (mm) | linear path minus nonlinear (um) "
          "| end effector on the linear strokes: position error (um) | its rotation (mrad) |")
    print("| --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['move']} | {' '.join(f'{v:.4f}' for v in r['nonlinear'])} | "
              f"{' '.join(f'{v:+.1f}' for v in (r['linear'] - r['nonlinear']) * 1e3)} | "
              f"{' '.join(f'{v:+.2f}' for v in r['position_error'] * 1e3)} | "
              f"{' '.join(f'{v:+.4f}' for v in r['rotation'])} |")


def closed_loop(design, figures, *, plant="inprocess", duration=1.0, settle=0.25, path=None,
                workdir=None, disturbed=False, model=None):
    """The 6 mm xy move in `duration` (s) in closed loop on the control model, `settle` (s)
    after it, on `plant` (a `run_loop` plant); returns the LoopResult. `disturbed`: with the
    encoders' quantum and the 50 Hz force of `DISTURBANCES`. An in-process run writes its
    plot to `figures` (None: no plot). `path`: the move's MovePath if made before. `model`:
    the control model, or the one through its voice coils (COILS; `design` then from it)."""
    model = load_scene(CONTROL) if model is None else model
    if path is None:
        dx, dy = MOVES["6 mm xy"]
        path = move_path(model, targets(dx, dy), kind="nonlinear")
    result = run_loop(model, path=path, design=design, duration=duration, settle=settle,
                      fs=design.sample_rate_hz, plant=plant, workdir=workdir,
                      progress=Progress(f"  closed loop ({plant}"
                                        f"{', disturbed' if disturbed else ''})"),
                      **(DISTURBANCES if disturbed else {}))
    if figures is not None and plant == "inprocess":
        result.plot(figures / ("manipulator_loop_coils.png" if model.actuators
                               else "manipulator_loop_disturbed.png" if disturbed
                               else "manipulator_loop.png"))
    return result


def compare_plants(design, plants, figures, *, duration=1.0, settle=0.25, model=None):
    """The move in process and on each of `plants` ("fmu", "libcosim"); returns
    {plant: LoopResult}, "inprocess" first. `model`: the control model (default), or the one
    through its voice coils (COILS; `design` then from it).

    All follow the same path with the same designed loops, so they differ only by how the
    plant is stepped (the same integrator and tolerance, inside the FMU)."""
    model = load_scene(CONTROL) if model is None else model
    dx, dy = MOVES["6 mm xy"]
    path = move_path(model, targets(dx, dy), kind="nonlinear")
    results = {"inprocess": closed_loop(design, figures, duration=duration, settle=settle,
                                        path=path, model=model)}
    with tempfile.TemporaryDirectory(prefix="manipulator_loop_") as workdir:  # FMUs, shared
        for plant in plants:
            results[plant] = closed_loop(design, figures, plant=plant, duration=duration,
                                         settle=settle, path=path, workdir=workdir,
                                         model=model)
    return results


def print_comparison(inprocess, other):
    """Each actuator's error / stroke on both plants, and their difference."""
    plant = other.settings["plant"]
    print(f"| loop | stroke (mm) | error / stroke, in process | error / stroke, {plant} | "
          "difference | max position difference / stroke |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    strokes = inprocess.loop_strokes
    apart = np.max(np.abs(other.position - inprocess.position), axis=0) / strokes
    for a, b, d in zip(inprocess.per_loop(), other.per_loop(), apart, strict=True):
        print(f"| {a['loop']} | {a['stroke'] * 1e3:.4f} | {a['error_ratio']:.4e} | "
              f"{b['error_ratio']:.4e} | {b['error_ratio'] - a['error_ratio']:+.1e} | "
              f"{d:.1e} |")
    print(f"\nwall time: {inprocess.wall_time_s:.1f} s in process, {other.wall_time_s:.1f} s "
          f"{plant} (with building its FMUs)")


def closed_loop_moves(design):
    """--moves: every move in closed loop on the nonlinear path and its feedforward. Per move
    each actuator's error / stroke, and where the end effector ends up: the forward statics
    of the actuators' last measured positions, against where it was sent."""
    model = load_scene(CONTROL)
    names, rest, p0, a0 = at_rest(model)
    rows = []
    for label, (dx, dy) in MOVES.items():
        log(f"  closed loop: {label}")
        path = move_path(model, targets(dx, dy), kind="nonlinear")
        result = closed_loop(design, None, model=model, path=path)
        end = inverse_statics(model, dict(zip(names, result.position[-1], strict=True)),
                              start=rest)
        p, a = effector(model, end.solution.x)
        rows.append({"move": label, "loops": result.per_loop(), "wall": result.wall_time_s,
                     "position_error": p - p0 - np.array([dx, dy, 0.0]) * 1e3,
                     "rotation": a - a0})
    return rows


def print_closed_loop_moves(rows):
    """Per move: the six errors / stroke, and the end effector at the end of the move."""
    print("| move | error / stroke, actuators 1 to 6 | within 0.1 % | end effector at the end: "
          "position error x y z (um) | its rotation x y z (mrad) | loop wall (s) |")
    print("| --- | --- | --- | --- | --- | ---: |")
    for row in rows:
        ratios = " ".join(f"{loop['error_ratio']:.1e}" for loop in row["loops"])
        passed = all(loop["passed"] for loop in row["loops"])
        print(f"| {row['move']} | {ratios} | {'yes' if passed else 'NO'} | "
              f"{' '.join(f'{v:+.3f}' for v in row['position_error'] * 1e3)} | "
              f"{' '.join(f'{v:+.4f}' for v in row['rotation'])} | {row['wall']:.1f} |")


def print_closed_loop(clean, disturbed):
    """Each actuator's tracking error without and with the disturbances."""
    print("| loop | stroke (mm) | max error (nm) | error / stroke | with 50 nm encoders and "
          "30 mN at 50 Hz: max error (nm) | error / stroke | within 0.1 % |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | --- |")
    for row, noisy in zip(clean.per_loop(), disturbed.per_loop(), strict=True):
        print(f"| {row['loop']} | {row['stroke'] * 1e3:.4f} | "
              f"{row['max_abs_error'] * 1e9:.1f} | {row['error_ratio']:.2e} | "
              f"{noisy['max_abs_error'] * 1e9:.1f} | {noisy['error_ratio']:.2e} | "
              f"{'yes' if noisy['passed'] else 'NO'} |")


def print_coil_loop(result):
    """Each actuator's tracking error through its coil and the largest drive signal."""
    print("| loop | stroke (mm) | max error (nm) | error / stroke | within 0.1 % | "
          "largest drive signal (V) |")
    print("| --- | ---: | ---: | ---: | --- | ---: |")
    drive = np.max(np.abs(result.force), axis=0)
    for row, volts in zip(result.per_loop(), drive, strict=True):
        print(f"| {row['loop']} | {row['stroke'] * 1e3:.4f} | "
              f"{row['max_abs_error'] * 1e9:.1f} | {row['error_ratio']:.2e} | "
              f"{'yes' if row['passed'] else 'NO'} | {volts:.3f} |")


def coils_study(loop, figures, plant="inprocess"):
    """--coils: the back-EMF's damping, the loops through the coils, with `loop` the move (in
    process and on `plant` when that is "fmu" or "libcosim")."""
    log("suspension modes without and with the coils")
    print("Damping of the suspension modes by the voice coils' back-EMF\n")
    print_coil_damping(coil_damping())
    log("design and robustness through the coils")
    design, rows = robustness(coils=True)
    print("\nRobust stability through the coils (design: 300 rad/s on the low-frequency model "
          "with the coils' equations, 4 kHz)\n")
    print_robustness(rows)
    if loop and plant != "inprocess":
        log(f"closed loop through the coils: 6 mm xy, in process and {plant}")
        results = compare_plants(design, [plant], figures, model=load_scene(COILS))
        print(f"\nClosed loop through the coils, 6 mm xy in 1 s, in process and {plant}\n")
        print_comparison(results["inprocess"], results[plant])
    elif loop:
        log("closed loop through the coils: 6 mm xy")
        result = closed_loop(design, figures, model=load_scene(COILS))
        print(f"\nClosed loop through the coils, 6 mm xy in 1 s ({result.wall_time_s:.1f} s "
              "wall)\n")
        print_coil_loop(result)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--loop", action="store_true",
                        help="also run the 6 mm xy move in closed loop (minutes)")
    parser.add_argument("--plant", choices=("inprocess", "fmu", "libcosim"),
                        default="inprocess",
                        help="with --loop: also run the loop on this plant (fmu: the "
                             "manipulator's FMU under fmpy; libcosim: it and a controller FMU "
                             "in libcosim) and compare it with the in-process loop")
    parser.add_argument("--coils", action="store_true",
                        help=f"the study through the voice coils ({COILS}): their damping, "
                             "the design and its robustness; with --loop the 6 mm xy move")
    parser.add_argument("--moves", action="store_true",
                        help="with --loop: every move in closed loop, not the 6 mm xy alone")
    parser.add_argument("--figures", type=Path, default=FIGURES, help="folder for the PNG")
    args = parser.parse_args(argv)
    if args.plant != "inprocess" and not args.loop:
        parser.error("--plant compares the closed loop: give --loop too")
    if args.moves and (not args.loop or args.plant != "inprocess" or args.coils):
        parser.error("--moves runs every move in closed loop in process: give --loop alone")
    args.figures.mkdir(parents=True, exist_ok=True)  # written after minutes of work
    if args.coils:
        coils_study(args.loop, args.figures, args.plant)
        return 0
    log("design and robustness")
    design, rows = robustness()
    print("Robust stability (design: 300 rad/s on the low-frequency model, 4 kHz)\n")
    print_robustness(rows)
    log("moves")
    print("\nMoves of the end effector (control model)\n")
    print_moves(moves(load_scene(CONTROL)))
    if args.loop and args.plant != "inprocess":
        log(f"closed loop: 6 mm xy, in process and {args.plant}")
        results = compare_plants(design, [args.plant], args.figures)
        print(f"\nClosed loop, 6 mm xy in 1 s, in process and {args.plant}\n")
        print_comparison(results["inprocess"], results[args.plant])
    elif args.moves:
        log("closed loop: every move")
        print("\nClosed loop, every move in 1 s (+ 0.25 s), nonlinear path and feedforward\n")
        print_closed_loop_moves(closed_loop_moves(design))
    elif args.loop:
        log("closed loop: 6 mm xy, then with the disturbances")
        model = load_scene(CONTROL)
        dx, dy = MOVES["6 mm xy"]
        path = move_path(model, targets(dx, dy), kind="nonlinear")
        clean = closed_loop(design, args.figures, model=model, path=path)
        disturbed = closed_loop(design, args.figures, model=model, path=path, disturbed=True)
        print(f"\nClosed loop, 6 mm xy in 1 s ({clean.wall_time_s:.1f} s wall; with the "
              f"disturbances {disturbed.wall_time_s:.1f} s)\n")
        print_closed_loop(clean, disturbed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
