"""Tutorial 3: a closed loop in Python, with and without feedforward, and on the linear plant.

    python examples/tutorials/closed_loop.py

The 1-DOF leaf-spring stage (built-in scene stage_planar_1dof) makes a 0.5 mm third-order move
in 0.5 s, sampled at 4 kHz: a PID-like feedback at a 300 rad/s cross-over, with the
feedforward m a + c v + k x of the stage's low-frequency model, and without. The plant is the
nonlinear simulation (the one-step ESDIRK, compiled with the controller). The target is a
tracking error within 0.1 % of the stroke. Last, the loop with feedforward on the stage's
linearisation (`plant="linear"`, stepped exactly): what one tunes a controller on, fast on any
model; its error next to the nonlinear plant's is what the nonlinearity adds.
"""

from flexure.controllers import run_loop

STROKE, DURATION, SETTLE = 0.5e-3, 0.5, 0.1  # m, s, s


def main():
    """Run the three loops; print and return {"feedforward": summary, "feedback alone": ...,
    "linear plant": ...}."""
    runs = {}
    for label, feedforward, plant in (("feedforward", True, "inprocess"),
                                      ("feedback alone", False, "inprocess"),
                                      ("linear plant", True, "linear")):
        result = run_loop("stage_planar_1dof", stroke=STROKE, duration=DURATION, settle=SETTLE,
                          feedforward=feedforward, plant=plant)
        runs[label] = summary = result.summary()
        print(f"{label:15s} max |error| {summary['max_abs_error']:.3e} m = "
              f"{100 * summary['error_ratio']:.2e} % of the stroke "
              f"({'passed' if summary['passed'] else 'FAILED'} against 0.1 %), "
              f"loop {summary['wall_time_s']:.3f} s")
    margins = runs["feedforward"]
    print(f"phase margin {margins['phase_margin_deg']:.1f} deg, gain margin "
          f"{margins['gain_margin']:.2f}, cross-over {margins['crossover_rad_s']:.0f} rad/s")
    return runs


if __name__ == "__main__":
    main()
