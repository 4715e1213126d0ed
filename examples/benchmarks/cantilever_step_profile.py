"""Where one ESDIRK step of the spatial cantilever goes: the engine's operations of the step
called in compiled loops at states of its run (CPU per call, medians of batches), times
their counts in the run.

The cantilever is `spatial.spatial_cantilever(n)` (every deformation a DOF, the sparse Newton
matrix), run with esdirk at rtol 1e-6 over its 5 ms (`spatial.cantilever_step`). A step on
that path is made of (`simulation.esdirk_kernels`): per Newton iteration a stage force
(OP_STAGE_FORCE, the residual in mass form) and a force solve (OP_NEWTON_FORCE_SOLVE), per
new hg a factorisation of the Newton matrix (OP_NEWTON_FACTOR), per attempt the error
estimate's solve (OP_NEWTON_SOLVE), per new Jacobian OP_NEWTON_JACOBIAN. Each is timed in a
loop of `count` calls: the stage force alternating two states a step apart 2 ms into the run
(its kinematics then take the chord steps a run sees), the solves with the position half of
the residual zero (as the stages keep it, `esdirk_newton.consistent_positions`) and not.
The sum of counts times costs is set against the run's CPU per step: what is left is the
step outside the engine (error estimate, step control, the compiled loop's own work).

python -m examples.benchmarks.cantilever_step_profile 16 64
"""

import statistics
import sys

import numpy as np

from .measure import cpu_per_call

AT = 2e-3  # s: the states' time in the 5 ms run


def _loops():
    """The compiled loops (numba), built on first use."""
    from flexure.core.engine import access
    from flexure.core.engine import data as ed
    from flexure.core.engine.operations import (
        FORCE,
        OP_NEWTON_FACTOR,
        OP_NEWTON_JACOBIAN,
        OP_STAGE_FORCE,
    )
    from flexure.core.numerics.jit import kernel
    from flexure.core.numerics.native import call_engine

    @kernel
    def stage_force(table, ys, acc, out, count):
        for k in range(count):
            y = ys[k % ys.shape[0]]
            out[:] = acc
            call_engine(access.dims(table)[ed.ENGINE], OP_STAGE_FORCE, table, 0.0,
                        y.ctypes.data, out.ctypes.data, out.ctypes.data, FORCE)

    @kernel
    def solve(table, op, v0, v, hg, count):
        for _ in range(count):
            v[:] = v0
            call_engine(access.dims(table)[ed.ENGINE], op, table, 0.0, v.ctypes.data, 0, 0, hg)

    @kernel
    def factor(table, hg, count):  # two hg alternating, as new steps have
        for k in range(count):
            call_engine(access.dims(table)[ed.ENGINE], OP_NEWTON_FACTOR, table, 0.0, 0, 0, 0,
                        hg * (1.0 + 1e-6 * (k % 2)))

    @kernel
    def jacobian(table, y, count):
        for _ in range(count):
            call_engine(access.dims(table)[ed.ENGINE], OP_NEWTON_JACOBIAN, table, 0.0,
                        y.ctypes.data, 0, 0, 0.0)

    return dict(stage_force=stage_force, solve=solve, factor=factor, jacobian=jacobian)


def profile(n, *, count=200):
    """({operation: CPU s per call}, the run's counts (steps, rhs, Jacobians, Newton
    factorisations), the run's CPU s per step (median of 3 runs)) of the n-BEAM cantilever."""
    from flexure.core import Simulator
    from flexure.core.engine.operations import OP_NEWTON_FORCE_SOLVE, OP_NEWTON_SOLVE

    from .spatial import cantilever_step, spatial_cantilever

    model = spatial_cantilever(n)
    cantilever_step(model)
    runs = [cantilever_step(model) for _ in range(3)]
    info = runs[0][1]
    per_step = statistics.median(seconds for seconds, _ in runs) / info[0]
    sim = Simulator(model, method="esdirk", rtol=1e-6)
    sim.advance_to(AT)
    first = np.array(sim.state, dtype=float)
    steps = sim.statistics["steps"]
    while sim.statistics["steps"] == steps:  # the state one step later
        sim.advance_to(sim.time + 1e-6)
    second = np.array(sim.state, dtype=float)
    table, ndof = sim.data.address, first.size // 2
    h = 5e-3 / info[0]
    hg = 0.25 * h  # the order-4 tableau's diagonal coefficient is 1/4
    loops = _loops()
    loops["jacobian"](table, first, 1)  # the Newton matrix's parts at the first state
    parts = {"NEWTON_JACOBIAN": cpu_per_call(loops["jacobian"], (table, first), 10),
             "NEWTON_FACTOR": cpu_per_call(loops["factor"], (table, hg), count)}
    v0 = 1e-6 * np.random.default_rng(1).standard_normal(2 * ndof)
    no_r1 = v0.copy()
    no_r1[:ndof] = 0.0
    v = v0.copy()
    parts["NEWTON_FORCE_SOLVE, r1 = 0"] = cpu_per_call(
        loops["solve"], (table, OP_NEWTON_FORCE_SOLVE, no_r1, v, hg), count)
    parts["NEWTON_FORCE_SOLVE, r1 != 0"] = cpu_per_call(
        loops["solve"], (table, OP_NEWTON_FORCE_SOLVE, v0, v, hg), count)
    parts["NEWTON_SOLVE (error estimate)"] = cpu_per_call(
        loops["solve"], (table, OP_NEWTON_SOLVE, v0, v, hg), count)
    ys = np.ascontiguousarray(np.stack([first, second]))
    acc = (second[ndof:] - first[ndof:]) / h
    parts["STAGE_FORCE, two states alternating"] = cpu_per_call(
        loops["stage_force"], (table, ys, acc, np.zeros(ndof)), count)
    return parts, info, per_step


def step_shares(parts, info, per_step):
    """{what: CPU s per step} from the parts and the run's counts, with the rest."""
    steps, rhs, jacobians, factorizations = info
    shares = {"stage forces": rhs * parts["STAGE_FORCE, two states alternating"] / steps,
              "force solves": rhs * parts["NEWTON_FORCE_SOLVE, r1 = 0"] / steps,
              "Newton matrix factorisations":
                  factorizations * parts["NEWTON_FACTOR"] / steps,
              "error estimate solves": parts["NEWTON_SOLVE (error estimate)"],
              "Jacobians": jacobians * parts["NEWTON_JACOBIAN"] / steps}
    shares["rest (outside these operations)"] = per_step - sum(shares.values())
    return shares


def main(argv):
    for n in [int(a) for a in argv] or [16, 64]:
        parts, info, per_step = profile(n)
        print(f"cantilever of {n} BEAMs ({6 * n} DOFs): {1e3 * per_step:.3f} ms a step; "
              f"steps, rhs, Jacobians, factorisations {info}")
        for name, seconds in parts.items():
            print(f"  {name:40s} {1e6 * seconds:9.1f} us a call")
        for name, seconds in step_shares(parts, info, per_step).items():
            print(f"  {name:40s} {1e6 * seconds:9.1f} us a step "
                  f"({100 * seconds / per_step:4.1f} %)")


if __name__ == "__main__":
    main(sys.argv[1:])
