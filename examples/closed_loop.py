"""Closed-loop tracking report: PID-like feedback plus feedforward on the leaf-spring stages.

The control target of the book chapter (seed 001): track a third-order move of 1 s within
0.1 % of its stroke with a PID-like feedback of about 300 rad/s cross-over, improved by the
feedforward of a stable inverse of the low-frequency model. For each case the loop of
`flexure.controllers.run_loop` is run on the nonlinear plant and the largest tracking error
max_k |r_k - y_k| (during the move and 0.25 s after it) is compared with 0.1 % of the stroke:

1. stage_planar_1dof, 1 mm in 1 s, feedback + feedforward, and feedback alone beside it;
2. 10 mm, where the nonlinear plant departs from the linear model of the feedforward;
3. stage_planar_3dof and stage_spatial_19dof: the parasitic modes are in the loop (and the
   3-DOF stage with the stable approximate inverse of its full model as feedforward);
4. the feedforward from a model with 10 % mass and stiffness error, on the true plant;
5. the three plants (in-process, the scene FMU under fmpy, controller and scene FMUs in
   libcosim): their difference in the tracking error, relative to the stroke.

Run `python examples/closed_loop.py` (about 10 minutes: each sample is an integrator call)
for the table of the README; `--quick` runs every case over a 0.02 s move (the tests do).
"""

import argparse
import tempfile
import warnings

import numpy as np

from flexure.controllers import low_frequency_model, run_loop
from flexure.core import load_scene
from flexure.core.reporting.tables import markdown_table

warnings.filterwarnings("ignore", module="scipy.signal")

HEADERS = ["case", "scene", "plant", "controller", "stroke (mm)", "max abs error (m)",
           "error / stroke (%)", "target 0.1 %", "max feedback force (N)", "max force (N)",
           "phase margin (deg)", "gain margin", "modulus margin", "closed-loop max abs(pole)",
           "wall time (s)"]


def cases(*, quick=False):
    """The runs of the report: (label, scene, keyword arguments of run_loop)."""
    one = load_scene("stage_planar_1dof")
    lf = low_frequency_model(one)
    out = [
        ("feedback + feedforward", "stage_planar_1dof", {}),
        ("feedback alone", "stage_planar_1dof", {"feedforward": False}),
        ("10 mm stroke", "stage_planar_1dof", {"stroke": 10e-3}),
        ("10 mm stroke, feedback alone", "stage_planar_1dof",
         {"stroke": 10e-3, "feedforward": False}),
        ("3 DOF, parasitic modes", "stage_planar_3dof", {}),
        ("3 DOF, inverse (ZPETC) feedforward", "stage_planar_3dof", {"feedforward": "inverse"}),
        ("feedforward model +10 % m, k", "stage_planar_1dof",
         {"feedforward_model": lf.scaled(mass=1.1, stiffness=1.1)}),
        ("feedforward model -10 % m, k", "stage_planar_1dof",
         {"feedforward_model": lf.scaled(mass=0.9, stiffness=0.9)}),
        ("plant: scene FMU (fmpy)", "stage_planar_1dof", {"plant": "fmu"}),
        ("plant: FMUs in libcosim", "stage_planar_1dof", {"plant": "libcosim"}),
    ]
    if not quick:
        out.insert(5, ("19 DOF, parasitic modes", "stage_spatial_19dof", {}))
    return out


def main(*, quick=False, plot=None, workdir=None):
    """Run every case; returns (rows, results by label) and prints the markdown tables."""
    timing = {"duration": 0.02, "settle": 0.01} if quick else {"duration": 1.0, "settle": 0.25}
    workdir = workdir or tempfile.mkdtemp(prefix="flexure_closed_loop_")
    rows, results = [], {}
    for label, scene, options in cases(quick=quick):
        options = {"stroke": 1e-3, **timing, **options}
        result = run_loop(scene, workdir=workdir, **options)
        s = result.summary()
        results[label] = result
        rows.append((label, scene, s["plant"],
                     f"feedback + {s['feedforward_kind']} feedforward" if s["feedforward"]
                     else "feedback alone",
                     s["stroke"] * 1e3, s["max_abs_error"], 100 * s["error_ratio"],
                     "passed" if s["passed"] else "failed", s["max_abs_feedback_force"],
                     s["max_abs_force"], s["phase_margin_deg"], s["gain_margin"],
                     s["modulus_margin"], s["closed_loop_spectral_radius"], s["wall_time_s"]))
        print(f"{label}: max |e| = {s['max_abs_error']:.4g} m "
              f"({100 * s['error_ratio']:.4g} %), {s['wall_time_s']:.1f} s", flush=True)
    print()
    print(markdown_table(HEADERS, rows))
    reference = results["feedback + feedforward"]
    agreement = []
    for label in ("plant: scene FMU (fmpy)", "plant: FMUs in libcosim"):
        other = results[label]
        agreement.append((label, np.max(np.abs(other.position - reference.position))
                          / reference.stroke,
                          abs(other.max_abs_error - reference.max_abs_error) / reference.stroke))
    print()
    print(markdown_table(["plant against in-process", "max abs(y - y_inprocess) / stroke",
                          "difference of max abs(e) / stroke"], agreement))
    if plot:
        reference.plot(plot)
    return rows, results, agreement


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="0.02 s moves (seconds, not minutes)")
    parser.add_argument("--plot", default=None, help="plot of the first case (PNG)")
    args = parser.parse_args()
    main(quick=args.quick, plot=args.plot)
