"""Where one stage iteration of manipulator_control's closed loop goes: the steps of the
ESDIRK's stage force in mass form (OP_STAGE_FORCE, `engine.stage_force`) replicated in a
compiled loop and stopped after each step, CPU per call (medians of batches); a step's cost is
the difference of two prefixes.

The states are the loop's: the forces of one closed-loop 6 mm xy run (`run_loop` as the
benchmark's row runs it, esdirk2 at rtol 1e-5, 4 kHz) replayed open loop from rest to the
sample of the fastest motion (`STATE_AT` of the move), then the state one ESDIRK step later.
Each prefix is timed twice: alternating those two states (as the first iteration of a stage,
whose kinematics start from the last evaluation a stage apart) and alternating the first
state with one a Newton correction away (`CORRECTION` of the step's change: the later
iterations). The candidate accelerations are the step's difference quotient.

The steps (`stage_force`, `motion.coordinate_forces`, `kinematics.solve_kinematics`):

    predict        x_prev + J_prev^-1 [0; q - q_prev] (one solve with the kept factors)
    residual       the slaves filled, every element's e alone, the constraint residual
    chord          the chord iterations with the kept factors (each: a solve, the slaves
                   filled, e and De, the residual: `kinematics.solve_kinematics`)
    De at solution e and De of every element (D2e of the non-BEAMs) where no chord step
                   was taken (after one, its iterate's evaluation is the solution's)
    J factor       J_z's entries (the touching elements' De T_e) and its sparse LU
    xdot           J^-1 [0; qdot], the slaves' T zdot
    slaves' c      the slaves' second-order accelerations
    element rates  edot = De xdot and the constraint rows' h (the BEAMs' own kernel)
    stresses       sigma_c = S e + D edot, r = f + B u - De^T sigma_c
    xddot_c        J^-1 ([0; a_c] - h - the slaves' h)
    force - mass   r - M xddot_c element by element, T^T (`inertia_product.force_minus_mass`)
    J^-T, DF^T     the last solve and the DOF rows

python -m examples.benchmarks.manipulator_stage_profile [COUNT [SCENE]]
"""

import statistics
import sys
import time

import numpy as np

STATE_AT = 0.5  # of the move's duration: the replay's last sample
CORRECTION = 1e-3  # the later iterations' state change, of the step's
# other scenes' replays: manipulator_reduced's loop as `reduced_methods` runs it, replayed
# with the order-4 ESDIRK at 1e-4 (one step a sample: a step apart is a sample apart)
REPLAYS = {"manipulator_reduced": {"method": "esdirk", "rtol": 1e-4, "move": (0.05, 0.0125)}}
STEPS = ("predict", "residual", "chord", "De at solution", "J factor", "xdot", "slaves' c",
         "element rates", "stresses", "xddot_c", "force - mass", "J^-T, DF^T")


def make_replica():
    """The compiled replica (numba), built on first use: replica(table, ys, acc, out, upto,
    count) makes `count` stage forces alternating the states ys, each stopped after step
    `upto` (an index of STEPS; len(STEPS) - 1: the whole force); returns the chord
    iterations taken over the calls."""
    from flexure.core.engine import data as ed
    from flexure.core.engine import slots as slot
    from flexure.core.engine.actuators import port_values
    from flexure.core.engine.deformation_rates import (
        element_rates,
        scatter_stress,
        stress_resultants,
    )
    from flexure.core.engine.factors import j_solve
    from flexure.core.engine.inertia_product import force_minus_mass
    from flexure.core.engine.kinematics import (
        deformations,
        dof_rows,
        dof_values,
        evaluate_elements,
        kinematic_residual,
        newton_step,
        predicted_coordinates,
        solution_order,
        store_solution,
    )
    from flexure.core.engine.motion import any_nonzero
    from flexure.core.engine.operations import (
        OP_RIGID_CONVECTIVE,
        OP_RIGID_EXPAND,
        OP_RIGID_RATES,
        run,
    )
    from flexure.core.engine.ports import add_input_forces
    from flexure.core.engine.slots import float_array as _f
    from flexure.core.engine.slots import int_array as _i
    from flexure.core.numerics.dense import copy
    from flexure.core.numerics.jit import kernel

    @kernel
    def keep(table, q, x):
        """x and q kept as the next warm start, J's factors as they were (a prefix that
        stops before `store_solution`: the next call predicts from this call's x as a run would)."""
        copy(_f(table, slot.X)[: x.size], x)
        copy(_f(table, slot.Q), q)

    @kernel
    def kinematics(table, q, upto):
        """The warm path of `solve_kinematics`, stopped after step `upto`; its chord
        iterations."""
        dims = _i(table, slot.DIMS)
        x, g, dx = _f(table, slot.X_TRIAL), _f(table, slot.G), _f(table, slot.DX)
        predicted_coordinates(table, q, x, _f(table, slot.REDUCED_FORCE), dx)
        if upto == 0:
            keep(table, q, x)
            return 0
        evaluate_elements(table, x, 0)
        solved = kinematic_residual(table, x, q, g) <= 1.0
        if upto == 1:
            keep(table, q, x)
            return 0
        chords = 0
        previous = 0.0
        while not solved and chords < dims[ed.CHORD_ITERATIONS]:
            step = newton_step(table, x, g, dx)
            chords += 1
            evaluate_elements(table, x, solution_order(table))
            rate = step / previous if previous > 0.0 else 1.0
            previous = step
            solved = kinematic_residual(table, x, q, g) <= 1.0 or step == 0.0 or (
                rate < 1.0 and step * rate <= 1.0 - rate)
        if upto == 2:
            keep(table, q, x)
            return chords
        if chords == 0:  # else the last chord iterate's evaluation had De
            deformations(table, x, solution_order(table), True)
        if upto == 3:
            keep(table, q, x)
            return chords
        store_solution(table, q, x)
        return chords

    @kernel
    def replica(table, ys, acc, out, upto, count):
        dims = _i(table, slot.DIMS)
        n, nf, nx = dims[ed.NDOF], dims[ed.NFREE], dims[ed.NX]
        x, xdot, r = _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.FORCE)
        free, dx = _i(table, slot.FREE), _f(table, slot.DX)
        q = np.empty(n)
        chords = 0
        for call in range(count):
            y = ys[call % ys.shape[0]]
            q_ref = _f(table, slot.Q_REF)
            for j in range(n):
                q[j] = q_ref[j] + y[j]
            qdot = y[n:]
            chords += kinematics(table, q, upto)
            if upto <= 4:
                continue
            moving = any_nonzero(qdot)
            dof_rows(table, qdot, dx)
            j_solve(table, dx, False)
            xdot[:] = 0.0
            for a in range(nf):
                xdot[free[a]] = dx[a]
            run(table, OP_RIGID_EXPAND, xdot.ctypes.data, 0, 0.0)
            if upto == 5:
                continue
            run(table, OP_RIGID_CONVECTIVE, x.ctypes.data, xdot.ctypes.data, 0.0)
            if upto == 6:
                continue
            element_rates(table, xdot, moving)
            if upto == 7:
                continue
            sigma = stress_resultants(table)
            copy(r, _f(table, slot.CONST_FORCE))
            add_input_forces(_i(table, slot.INPUT_PORTS), port_values(table), x, r)
            scatter_stress(table, sigma, r)
            if upto == 8:
                continue
            xddot = _f(table, slot.DX)
            dof_rows(table, acc, xddot)
            quad = _f(table, slot.G)
            for a in range(nf):
                xddot[a] -= quad[a]
            run(table, OP_RIGID_RATES, 0, 0, 0.0)
            rigid_h = _f(table, slot.RIGID_H)
            for a in range(nf):
                xddot[a] -= rigid_h[a]
            j_solve(table, xddot, False)
            if upto == 9:
                continue
            w = _f(table, slot.AUG_RHS)
            force_minus_mass(table, x, xdot, moving, r, xddot[:nf], _f(table, slot.XDDOT),
                             _f(table, slot.X_TRIAL), w[:nf])
            if upto == 10:
                continue
            j_solve(table, w[:nf], True)
            dof_values(table, w, out)
        return chords + 0 * nx

    return replica


def states(name="manipulator_control", method=None, rtol=None, move=None):
    """(model, simulator, the first state, one a step later, the step (s)) of the loop's
    replay (the module's docstring) on the scene `name`; the replay with `method` at `rtol`
    (default the loop's own), the loop's move in `move` = (duration, settle) s (default
    `run_loop`'s)."""
    from flexure.controllers.move_path import move_path
    from flexure.controllers.runner import run_loop
    from flexure.core import Simulator, load_scene

    from ..manipulator_loop import MOVES, targets

    model = load_scene(name)
    path = move_path(model, targets(*MOVES["6 mm xy"]), kind="nonlinear")
    timing = {} if move is None else {"duration": move[0], "settle": move[1]}
    loop = run_loop(model, path=path, plant="inprocess", **timing)
    sim = Simulator(model, method=method or loop.settings["method"],
                    rtol=rtol or loop.settings["rtol"])
    last = int(round(STATE_AT * loop.settings["move_end"] / (loop.t[1] - loop.t[0])))
    for k in range(last):
        sim.set_inputs(loop.force[k])
        sim.advance_to(loop.t[k + 1])
    first, steps, start = np.array(sim.state, dtype=float), sim.statistics["steps"], sim.time
    while sim.statistics["steps"] == steps:
        sim.advance_to(sim.time + 1e-6)
    return model, sim, first, np.array(sim.state, dtype=float), sim.time - start


def profile(count=400, batches=5, **replay):
    """{(pair, step): CPU s per call of that step}, chord iterations a call by pair, the
    full OP_STAGE_FORCE's and OP_RHS's CPU s per call by pair (pair: "a step apart", "a
    correction apart"); `replay`: `states`' arguments (the scene, the replay's method)."""
    from flexure.core.engine import access
    from flexure.core.engine import data as ed
    from flexure.core.engine.operations import FORCE, OP_RHS, OP_STAGE_FORCE
    from flexure.core.numerics.jit import kernel
    from flexure.core.numerics.native import call_engine

    @kernel
    def operation(table, op, ys, acc, out, count):
        for k in range(count):
            y = ys[k % ys.shape[0]]
            if op == OP_STAGE_FORCE:
                call_engine(access.dims(table)[ed.ENGINE], op, table, 0.0, y.ctypes.data,
                            acc.ctypes.data, out.ctypes.data, FORCE)
            else:
                call_engine(access.dims(table)[ed.ENGINE], op, table, 0.0, y.ctypes.data,
                            out.ctypes.data, 0, 0.0)
        return 0

    _, sim, first, second, h = states(**replay)
    n = first.size // 2
    table = sim.data.address
    acc = (second[n:] - first[n:]) / h
    pairs = {"a step apart": np.stack([first, second]),
             "a correction apart": np.stack([first, first + CORRECTION * (second - first)])}
    replica = make_replica()
    out = np.zeros(2 * n)

    def cpu(function, *args):
        function(*args, 2)
        seconds = []
        for _ in range(batches):
            start = time.process_time()
            function(*args, count)
            seconds.append((time.process_time() - start) / count)
        return statistics.median(seconds)

    prefixes, chords, whole = {}, {}, {}
    for pair, ys in pairs.items():
        ys = np.ascontiguousarray(ys)
        chords[pair] = replica(table, ys, acc, out, 2, count) / count
        for upto in range(len(STEPS)):
            prefixes[pair, upto] = cpu(replica, table, ys, acc, out, upto)
        whole[pair] = (cpu(operation, table, OP_STAGE_FORCE, ys, acc, out),
                       cpu(operation, table, OP_RHS, ys, acc, out))
    parts = {(pair, STEPS[k]): prefixes[pair, k] - (prefixes[pair, k - 1] if k else 0.0)
             for pair in pairs for k in range(len(STEPS))}
    return parts, chords, whole


def main(argv):
    count = int(argv[0]) if argv else 400
    name = argv[1] if len(argv) > 1 else "manipulator_control"
    parts, chords, whole = profile(count, name=name, **REPLAYS.get(name, {}))
    pairs = list(chords)
    print(f"{name}, one stage iteration (us a call; medians of 5 batches of {count})")
    print(f"| step | {' | '.join(pairs)} |")
    print("|---|" + "---|" * len(pairs))
    for name in STEPS:
        print(f"| {name} | " + " | ".join(f"{1e6 * parts[p, name]:.1f}" for p in pairs) + " |")
    print("| sum of the steps (the replica) | " + " | ".join(
        f"{1e6 * sum(parts[p, s] for s in STEPS):.1f}" for p in pairs) + " |")
    print("| OP_STAGE_FORCE | " + " | ".join(f"{1e6 * whole[p][0]:.1f}" for p in pairs) + " |")
    print("| OP_RHS | " + " | ".join(f"{1e6 * whole[p][1]:.1f}" for p in pairs) + " |")
    print("| chord iterations a call | " + " | ".join(f"{chords[p]:.2f}" for p in pairs) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
