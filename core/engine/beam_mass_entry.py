"""The element masses of a group of BEAMs in closed form: the engine's OP_BEAM_MASSES.

`motion.inertia_forces` assembles M_ff = diag(lumped) + sum Dp^T Mp Dp element by element
with the generic `point_masses.element_mass`, which walks Dp's non-zeros with indices read
from memory (about 1.4 us a BEAM). For a group whose mass pattern is the BEAM's
(`elements.beam_mass.beam_pattern`) this operation does the same group's work with the
BEAM's closed form (`beam_element_mass`, loops of 3 and 4 that the compiler unrolls), element
by element where Dp has the BEAM's block structure (`beam_structured`; any other element of
the group keeps the generic kernel): the same products summed in another order, equal to
round-off. Gravity and, moving, -Mp (D2p xdot) xdot on the points go into r as Dp^T w.

An operation of its own, reached through the table of operations (`run`) and compiled only
for a model with an inertia group of BEAMs and no rigid clusters (`uses`, `engine.connect`):
called directly, its unrolled products were compiled into every model's engine, about 4 s
more of the planar demo's first loop on an empty cache (docs/benchmarks.md, session 28). A
model with rigid clusters keeps the generic path (its touching elements' masses go on their
z-coordinates, `rigid_kernels`). Units as the coordinates: kg, kg m, kg m^2; N, N m.
"""

import numpy as np

from ..elements.beam_mass import PATTERN, beam_element_mass, beam_pattern, beam_structured
from ..numerics import sparse_lu
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of
from . import data as ed
from . import slots as slot
from .factors import add_element_mass
from .operations import ENTRY
from .point_masses import (
    add_point_forces,
    element_mass,
    element_points,
    point_columns,
    point_forces,
)
from .slots import float_array as _f
from .slots import group_inertia, inertia_scratch
from .slots import int_array as _i


def uses(data):
    """Whether the packed model `data` (`EngineData`) runs OP_BEAM_MASSES: an inertia group
    with the BEAM's mass pattern, and no rigid clusters."""
    dims = data.int_array("dims")
    if dims[ed.NSLAVES] > 0:
        return False
    groups = data.int_array("groups").reshape(-1, ed.G_WIDTH)[: dims[ed.NGROUPS]]
    patterns = data.int_array("mass_pattern")
    for row in groups:
        start, count = row[ed.G_PATTERN_OFFSET], row[ed.G_PATTERN_COUNT]
        if row[ed.G_P] > 0 and np.array_equal(patterns[start: start + count], PATTERN):
            return True
    return False


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
    if dims[ed.A_SPARSE] == 1:
        A = sparse_lu.matrix_values(_i(table, slot.AUG_SPARSE), _f(table, slot.AUG_SPARSE_VALUES))
    else:
        A = _f(table, slot.AUG)  # the band storage (`banded.layout`)
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


@entry(ENTRY)
def beam_masses_entry(op, user_data, t, a, b, c, s):
    """OP_BEAM_MASSES: a = the group's index, b = its first entry in the augmented map (both
    passed as integers in the address arguments), s = 1 moving; `group_masses`' status."""
    return group_masses(address_of(user_data), address_of(a), address_of(b), s == 1.0)
