"""The rates of the elements that form their quadratic forms h = xdot^T D2e xdot themselves
(the BEAM: `elements.entries.ORDER_DIRECTIONAL`), and their Hessians when a tangent asks:
the engine's OP_FORMED_RATES.

`deformation_rates.element_rates` contracts each element's D2e with xdot for h. An element
with a directional kernel gives h from x and xdot directly, for about a tenth of its Hessians'
cost, so the kinematic solution leaves such an element's D2e out (`kinematics.AT_SOLUTION`)
and this operation gives its group's rates (s = RATES: a = the group's index, b = xdot's
address); the readers of D2e, the tangent and the ESDIRK's Newton matrix, ask it for the
Hessians at the solution first (s = HESSIANS, `kinematics.hessians_at_solution`).

An operation of its own, reached through the table of operations and compiled only for a
model with such an element (`uses`, `engine.connect`): linked into `element_rates`, the
tangent and the Newton matrix, it was compiled into every model's engine, 1 to 3 s more of
the planar demo's first loop on an empty cache (docs/benchmarks.md, session 32). Units: edot
1/s or m/s by the deformation, h 1/s^2 or m/s^2.
"""

from ..elements.beam_directional import POINTS_WIDTH, kept_points_kernel, points_kernel
from ..elements.entries import ORDER_DIRECTIONAL
from ..numerics.jit import entry, kernel
from ..numerics.native import address_of, as_float_pointer, call_deformations, carray
from . import data as ed
from . import slots as slot
from .deformation_rates import internal
from .kinematics import hessians_at_solution
from .operations import ENTRY, HESSIANS
from .rigid_inertia_kernels import visits_element
from .slots import float_array as _f
from .slots import group, group_deformations
from .slots import int_array as _i


def uses(data):
    """Whether the packed model `data` (`EngineData`) runs OP_FORMED_RATES: an element group
    with deformations whose element has a directional kernel."""
    return any(getattr(g.kind, "directional_kernel", None) is not None
               and g.deformation_index.shape[1] > 0 for g in data.model.groups)


@kernel
def formed_rates(table, g, xdot):
    """`element_rates` of group g, whose element forms h = v^T D2e v itself: edot = De xdot
    and its directional kernel's h at the solution (slot x) on the constraint rows, for the
    elements with any (slot g). A BEAM group with kept points (group field points_offset)
    gives each element that the element passes visit (`rigid_inertia_kernels.
    visits_element`) its inertia points in the same call, into slot beam_points
    (`beam_directional.points_kernel`), from the
    rotations that the kinematics kept there where it did (dims rotations_kept: the
    elements a cluster does not make internal, `beam_directional.kept_points_kernel`)."""
    dims = _i(table, slot.DIMS)
    edot, quad = _f(table, slot.EDOT), _f(table, slot.G)
    row_of_def = _i(table, slot.ROW_OF_DEF)
    x, local = _f(table, slot.X), _f(table, slot.LOCAL)
    max_m = dims[ed.MAX_M]
    v = local[:max_m]  # the element's xdot
    xl = local[max_m: 2 * max_m]  # its x
    formed = local[2 * max_m: 2 * max_m + dims[ed.MAX_K]]  # its h
    skipping = dims[ed.NSLAVES] > 0
    touching = _i(table, slot.RIGID_ELEMENTS)
    row = group(table, g)
    n, m, k, coords, defs, De, _ = group_deformations(table, g)
    function, width = row[ed.G_DEFORMATIONS_ENTRY], row[ed.G_REF_WIDTH]
    refs = _f(table, slot.GROUP_DATA).ctypes.data + 8 * row[ed.G_DATA_OFFSET]
    keeping = row[ed.G_POINTS_OFFSET] >= 0
    rotations = dims[ed.ROTATIONS_KEPT] == 1  # the kinematics' (`kinematics.deformations`)
    beam_refs = _f(table, slot.GROUP_DATA)[row[ed.G_DATA_OFFSET]:]
    points = _f(table, slot.BEAM_POINTS)[max(row[ed.G_POINTS_OFFSET], 0):]
    for i in range(n):
        inner = skipping and internal(table, row, i, touching)
        keep = keeping and visits_element(table, row, i, skipping)
        if inner and not keep:
            for b in range(k):
                edot[defs[i * k + b]] = 0.0
            continue
        for a in range(m):
            v[a] = xdot[coords[i * m + a]]
        if keep:  # h and the points in one call; m = 14, k = 6 (the BEAM's)
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
            ref, kept = beam_refs[i * width: (i + 1) * width], points[i * POINTS_WIDTH:]
            if rotations and not inner:  # from the rotations the kinematics kept there
                kept_points_kernel(xl, v, ref, formed, kept[:POINTS_WIDTH])
            else:
                points_kernel(xl, v, ref, formed, kept[:POINTS_WIDTH])
        elif has_rows(row_of_def, defs, i, k):
            for a in range(m):
                xl[a] = x[coords[i * m + a]]
            call_deformations(function, xl.ctypes.data, refs + 8 * i * width,
                              ORDER_DIRECTIONAL, formed.ctypes.data, v.ctypes.data, 0, m, k,
                              width)
        if inner:
            for b in range(k):
                edot[defs[i * k + b]] = 0.0
            continue
        for b in range(k):
            s = 0.0
            base = (i * k + b) * m
            for a in range(m):
                s += De[base + a] * v[a]
            edot[defs[i * k + b]] = s
            r = row_of_def[defs[i * k + b]]
            if r >= 0:
                quad[r] = formed[b]


@kernel(inline="always")
def has_rows(row_of_def, defs, i, k):
    """Whether any of element i's k deformations is a row of J (`row_of_def` >= 0)."""
    for b in range(k):
        if row_of_def[defs[i * k + b]] >= 0:
            return True
    return False


@entry(ENTRY)
def formed_rates_entry(op, user_data, t, a, b, c, s):
    """OP_FORMED_RATES: s = operations.RATES, a = the group's index (as an integer), b = xdot (NX,);
    s = operations.HESSIANS, the Hessians at the last kinematic solution. Status ed.OK."""
    table = address_of(user_data)
    if s == HESSIANS:
        hessians_at_solution(table)
        return ed.OK
    xdot = carray(as_float_pointer(address_of(b)), (_i(table, slot.DIMS)[ed.NX],))
    formed_rates(table, address_of(a), xdot)
    return ed.OK
