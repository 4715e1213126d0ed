"""Work-precision of the velocities' absolute tolerance: the default rule (every velocity's
atol the position's times the LOWEST natural frequency, `tolerances.default_atol`) against a
per-DOF rule (each velocity's atol the position's times sqrt(K0_ii / M0_ii), the Rayleigh
quotient of that DOF's unit vector, at least the lowest frequency).

Open loop (a 1 N step on every input from rest, every accepted step, the states at equally
spaced times by the cubic Hermite interpolant): the error is max |q - q_ref| over the samples
and DOFs over max |q_ref| (q the DOFs' deviations, m or rad), the reference esdirk at
`REFERENCE_RTOL`. The loops (`run_loop` on the nonlinear move path, in process): the error is
max |y - y_ref| over the samples and loops of the loops' positions over the stroke, and the
tracking error's change against the reference's. Time: the integration's wall
(`Simulator.statistics`) open loop, the loop's CPU (`LoopResult.cpu_time_s`) on the loops.

    python -m examples.benchmarks.velocity_atol CASE [--methods esdirk2,...] [--rtols ...]

CASE: stage_planar_1dof, stage_planar_3dof, stage_spatial_19dof, cantilever16,
manipulator_control, manipulator_reduced.
"""

import argparse

import numpy as np

from flexure.core.simulation import tolerances

REFERENCE_RTOL = 1e-9
OPEN_LOOP = {"stage_planar_1dof": 0.04, "stage_planar_3dof": 0.04, "stage_spatial_19dof": 0.04,
             "cantilever16": 0.005}  # s simulated
LOOPS = {"manipulator_control": (0.2, 0.05), "manipulator_reduced": (0.02, 0.005)}  # move, settle
DEFAULT_ATOL = tolerances.default_atol


def per_dof_atol(model, rtol, data=None):
    """The default atol with each velocity's scaled by max(omega_ref, sqrt(K0_ii / M0_ii))
    instead of omega_ref (rad/s)."""
    from flexure.core.mechanics.kinematics import length_scale

    atol = DEFAULT_ATOL(model, rtol, data).copy()
    n = model.declared_dof_count
    _, _, M0, K0 = tolerances.initial_matrices(model, data)
    omega_ref = tolerances.reference_frequency(model, M0, K0, length_scale(model))
    m, k = np.diag(M0), np.diag(K0)
    ok = (m > 0) & (k > 0)
    omega = np.full(n, omega_ref)
    omega[ok] = np.maximum(omega_ref, np.sqrt(k[ok] / m[ok]))
    atol[n:2 * n] *= omega / omega_ref
    return atol


def use_rule(rule):
    """Make `rule` ("default" or "per-dof") every Simulator's default atol in this process."""
    tolerances.default_atol = per_dof_atol if rule == "per-dof" else DEFAULT_ATOL


def load(case):
    """The model of a CASE: a built-in scene, or "cantileverN" (`spatial_cantilever(N)`)."""
    from flexure.core import load_scene

    if case.startswith("cantilever"):
        from .spatial import spatial_cantilever
        return spatial_cantilever(int(case[len("cantilever"):]))
    return load_scene(case)


def open_loop(model, t_end, method, rtol):
    """(q at the sample times, the integration's wall s, steps, rhs evaluations)."""
    import scipy.interpolate

    from flexure.core import simulate

    inputs = {port.name: 1.0 for port in model.inputs}
    result = simulate(model, t_end, inputs=inputs, method=method, rtol=rtol)
    stats = result.statistics
    times = np.linspace(0.0, t_end, 201)
    q = scipy.interpolate.CubicHermiteSpline(result.times, result.q, result.qdot)(times)
    return q, stats["wall_time_s"], stats["steps"], stats["rhs_evaluations"]


def loop(model, path, move, method, rtol):
    """(LoopResult, steps, rhs evaluations)."""
    from flexure.controllers import runner
    from flexure.controllers.runner import run_loop

    made = []
    compiled = runner.compiled_loop

    def recording(*args, ended, **kwargs):  # the plant's Simulator at the end, for its counts
        return compiled(*args, ended=lambda sim: (made.append(sim), ended(sim)), **kwargs)
    runner.compiled_loop = recording
    try:
        result = run_loop(model, path=path, plant="inprocess", duration=move[0],
                          settle=move[1], method=method, rtol=rtol)
    finally:
        runner.compiled_loop = compiled
    stats = made[-1].statistics
    return result, stats["steps"], stats["rhs_evaluations"]


def main(argv=None):
    """Print the work-precision rows of one CASE, the default rule and per-DOF interleaved."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=[*OPEN_LOOP, *LOOPS])
    parser.add_argument("--methods", default="esdirk2,esdirk3,esdirk,sdirk2")
    parser.add_argument("--rtols", default="1e-3,1e-4,1e-5,1e-6")
    parser.add_argument("--rules", default="default,per-dof")
    args = parser.parse_args(argv)
    model = load(args.case)
    rtols = [float(r) for r in args.rtols.split(",")]
    print(f"{args.case}: {model.ndof} DOFs", flush=True)
    if args.case in LOOPS:
        from flexure.controllers.move_path import move_path

        from ..manipulator_loop import MOVES, targets
        path = move_path(model, targets(*MOVES["6 mm xy"]), kind="nonlinear")
        move = LOOPS[args.case]
        use_rule("default")
        ref, _, _ = loop(model, path, move, "esdirk", REFERENCE_RTOL)
        ref_error = ref.summary()["error_ratio"]
        print(f"reference: tracking error / stroke {ref_error:.10e}", flush=True)
        stroke = np.max(np.abs(ref.reference - ref.reference[0]))
    else:
        t_end = OPEN_LOOP[args.case]
        use_rule("default")
        q_ref, _, _, _ = open_loop(model, t_end, "esdirk", REFERENCE_RTOL)
        scale = np.max(np.abs(q_ref))
    print("rule | method | rtol | steps | rhs | time (s) | error | tracking error change / stroke")
    for method in args.methods.split(","):
        for rtol in rtols:
            for rule in args.rules.split(","):
                use_rule(rule)
                if args.case in LOOPS:
                    result, steps, rhs = loop(model, path, move, method, rtol)
                    cpu = result.cpu_time_s
                    error = np.max(np.abs(result.position - ref.position)) / stroke
                    extra = f"{result.summary()['error_ratio'] - ref_error:+.3e}"
                else:
                    q, cpu, steps, rhs = open_loop(model, t_end, method, rtol)
                    error, extra = np.max(np.abs(q - q_ref)) / scale, ""
                print(f"{rule} | {method} | {rtol:.0e} | {steps} | {rhs} | {cpu:.3f} | "
                      f"{error:.3e} | {extra}", flush=True)
    use_rule("default")


if __name__ == "__main__":
    main()
