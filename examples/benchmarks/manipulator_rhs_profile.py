"""Where one right-hand side of manipulator_control goes: the steps of OP_RHS
(`engine.first_order_rhs` -> `motion.evaluate` in the augmented form) replicated in a
compiled loop and stopped after each step, CPU per call (medians of batches); a step's cost
is the difference of two prefixes.

Three pairs of states, each alternated call by call: the same state twice (what
`refined.rhs_cost` measures: an integrator never asks that twice), two states one ESDIRK step
apart of the loop's replay (`manipulator_stage_profile.states`: the 6 mm xy move at half its
duration) and two states a Newton correction apart (`CORRECTION` of that step). The steps:

    front half     the kinematics with J's LU, xdot, the slaves' c, the element rates,
                   the stresses, r = f + B u - De^T sigma_c (`motion.coordinate_forces`)
    conv           conv = -J^-1 h on J's rows, the slaves' rows filled (for the tangent;
                   OP_RHS leaves it pending, `engine.convective`, so the sums below
                   leave it out: its row is what a reader of conv pays)
    inertia        A's values cleared, M_ff assembled element by element with the element
                   masses' gravity and -g_conv into r (`motion.inertia_forces`)
    rigid rows     J_o beside and below M_ff, rhs = T^T (r - M c) and -h on the rigid rows
    factor         the sparse LU of A (`factors.augmented_factor`)
    solve          one solve with it
    qddot          xddot filled on x and qddot on the DOFs (`motion.qddot_of_solution`)

and the same for the path OP_RHS takes on this model since session 36, A's solution refined
with kept factors (`refined_accelerations`), its steps replicated with two products always
(the operation takes as many as it needs: one at the same state, two or three a step apart):

    forces and b   the element masses' gravity and -g_conv into r and the residual at d = 0
                   (T^T, the rigid rows) in one element pass (`residual` with its forces)
    d_1            a solve with the kept factors
    product k      the residual at d_k (an element pass, T^T, the rigid rows) and a solve

(the operation itself starts from the last solution when it still holds it, skipping b and
d_1). The OP_RHS row is the operation as it is.

python -m examples.benchmarks.manipulator_rhs_profile [COUNT [SCENE]]
"""

import statistics
import sys
import time

import numpy as np

from .manipulator_stage_profile import CORRECTION, REPLAYS, states

STEPS = ("front half", "conv", "inertia", "rigid rows", "factor", "solve", "qddot")
REFINED_STEPS = ("front half", "conv", "forces and b", "d_1", "product 1", "product 2", "qddot")


def _replica():
    """The compiled replica (numba), built on first use: replica(table, ys, upto, count) makes
    `count` evaluations alternating the states ys, each stopped after step `upto` (an index of
    STEPS; len(STEPS) - 1: the whole evaluation)."""
    from flexure.core.engine import data as ed
    from flexure.core.engine import slots as slot
    from flexure.core.engine.factors import (
        add_rigid_rows,
        augmented_factor,
        augmented_matrix,
        augmented_resolve,
        j_solve,
        kept_resolve,
    )
    from flexure.core.engine.motion import coordinate_forces, inertia_forces, qddot_of_solution
    from flexure.core.engine.operations import (
        OP_RIGID_CONDENSE,
        OP_RIGID_EXPAND,
        OP_RIGID_RATES,
        run,
    )
    from flexure.core.engine.refined_accelerations import residual
    from flexure.core.engine.slots import float_array as _f
    from flexure.core.engine.slots import int_array as _i
    from flexure.core.numerics.dense import copy
    from flexure.core.numerics.jit import kernel

    @kernel
    def replica(table, ys, upto, count):
        dims = _i(table, slot.DIMS)
        n, nf, nx = dims[ed.NDOF], dims[ed.NFREE], dims[ed.NX]
        na = nf + dims[ed.NRIGID]
        free = _i(table, slot.FREE)
        q = np.empty(n)
        for call in range(count):
            y = ys[call % ys.shape[0]]
            q_ref = _f(table, slot.Q_REF)
            for j in range(n):
                q[j] = q_ref[j] + y[j]
            status, moving = coordinate_forces(table, q, y[n: 2 * n])
            if upto == 0:
                continue
            x, xdot, r = _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.FORCE)
            dx, quad, conv = _f(table, slot.DX), _f(table, slot.G), _f(table, slot.CONV)
            rigid_h = _f(table, slot.RIGID_H)
            conv[:] = 0.0
            if moving:
                run(table, OP_RIGID_RATES, 0, 0, 0.0)
                for a in range(nf):
                    dx[a] = quad[a] + rigid_h[a]
                j_solve(table, dx, False)
                for a in range(nf):
                    conv[free[a]] = -dx[a]
                run(table, OP_RIGID_EXPAND, conv.ctypes.data, 0, 1.0)
            if upto == 1:
                continue
            A, rhs = augmented_matrix(table), _f(table, slot.AUG_RHS)
            inertia_forces(table, x, xdot, moving, r, A, na)
            if upto == 2:
                continue
            add_rigid_rows(table, A, na)
            total = _f(table, slot.X_TRIAL)
            rigid_force = _f(table, slot.RIGID_FORCE)
            for a in range(nx):
                total[a] = r[a] + rigid_force[a]
            run(table, OP_RIGID_CONDENSE, total.ctypes.data, rhs.ctypes.data, 0.0)
            for o in range(dims[ed.NRIGID]):
                rhs[nf + o] = -(quad[o] + rigid_h[o]) if moving else 0.0
            if upto == 3:
                continue
            augmented_factor(table, A, na)
            if upto == 4:
                continue
            augmented_resolve(table, na, rhs)
            if upto == 5:
                continue
            qddot_of_solution(table, rhs, _f(table, slot.XDDOT), True, quad, moving,
                              _f(table, slot.QDDOT))
        return status

    @kernel
    def refined(table, ys, upto, count):
        """As `replica`, the refined path's steps (REFINED_STEPS) with two products always."""
        dims = _i(table, slot.DIMS)
        n, nf, nx = dims[ed.NDOF], dims[ed.NFREE], dims[ed.NX]
        na = nf + dims[ed.NRIGID]
        free = _i(table, slot.FREE)
        q = np.empty(n)
        work = _f(table, slot.REFINEMENT)
        b, d, c = work[:na], work[na: 2 * na], work[2 * na: 3 * na]
        a, total = work[3 * na: 3 * na + nx], work[3 * na + nx: 3 * na + 2 * nx]
        for call in range(count):
            y = ys[call % ys.shape[0]]
            q_ref = _f(table, slot.Q_REF)
            for j in range(n):
                q[j] = q_ref[j] + y[j]
            status, moving = coordinate_forces(table, q, y[n: 2 * n])
            if upto == 0:
                continue
            dx, quad, conv = _f(table, slot.DX), _f(table, slot.G), _f(table, slot.CONV)
            rigid_h = _f(table, slot.RIGID_H)
            conv[:] = 0.0
            if moving:
                run(table, OP_RIGID_RATES, 0, 0, 0.0)
                for k in range(nf):
                    dx[k] = quad[k] + rigid_h[k]
                j_solve(table, dx, False)
                for k in range(nf):
                    conv[free[k]] = -dx[k]
                run(table, OP_RIGID_EXPAND, conv.ctypes.data, 0, 1.0)
            if upto == 1:
                continue
            d[:] = 0.0
            residual(table, moving, d, a, total, b, True)
            if upto == 2:
                continue
            copy(d, b)
            kept_resolve(table, True, na, d)
            for product in range(2):
                if upto == 3 + product:
                    break
                residual(table, moving, d, a, total, c, False)
                kept_resolve(table, True, na, c)
                for k in range(na):
                    d[k] += c[k]
            if upto < 6:
                continue
            qddot_of_solution(table, d, _f(table, slot.XDDOT), True, quad, moving,
                              _f(table, slot.QDDOT))
        return status

    return replica, refined


def profile(count=300, batches=5, **replay):
    """{(pair, step): CPU s per call of that step} and the whole OP_RHS's CPU s per call by
    pair (the module's docstring); `replay`: `manipulator_stage_profile.states`' arguments
    (the scene, the replay's method)."""
    from flexure.core.engine import access
    from flexure.core.engine import data as ed
    from flexure.core.engine.operations import OP_RHS
    from flexure.core.numerics.jit import kernel
    from flexure.core.numerics.native import call_engine

    @kernel
    def operation(table, ys, out, count):
        status = 0
        for k in range(count):
            y = ys[k % ys.shape[0]]
            status = call_engine(access.dims(table)[ed.ENGINE], OP_RHS, table, 0.0,
                                 y.ctypes.data, out.ctypes.data, 0, 0.0)
        return status

    _, sim, first, second, _ = states(**replay)
    table = sim.data.address
    pairs = {"the same state": np.stack([first, first]),
             "a step apart": np.stack([first, second]),
             "a correction apart": np.stack([first, first + CORRECTION * (second - first)])}
    replica, refined = _replica()
    out = np.zeros(first.size)

    def cpu(function, *args):
        function(*args, 2)
        seconds = []
        for _ in range(batches):
            start = time.process_time()
            function(*args, count)
            seconds.append((time.process_time() - start) / count)
        return statistics.median(seconds)

    prefixes, whole = {}, {}
    for pair, ys in pairs.items():
        ys = np.ascontiguousarray(ys)
        for name, function, steps in (("plain", replica, STEPS),
                                      ("refined", refined, REFINED_STEPS)):
            for upto in range(len(steps)):
                prefixes[name, pair, upto] = cpu(function, table, ys, upto)
        whole[pair] = cpu(operation, table, ys, out)
    parts = {(name, pair, steps[k]): prefixes[name, pair, k]
             - (prefixes[name, pair, k - 1] if k else 0.0)
             for name, steps in (("plain", STEPS), ("refined", REFINED_STEPS))
             for pair in pairs for k in range(len(steps))}
    return parts, whole


def main(argv):
    count = int(argv[0]) if argv else 300
    name = argv[1] if len(argv) > 1 else "manipulator_control"
    parts, whole = profile(count, name=name, **REPLAYS.get(name, {}))
    pairs = list(whole)
    print(f"{name}, one rhs (us a call; medians of 5 batches of {count})")
    print(f"| step | {' | '.join(pairs)} |")
    print("|---|" + "---|" * len(pairs))
    for path, steps in (("plain", STEPS), ("refined", REFINED_STEPS)):
        for name in steps:
            print(f"| {path}: {name} | " + " | ".join(
                f"{1e6 * parts[path, p, name]:.1f}" for p in pairs) + " |")
        print(f"| {path}: sum of the steps but conv | " + " | ".join(
            f"{1e6 * sum(parts[path, p, s] for s in steps if s != 'conv'):.1f}"
            for p in pairs) + " |")
    print("| OP_RHS | " + " | ".join(f"{1e6 * whole[p]:.1f}" for p in pairs) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
