"""The element masses of a group of BEAMs in closed form: the engine's OP_BEAM_MASSES.

`motion.inertia_forces` assembles M_ff = diag(lumped) + sum Dp^T Mp Dp element by element
with the generic `point_masses.element_mass`, which walks Dp's non-zeros with indices read
from memory (about 1.4 us a BEAM). For a group whose mass pattern is the BEAM's
(`elements.beam_mass.beam_pattern`) this operation does the same group's work with the
BEAM's closed form (`beam_element_mass`, loops of 3 and 4 that the compiler unrolls), element
by element where Dp has the BEAM's block structure (`beam_structured`; any other element of
the group keeps the generic kernel): the same products summed in another order, equal to
round-off. Gravity and, moving, -Mp (D2p xdot) xdot on the points go into r as Dp^T w.

With rigid clusters, the same operation gives a touching BEAM's mass on its z-coordinates
(`touching_beam_mass`: T_e^T Me T_e from the closed form, and the forces of the slaves' c),
for `motion.inertia_forces`, which has its points and their forces already.

An operation of its own, reached through the table of operations (`run`) and compiled only
for a model with an inertia group of BEAMs (`uses`, `engine.connect`): called directly, its
unrolled products were compiled into every model's engine, about 4 s more of the planar
demo's first loop on an empty cache (docs/benchmarks.md, session 28). Units as the
coordinates: kg, kg m, kg m^2; N, N m.
"""

import numpy as np

from ..elements.beam_mass import (
    PATTERN,
    M,
    beam_element_mass,
    beam_pattern,
    beam_structured,
)
from ..elements.beam_mass import P as BEAM_P
from ..numerics import sparse_lu
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of
from . import data as ed
from . import rigid as rg
from . import slots as slot
from .factors import add_element_mass
from .operations import BEAM_GROUP_MOVING, BEAM_TOUCHING_AT_REST, BEAM_TOUCHING_MOVING, ENTRY
from .point_masses import (
    add_point_forces,
    element_mass,
    element_points,
    point_columns,
    point_forces,
)
from .rigid_kernels import touching
from .slots import float_array as _f
from .slots import group_inertia, inertia_scratch
from .slots import int_array as _i
from .touching_beam_mass import SCRATCH, touching_beam_mass


def uses(data):
    """Whether the packed model `data` (`EngineData`) runs OP_BEAM_MASSES: without rigid
    clusters, an inertia group with the BEAM's mass pattern; with them, a touching element
    of such a group whose mass is its own (not folded into its cluster's rigid body)."""
    dims = data.int_array("dims")
    groups = data.int_array("groups").reshape(-1, ed.G_WIDTH)[: dims[ed.NGROUPS]]
    patterns = data.int_array("mass_pattern")
    beams = [g for g, row in enumerate(groups) if row[ed.G_P] > 0 and np.array_equal(
        patterns[row[ed.G_PATTERN_OFFSET]: row[ed.G_PATTERN_OFFSET] + row[ed.G_PATTERN_COUNT]],
        PATTERN)]
    if dims[ed.NSLAVES] == 0:
        return bool(beams)
    elements = data.int_array("rigid_elements").reshape(-1, rg.ELEMENT_WIDTH)
    return any(row[rg.E_GROUP] in beams and row[rg.E_MASS_OFFSET] >= 0
               and row[rg.E_FOLDED] == 0 for row in elements)


@kernel(inline="always")
def _augmented_values(table):
    """The augmented matrix's values as its carrier stores them: the sparse LU's values, or
    the dense (na, na) band (row length na; `factors`)."""
    dims = _i(table, slot.DIMS)
    na = dims[ed.NFREE] + dims[ed.NRIGID]
    if dims[ed.A_SPARSE] == 1:
        return sparse_lu.matrix_values(_i(table, slot.AUG_SPARSE),
                                       _f(table, slot.AUG_SPARSE_VALUES))
    return _f(table, slot.AUG)[: na * na]


@kernel
def group_masses(table, g, mass_entry, moving):
    """Group g's element masses onto the augmented matrix's free-coordinate block (its
    entries from `mass_entry` on in the augmented map) and its points' forces into slot
    force, in closed form; ed.NOT_AVAILABLE (nothing done) when g's mass pattern is not the
    BEAM's, else ed.OK."""
    inertia = group_inertia(table, g)
    n, m, P, _, _, coords, _, masses, gravity, pattern = inertia
    if not beam_pattern(pattern):
        return ed.NOT_AVAILABLE
    dims = _i(table, slot.DIMS)
    na = dims[ed.NFREE] + dims[ed.NRIGID]
    A = _augmented_values(table)
    x, xdot, r = _f(table, slot.X), _f(table, slot.XDOT), _f(table, slot.FORCE)
    columns = _i(table, slot.POINT_COLUMNS)
    scratch = inertia_scratch(table, 0, P, m)
    _, _, point, acc, w, Dp, o = scratch
    Me = _f(table, slot.LOCAL)[o: o + m * m]
    position = columns[P * m + P: P * m + P + m]
    for i in range(n):
        element_points(inertia, scratch, i, x, xdot, 2 if moving else 1)
        for pp in range(P):
            point[pp] = gravity[pp] - acc[pp] if moving else gravity[pp]
        Mp = masses[i * P * P: (i + 1) * P * P]
        point_columns(P, m, Dp, columns)
        point_forces(Mp, pattern, P, point, w)
        if beam_structured(Dp, columns):
            beam_element_mass(Mp, Dp, Me)
        else:
            element_mass(Mp, pattern, P, m, Dp, point, w, Me, columns)  # the same w
        add_point_forces(r, coords[i * m: (i + 1) * m], P, m, Dp, w, columns)
        add_element_mass(table, A, na, mass_entry, coords[i * m: (i + 1) * m], m, Me, position)
        mass_entry += m * m
    return ed.OK


@kernel
def touching_masses(table, t, moving):
    """Touching element t's mass on its z-coordinates onto the augmented matrix and, moving,
    the forces of the slaves' c into slot rigid_force (as `motion._touching_mass`), in the
    BEAM's closed form; ed.NOT_AVAILABLE (nothing done) unless t is a BEAM (its group's mass
    pattern the BEAM's, its Dp of the BEAM's structure), else ed.OK. Reads the element's Dp
    and its rows' non-zero columns where `motion.inertia_forces` left them (the inertia
    scratch, slot point_columns)."""
    g, i, mz, z, _, mass_offset = touching(table, t)
    inertia = group_inertia(table, g)
    n, m, P, _, _, coords, _, masses, _, pattern = inertia
    local = _f(table, slot.RIGID_LOCAL)
    if m != M or P != BEAM_P or local.size < SCRATCH or not beam_pattern(pattern):
        return ed.NOT_AVAILABLE
    Dp = inertia_scratch(table, 0, P, m)[5]
    columns = _i(table, slot.POINT_COLUMNS)
    if not beam_structured(Dp, columns):
        return ed.NOT_AVAILABLE
    c = _f(table, slot.RIGID_C)
    c_e, f_c, Me_z = local[SCRATCH - 28: SCRATCH - 14], local[SCRATCH - 14: SCRATCH], \
        local[SCRATCH - 28 - M * M: SCRATCH - 28]
    for a in range(M):
        c_e[a] = c[coords[i * m + a]] if moving else 0.0
    start = _i(table, slot.RIGID_ELEMENTS)[t * rg.ELEMENT_WIDTH + rg.E_TERM_OFFSET]
    touching_beam_mass(_i(table, slot.RIGID_TERMS), start, _f(table, slot.RIGID_WEIGHTS), mz,
                       masses[i * P * P: (i + 1) * P * P], Dp, c_e, Me_z, f_c, local)
    if moving:
        rigid_force = _f(table, slot.RIGID_FORCE)
        for a in range(mz):
            rigid_force[z[a]] -= f_c[a]
    dims = _i(table, slot.DIMS)
    entry = dims[ed.A_RIGID] + 2 * _f(table, slot.RIGID_DE).size + mass_offset
    add_element_mass(table, _augmented_values(table), dims[ed.NFREE] + dims[ed.NRIGID],
                     entry, z, mz, Me_z, columns[P * mz + P: P * mz + P + mz])
    return ed.OK


@entry(ENTRY)
def beam_masses_entry(op, user_data, t, a, b, c, s):
    """OP_BEAM_MASSES: with s = BEAM_GROUP_AT_REST or BEAM_GROUP_MOVING, a = a group's index
    and b = its first entry in the augmented map (both passed as integers in the address
    arguments), `group_masses`' status; with s = BEAM_TOUCHING_AT_REST or
    BEAM_TOUCHING_MOVING, a = a touching element's index, `touching_masses`' status."""
    table = address_of(user_data)
    if s == BEAM_TOUCHING_AT_REST or s == BEAM_TOUCHING_MOVING:
        return touching_masses(table, address_of(a), s == BEAM_TOUCHING_MOVING)
    return group_masses(table, address_of(a), address_of(b), s == BEAM_GROUP_MOVING)
