"""Where one right-hand side of the spatial cantilever goes: the engine's own kernels called
in numba loops at a state of a run (CPU per call, medians of batches).

The cantilever is `spatial.spatial_cantilever(n)` (every deformation a DOF), run with esdirk
at rtol 1e-6 to `at` (2 ms into the 5 ms run by default); the parts are timed at the state
the run stops in, after one evaluation there (so the slots hold its x, xdot, De and D2e).
The whole rhs is timed two ways: at that one state (the kinematics' warm start lands, no
chord step) and alternating it with the state one step later (the chord steps a run sees).
Each part is a kernel of `core/engine` called `count` times in a compiled loop; the loop's
own overhead is a few ns a call. Parts that leave their result in the slots (a
factorisation) are timed with what must precede them, and the difference is reported. The
last row is what a residual in mass form takes instead of the inertia and the rigid rows
into A: `inertia_product.force_minus_mass` (rhs_f - M_ff w_f, no mass assembled).

python -m examples.benchmarks.cantilever_rhs_profile 16 64
"""

import sys

import numpy as np

from .measure import cpu_per_call as _time

CANTILEVER_AT = 2e-3  # s: the state's time in the 5 ms run after the tip load


def _loops():
    """The compiled loops (numba), built on first use."""
    from flexure.core.engine import data as ed
    from flexure.core.engine import slots as slot
    from flexure.core.engine.deformation_rates import (
        element_rates,
        scatter_stress,
        stress_resultants,
    )
    from flexure.core.engine.factors import (
        add_rigid_rows,
        augmented_matrix,
        augmented_resolve,
        j_factor,
        j_solve,
    )
    from flexure.core.engine.inertia_product import force_minus_mass
    from flexure.core.engine.kinematics import deformations
    from flexure.core.engine.motion import inertia_forces, qddot_of_solution
    from flexure.core.engine.operations import OP_CONFIGURATION, OP_RHS, run
    from flexure.core.engine.slots import float_array as _f
    from flexure.core.engine.slots import int_array as _i
    from flexure.core.numerics import banded
    from flexure.core.numerics.jit import kernel

    @kernel
    def rhs(table, ys, ydot, count):
        for k in range(count):
            y = ys[k % ys.shape[0]]
            run(table, OP_RHS, y.ctypes.data, ydot.ctypes.data, 0.0)

    @kernel
    def configuration(table, qs, count):
        for k in range(count):
            run(table, OP_CONFIGURATION, qs[k % qs.shape[0]].ctypes.data, 0, 0.0)

    @kernel
    def elements(table, order, count):
        x = _f(table, slot.X)
        for _ in range(count):
            deformations(table, x, order, True)

    @kernel
    def factor_j(table, count):
        for _ in range(count):
            j_factor(table)

    @kernel
    def solve_j(table, count):
        dx = _f(table, slot.DX)
        for _ in range(count):
            dx[:] = 1e-3
            j_solve(table, dx, False)

    @kernel
    def rates(table, count):
        xdot = _f(table, slot.XDOT)
        for _ in range(count):
            element_rates(table, xdot, True)

    @kernel
    def stresses(table, count):
        r = _f(table, slot.X_TRIAL)
        for _ in range(count):
            sigma = stress_resultants(table)
            r[:] = 0.0
            scatter_stress(table, sigma, r)

    @kernel
    def assembly(table, factor, count):
        dims = _i(table, slot.DIMS)
        na = dims[ed.NFREE] + dims[ed.NRIGID]
        x, xdot = _f(table, slot.X), _f(table, slot.XDOT)
        r = _f(table, slot.X_TRIAL)
        for _ in range(count):
            A = augmented_matrix(table)
            inertia_forces(table, x, xdot, True, r, A, na)
            add_rigid_rows(table, A, na)
            if factor:
                banded.factor(A, na, _i(table, slot.AUG_PIVOTS), dims[ed.A_KL], dims[ed.A_KU])
        dims[ed.A_FACTORS] = ed.BANDED_FACTORS

    @kernel
    def clear(table, count):
        for _ in range(count):
            augmented_matrix(table)

    @kernel
    def resolve(table, count):
        dims = _i(table, slot.DIMS)
        na = dims[ed.NFREE] + dims[ed.NRIGID]
        rhs_ = _f(table, slot.AUG_RHS)
        for _ in range(count):
            rhs_[:na] = 1e-3
            augmented_resolve(table, na, rhs_)

    @kernel
    def solution(table, count):
        dims = _i(table, slot.DIMS)
        rhs_ = _f(table, slot.AUG_RHS)
        for _ in range(count):
            qddot_of_solution(table, rhs_, _f(table, slot.X_TRIAL), True, _f(table, slot.G),
                              True, _f(table, slot.QDDOT))
        return dims[0]

    @kernel
    def product(table, r, w_f, a, total, out_f, count):
        x, xdot = _f(table, slot.X), _f(table, slot.XDOT)
        for _ in range(count):
            force_minus_mass(table, x, xdot, True, r, w_f, a, total, out_f)

    return dict(rhs=rhs, configuration=configuration, elements=elements, factor_j=factor_j,
                solve_j=solve_j, rates=rates, stresses=stresses, assembly=assembly, clear=clear,
                resolve=resolve, solution=solution, product=product)


def profile(n, *, at=CANTILEVER_AT, count=300):
    """{part: CPU s per call} of one rhs of the n-BEAM cantilever at the state `at` s into
    its run, and the sizes {name: value} of its factorisations."""
    from flexure.core import Simulator
    from flexure.core.engine import data as ed
    from flexure.core.engine import engine

    from .spatial import spatial_cantilever

    model = spatial_cantilever(n)
    sim = Simulator(model, method="esdirk", rtol=1e-6)
    sim.advance_to(at)
    first = np.array(sim.state, dtype=float)
    steps = sim.statistics["steps"]
    sim.advance_to(at + 1e-6)
    while sim.statistics["steps"] == steps:  # the state one step later
        sim.advance_to(sim.time + 1e-6)
    second = np.array(sim.state, dtype=float)
    data = sim.data
    engine.connect(data, engine.OP_RHS, engine.OP_CONFIGURATION)
    table = data.address
    dims = data.int_array("dims")
    ndof = dims[ed.NDOF]
    q_ref = data.float_array("q_ref")
    ydot = np.empty_like(first)
    loops = _loops()
    parts = {}
    ys = np.ascontiguousarray(np.stack([first, second]))
    parts["rhs, alternating two states a step apart"] = _time(loops["rhs"], (table, ys, ydot),
                                                              count)
    qs = np.ascontiguousarray(q_ref + ys[:, :ndof])
    parts["kinematics, alternating"] = _time(loops["configuration"], (table, qs), count)
    one = np.ascontiguousarray(first[None, :])
    parts["rhs at one state"] = _time(loops["rhs"], (table, one, ydot), count)
    parts["kinematics at one state"] = _time(loops["configuration"], (table, qs[:1]), count)
    loops["rhs"](table, one, ydot, 1)
    for order in (0, 1, 2):
        parts[f"deformations, order {order}"] = _time(loops["elements"], (table, order), count)
    parts["J's factorisation"] = _time(loops["factor_j"], (table,), count)
    parts["a solve with J"] = _time(loops["solve_j"], (table,), count)
    loops["rhs"](table, one, ydot, 1)
    parts["element rates (edot, h)"] = _time(loops["rates"], (table,), count)
    parts["stresses and De^T sigma"] = _time(loops["stresses"], (table,), count)
    parts["clearing A's band"] = _time(loops["clear"], (table,), count)
    assembled = _time(loops["assembly"], (table, False), count)
    parts["inertia and the rigid rows into A"] = assembled - parts["clearing A's band"]
    if not dims[ed.A_SPARSE]:  # the sparse LU factors inside `augmented_solve` alone
        parts["A's banded factorisation"] = (_time(loops["assembly"], (table, True), count)
                                             - assembled)
    parts["a solve with A"] = _time(loops["resolve"], (table,), count)
    loops["rhs"](table, one, ydot, 1)
    parts["qddot from the solution"] = _time(loops["solution"], (table,), count)
    nx, nf = int(dims[ed.NX]), int(dims[ed.NFREE])
    w_f = data.float_array("augmented_rhs")[:nf].copy()  # any accelerations: the same cost
    parts["force_minus_mass (inertia_product)"] = _time(
        loops["product"], (table, data.float_array("force").copy(), w_f, np.zeros(nx),
                           np.zeros(nx), np.zeros(nf)), count)
    sizes = {"n_free": int(dims[ed.NFREE]), "n_rigid": int(dims[ed.NRIGID]),
             "J kl, ku": (int(dims[ed.J_KL]), int(dims[ed.J_KU])),
             "A kl, ku": (int(dims[ed.A_KL]), int(dims[ed.A_KU])),
             "J sparse, A sparse": (int(dims[ed.J_SPARSE]), int(dims[ed.A_SPARSE]))}
    return parts, sizes


def main(argv):
    for n in [int(a) for a in argv] or [16, 64]:
        parts, sizes = profile(n)
        print(f"cantilever of {n} BEAMs ({6 * n} DOFs): {sizes}")
        for name, seconds in parts.items():
            print(f"  {name:40s} {1e6 * seconds:9.2f} us")


if __name__ == "__main__":
    main(sys.argv[1:])
