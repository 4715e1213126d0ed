"""Where the inertia of one `manipulator_control` rhs goes: the engine's own kernels called in
numba loops at a state of a run (CPU per call, medians of batches).

The state is the one 10 ms into a run with every input at 1 (as `refined.rhs_cost`); the
parts are timed after one evaluation there (the slots hold its x, xdot, c and T's weights).
Each part is a loop over what `motion.inertia_forces` visits, cut after a stage, so a
stage's cost is the difference of two loops: for the touching elements with a mass of their
own (the BEAMs joining the rigid clusters), their inertia points (Dp and (D2p v) v), their
point forces onto r, their mass on the z-coordinates with the slaves' c forces and its
assembly into the augmented matrix (`motion.touching_element_mass`, and beside it, to compare
another form of that product with, the generic `rigid_kernels.touching_mass` alone:
docs/benchmarks.md, session 32); for every other massive element its element mass and
assembly; the lumped masses; the folded clusters' rigid bodies. The whole of
`inertia_forces` is timed as well, A cleared before each call (`augmented_matrix`, timed
alone and subtracted); the parts' loops clear it once. Last, what a residual in mass form
takes instead: `inertia_product.force_minus_mass` (rhs_f - M_ff w_f, no mass assembled)
against what it replaces, `inertia_forces` with the rigid rows into A and rhs_f condensed
(T^T (r - M c)), A's clearing included in both rows of that pair.

python -m examples.benchmarks.manipulator_inertia_profile
"""

import sys

import numpy as np

from .measure import cpu_per_call


def _loops():
    """The compiled loops (numba), built on first use."""
    from flexure.core.engine import data as ed
    from flexure.core.engine import slots as slot
    from flexure.core.engine.factors import (
        add_element_mass,
        add_lumped,
        add_rigid_rows,
        augmented_matrix,
        mass_entries_start,
    )
    from flexure.core.engine.inertia_product import force_minus_mass
    from flexure.core.engine.motion import inertia_forces, touching_element_mass
    from flexure.core.engine.operations import OP_RIGID_BODIES, OP_RIGID_CONDENSE, run
    from flexure.core.engine.point_masses import (
        add_point_forces,
        element_mass,
        element_points,
        point_columns,
        point_forces,
    )
    from flexure.core.engine.rigid_inertia_kernels import BODIES_MOVING, own_mass
    from flexure.core.engine.rigid_kernels import touching, touching_mass
    from flexure.core.engine.slots import float_array as _f
    from flexure.core.engine.slots import group, group_inertia, inertia_scratch, rigid_element
    from flexure.core.engine.slots import int_array as _i
    from flexure.core.numerics.jit import kernel
    from flexure.core.numerics.native import call_engine

    @kernel
    def generic(table, t, coords, Mp, pattern, P, m, Dp, A, na):
        """`motion.touching_element_mass` by the generic product, moving."""
        dims = _i(table, slot.DIMS)
        columns = _i(table, slot.POINT_COLUMNS)
        g, i, mz, z, _, mass_offset = touching(table, t)
        Me, force = touching_mass(table, t, Mp, pattern, P, m, Dp, columns, coords, True)
        rigid_force = _f(table, slot.RIGID_FORCE)
        for a in range(mz):
            rigid_force[z[a]] -= force[a]
        entry = dims[ed.A_RIGID] + 2 * _f(table, slot.RIGID_DE).size + mass_offset
        add_element_mass(table, A, na, entry, z, mz, Me, columns[P * mz + P: P * mz + P + mz])

    @kernel
    def clear(table, count):
        for _ in range(count):
            augmented_matrix(table)

    @kernel
    def whole(table, count):
        dims = _i(table, slot.DIMS)
        na = dims[ed.NFREE] + dims[ed.NRIGID]
        x, xdot, r = _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.X_TRIAL)
        for _ in range(count):
            A = augmented_matrix(table)
            inertia_forces(table, x, xdot, True, r, A, na)

    @kernel
    def elements(table, touching, stage, count):
        """The element loop of `inertia_forces` over the touching elements (touching) or the
        others, up to `stage`: 1 the points, 2 their forces, 3 the mass, 4 its assembly."""
        dims = _i(table, slot.DIMS)
        na = dims[ed.NFREE] + dims[ed.NRIGID]
        x, xdot, r = _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.X_TRIAL)
        local, columns = _f(table, slot.LOCAL), _i(table, slot.POINT_COLUMNS)
        A = augmented_matrix(table)
        for _ in range(count):
            mass_entry = mass_entries_start(table)
            for g in range(dims[ed.NGROUPS]):
                row = group(table, g)
                inertia = group_inertia(table, g)
                n, m, P, _, _, coords, _, masses, gravity, pattern = inertia
                scratch = inertia_scratch(table, 0, P, m)
                _, _, point, acc, w, Dp, o = scratch
                Me = local[o: o + m * m]
                for i in range(n):
                    t = rigid_element(table, row, i)
                    if (t >= 0) != touching or (t >= 0 and not own_mass(table, t)):
                        mass_entry += m * m
                        continue
                    element_points(inertia, scratch, i, x, xdot, 2)
                    for pp in range(P):
                        point[pp] = gravity[pp] - acc[pp]
                    Mp = masses[i * P * P: (i + 1) * P * P]
                    if stage >= 2:
                        if touching or stage == 2:
                            point_columns(P, m, Dp, columns)
                            point_forces(Mp, pattern, P, point, w)
                        else:
                            element_mass(Mp, pattern, P, m, Dp, point, w, Me, columns)
                        add_point_forces(r, coords[i * m: (i + 1) * m], P, m, Dp, w, columns)
                    # stage 3: as `inertia_forces`, 5: the generic product alone
                    if stage == 3 and touching:
                        touching_element_mass(table, t, coords[i * m: (i + 1) * m], Mp, pattern, P,
                                       m, Dp, True, A, na)
                    if stage == 5:
                        generic(table, t, coords[i * m: (i + 1) * m], Mp, pattern, P, m, Dp, A,
                                na)
                    if stage == 4 and not touching:
                        position = columns[P * m + P: P * m + P + m]
                        add_element_mass(table, A, na, mass_entry, coords[i * m: (i + 1) * m],
                                         m, Me, position)
                    mass_entry += m * m

    @kernel
    def lumped(table, count):
        dims = _i(table, slot.DIMS)
        na = dims[ed.NFREE] + dims[ed.NRIGID]
        A = augmented_matrix(table)
        for _ in range(count):
            add_lumped(table, A, na)

    @kernel
    def bodies(table, count):
        dims = _i(table, slot.DIMS)
        A = augmented_matrix(table)
        for _ in range(count):
            call_engine(dims[ed.ENGINE], OP_RIGID_BODIES, table, float(A.size), A.ctypes.data,
                        0, 0, BODIES_MOVING)

    @kernel
    def replaced(table, total, count):
        """What `force_minus_mass` replaces in `motion.evaluate`: A cleared, the inertia and
        the rigid rows into it, rhs_f condensed (total (NX,) scratch)."""
        dims = _i(table, slot.DIMS)
        nf = dims[ed.NFREE]
        na = nf + dims[ed.NRIGID]
        x, xdot, r = _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.X_TRIAL)
        rhs = _f(table, slot.AUG_RHS)
        rigid_force = _f(table, slot.RIGID_FORCE)
        for _ in range(count):
            A = augmented_matrix(table)
            inertia_forces(table, x, xdot, True, r, A, na)
            add_rigid_rows(table, A, na)
            for a in range(dims[ed.NX]):
                total[a] = r[a] + rigid_force[a]
            run(table, OP_RIGID_CONDENSE, total.ctypes.data, rhs.ctypes.data, 0.0)

    @kernel
    def product(table, r, w_f, a, total, out_f, count):
        """`force_minus_mass` moving, at the slots' x and xdot."""
        x, xdot = _f(table, slot.X), _f(table, slot.XDOT)
        for _ in range(count):
            force_minus_mass(table, x, xdot, True, r, w_f, a, total, out_f)

    return dict(clear=clear, whole=whole, elements=elements, lumped=lumped, bodies=bodies,
                replaced=replaced, product=product)


def _time(function, args, count):
    """`measure.cpu_per_call` over 7 batches: the inertia's parts are differences of loops."""
    return cpu_per_call(function, args, count, batches=7)


def state(model, at=0.01):
    """(simulator, y) at `at` s into a run of `model` with every input at 1."""
    from flexure.core import Simulator

    sim = Simulator(model, rtol=1e-6)
    sim.set_inputs(np.ones(len(model.inputs)))
    sim.advance_to(at)
    y = np.ascontiguousarray(sim.state, dtype=float)
    sim.derivative(0.0, y)  # the engine's inputs, and one evaluation at y
    return sim, y


def profile(name="manipulator_control", *, count=300):
    """{part: CPU s per call} of the inertia of one rhs of the scene `name`."""
    from flexure.core import load_scene
    from flexure.core.engine import data as ed
    from flexure.core.engine import engine

    sim, y = state(load_scene(name))
    data = sim.data
    ydot = np.empty_like(y)
    assert engine.call(data, engine.OP_RHS, y, ydot) == ed.OK
    table = data.address
    loops = _loops()
    parts = {}
    clear = _time(loops["clear"], (table,), count)
    parts["A cleared (augmented_matrix)"] = clear
    parts["inertia_forces, all of it"] = _time(loops["whole"], (table,), count) - clear
    stages = [_time(loops["elements"], (table, True, s), count) for s in (1, 2, 3)]
    parts["touching: inertia points (Dp, acc)"] = stages[0]
    parts["touching: point forces onto r"] = stages[1] - stages[0]
    parts["touching: mass on z with c forces, into A"] = stages[2] - stages[1]
    parts["- of it the generic path (touching_mass)"] = (
        _time(loops["elements"], (table, True, 5), count) - stages[1])
    stages = [_time(loops["elements"], (table, False, s), count) for s in (1, 3, 4)]
    parts["others: inertia points (Dp, acc)"] = stages[0]
    parts["others: element mass and forces"] = stages[1] - stages[0]
    parts["others: assembly into A"] = stages[2] - stages[1]
    parts["lumped masses"] = _time(loops["lumped"], (table,), count)
    parts["folded clusters' rigid bodies"] = _time(loops["bodies"], (table,), count)
    dims = data.int_array("dims")
    nx, nf = int(dims[ed.NX]), int(dims[ed.NFREE])
    parts["inertia, rigid rows into A, rhs_f (replaced)"] = _time(
        loops["replaced"], (table, np.zeros(nx)), count)
    w_f = data.float_array("augmented_rhs")[:nf].copy()  # any accelerations: the cost is
    # the same; these are the last evaluation's
    scratch = (np.zeros(nx), np.zeros(nx), np.zeros(nf))
    parts["force_minus_mass (inertia_product)"] = _time(
        loops["product"], (table, data.float_array("force").copy(), w_f) + scratch, count)
    return parts


def main(argv):
    for name in argv or ["manipulator_control"]:
        parts = profile(name)
        print(f"{name}: the inertia of one rhs (us per call)")
        for part, seconds in parts.items():
            print(f"  {part:45s} {1e6 * seconds:9.2f}")


if __name__ == "__main__":
    main(sys.argv[1:])
