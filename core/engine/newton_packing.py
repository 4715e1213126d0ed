"""Which models take the sparse Newton matrix of the ESDIRK, and its packed patterns and maps.

The compiled side (`newton`) solves (I - hg J) [dq; dv] = [r1; r2] on the free coordinates
through the saddle-point system [H J_o^T; J_o 0], H = M + hg C_x + hg^2 K_x, and J's own
sparse LU at the Newton matrix's state (docs/analyses.md, "The Newton matrix"). A model takes
that path (`NewtonPacking.analyse`) when all of these hold:

- at least SPARSE_NEWTON_FROM DOFs (below it the dense Newton matrix of
  `simulation.newton_matrix` costs under a millisecond and the small models keep their
  numbers);
- the accelerations come from the augmented form (`orders.FactorPlan.augmented`);
- no coil currents, no kinematic inputs (their first-order Jacobians have blocks this path
  does not form: they keep the dense one);
- with rigid clusters: the augmented system factored sparse (H's mass block is then
  assembled by the evaluation's own functions, `newton_rigid`), no moment input on a
  slave, and each touching element's z-pairs and each master's rotation pairs in H's
  pattern;
- S and D couple the deformations of one element only, and every pair of the free
  coordinates of one element (and of a moment input's Euler parameters) is an entry of the
  augmented system's pattern (true where every element has mass: a massless element's
  stiffness would couple coordinates that M does not);
- J and the augmented system have static pivots at the initial configuration
  (`sparse_packing.SparseFactors`), and the element-local buffers fit in slot local.

The sparse patterns are those of `sparse_packing.SparseFactors` (the plan's when it analysed
them, else analysed here), whether the evaluation factors banded or sparse: the Newton
matrix has its own copies of both LUs. `SPARSE_NEWTON_FROM` is read at packing, so a test
may lower it before it packs a model.
"""

import numpy as np

from ..mechanics.rigid_bodies import PLANAR_TRANSLATION, SPATIAL_TRANSLATION
from . import sparse_packing
from .rigid import E_INTERNAL

SPARSE_NEWTON_FROM = 50  # DOFs (the dense path's Schur complement starts there too)
EULER_PAIRS = 16  # a moment input's Euler parameters, 4 x 4


class NewtonPacking:
    """The sparse Newton matrix's LUs and maps for one model (the `newton` slots).

    Attributes
    ----------
    j_ints, j_floats, h_ints, h_floats : ndarray
        The packed sparse LUs of J and of the augmented system (`numerics.sparse_lu`), copies.
    j_map : ndarray of int (de_size + nxdof,)
        De entry, then DOF coordinate j -> slot of J's values.
    h_map : ndarray of int
        [free coordinate -> its diagonal slot (n_free), De entry -> slot of (rigid row,
        coordinate) (de_size), De entry -> slot of (coordinate, rigid row) (de_size), per
        element group in the engine's order, per element, pair (a, b) of its m coordinates ->
        slot (n m m)], -1 where a coordinate is fixed (and for a touching element); with
        rigid clusters then their parts (`_rigid_pairs`).
    stress_row : ndarray of int (ne,)
    port_map : ndarray of int (n_inputs EULER_PAIRS,)
    """

    def __init__(self, factors, h_map, stress_row, port_map):
        self.j_ints, self.j_floats = (factors.constraints.ints.copy(),
                                      factors.constraints.floats.copy())
        self.h_ints, self.h_floats = (factors.augmented.ints.copy(),
                                      factors.augmented.floats.copy())
        self.j_map = factors.constraint_map.copy()
        self.h_map, self.stress_row, self.port_map = h_map, stress_row, port_map
        self.nnz = int(factors.augmented.ints[1])  # sparse_lu's H_NNZ_A

    @classmethod
    def analyse(cls, c):
        """The `NewtonPacking` of packing context c (`packing.Context`), or None when the
        model keeps the dense Newton matrix (the module's rule)."""
        model, n, topology, plan = c.model, c.counts, c.topology, c.plan
        rigid = c.rigid.active
        if (n["ndof"] < SPARSE_NEWTON_FROM or not plan.augmented or n["nel"] or n["nki"]
                or not _element_local(c) or _scratch_needed(n) > n["scratch"]):
            return None
        if rigid and (plan.factors is None or not plan.a_sparse
                      or _moment_on_slaves(model.inputs, c.rigid.slave_index)):
            return None
        factors = plan.factors
        if factors is None:
            try:
                factors = sparse_packing.SparseFactors(
                    model, c.groups.de_groups,
                    [g for g in c.groups.all if id(g) in c.groups.inertia], topology.free,
                    topology.rows, topology.row_of_def, topology.col_of_coord,
                    c.groups.de_size, None)
            except ValueError:  # singular at the initial configuration: no static pivots
                return None
        nf, de_size = topology.free.size, c.groups.de_size
        slot = factors.augmented.slot
        col = topology.col_of_coord
        pairs = []
        try:
            for gp, group in enumerate(c.groups.all):
                cols = col[group.coordinate_index].copy()  # (n, m)
                if rigid:  # a touching element's entries are on its z-coordinates (below)
                    of = c.rigid.element_of[c.rigid.element_offsets[gp]:][:cols.shape[0]]
                    cols[of >= 0] = -1
                rows_, columns = (np.broadcast_to(cols[:, :, None], cols.shape + cols.shape[1:]),
                                  np.broadcast_to(cols[:, None, :], cols.shape + cols.shape[1:]))
                place = np.full(rows_.shape, -1, dtype=np.int64)
                inside = (rows_ >= 0) & (columns >= 0)
                place[inside] = slot(rows_[inside], columns[inside])
                pairs.append(place.ravel())
            port_map = _port_map(model.inputs, col, slot)
            if rigid:
                pairs += _rigid_pairs(c.rigid, col, slot)
        except ValueError:  # an element pair outside the pattern: a massless element
            return None
        amap = factors.augmented_map
        h_map = np.concatenate([amap[: nf + 2 * de_size], *pairs]).astype(np.int64)
        stress_row = np.full(len(model.deformation_names), -1, dtype=np.int64)
        stress_row[c.stressed] = np.arange(c.stressed.size)
        return cls(factors, h_map, stress_row, port_map)


def _element_local(c):
    """Whether S and D couple deformations of one element only."""
    owner = np.full(len(c.model.deformation_names), -1, dtype=np.int64)
    element = 0
    for group in c.groups.all:
        defs = group.deformation_index
        for i in range(defs.shape[0]):
            owner[defs[i]] = element
            element += 1
    rows, columns = np.nonzero((c.S != 0.0) | (c.D != 0.0))
    first, second = owner[c.stressed[rows]], owner[c.stressed[columns]]
    return bool(np.all((first == second) & (first >= 0)))


def _scratch_needed(n):
    """Slot local's entries the Newton Jacobian's element loop uses: the inertia buffers
    (`slots.inertia_scratch`), Me, K_e, C_e (m m each) and two rows (m each)."""
    m, p = n["max_m"], n["max_p"]
    return 2 * m + 3 * p + p * m + 3 * m * m + 2 * m


def _moment_on_slaves(inputs, slave_index):
    """Whether a moment input acts on a slave's Euler parameters (its load stiffness would
    need T: such a model keeps the dense Newton matrix)."""
    return any(port.about_axis and np.any(slave_index[np.asarray(port.euler)] >= 0)
               for port in inputs)


def _rigid_pairs(rigid, col, slot):
    """The rigid clusters' parts of h_map (`newton_rigid`): per touching element t the
    offset of its z-pairs (n_touching + 1, the last the total), its z-pairs (mz mz; -1 for
    an element inside a cluster, whose K_e and C_e vanish), then per slave node the 16
    pairs of its master's rotation coordinates (4 x 4; a planar one's one pair first).
    Raises ValueError where a pair is outside H's pattern."""
    offsets, places = [0], []
    for gp, i, z in rigid.touching:
        zc = col[z]
        place = np.full((z.size, z.size), -1, dtype=np.int64)
        if not rigid.element_row(gp, i)[E_INTERNAL]:
            inside = (zc[:, None] >= 0) & (zc[None, :] >= 0)
            rows_, columns = np.broadcast_to(zc[:, None], place.shape), \
                np.broadcast_to(zc[None, :], place.shape)
            place[inside] = slot(rows_[inside], columns[inside])
        places.append(place.ravel())
        offsets.append(offsets[-1] + place.size)
    masters = np.full((rigid.slaves.shape[0], EULER_PAIRS), -1, dtype=np.int64)
    for j, row in enumerate(rigid.slaves):
        if row[0] not in (SPATIAL_TRANSLATION, PLANAR_TRANSLATION):
            continue
        mr = col[row[8:12][row[8:12] >= 0]]  # a fixed master coordinate: -1, no entry
        size = mr.size
        for a in range(size):
            for b in range(size):
                if mr[a] >= 0 and mr[b] >= 0:
                    masters[j, a * size + b] = slot([mr[a]], [mr[b]])[0]
    return [np.array(offsets, dtype=np.int64), *places, masters.ravel()]


def _port_map(inputs, col, slot):
    """Per input the slots of its Euler parameters' pairs (a moment input), else -1."""
    out = np.full(len(inputs) * EULER_PAIRS, -1, dtype=np.int64)
    for j, port in enumerate(inputs):
        if not port.about_axis:
            continue
        cols = col[np.asarray(port.euler)]
        for a in range(4):
            for b in range(4):
                if cols[a] >= 0 and cols[b] >= 0:
                    out[j * EULER_PAIRS + 4 * a + b] = slot([cols[a]], [cols[b]])[0]
    return out


def pack(c):
    """The `newton` slots of packing context c (empty on the dense path)."""
    p, nothing = c.newton, np.zeros(0, dtype=np.int64)
    if p is None:
        return {"newton_j": nothing, "newton_j_map": nothing, "newton_h": nothing,
                "newton_h_map": nothing, "newton_stress_row": nothing,
                "newton_port_map": nothing, "newton_j_values": np.zeros(0),
                "newton_h_values": np.zeros(0), "newton_parts": np.zeros(0),
                "newton_scratch": np.zeros(0)}
    return {"newton_j": p.j_ints.copy(), "newton_j_map": p.j_map,
            "newton_h": p.h_ints.copy(), "newton_h_map": p.h_map,
            "newton_stress_row": p.stress_row, "newton_port_map": p.port_map,
            "newton_j_values": p.j_floats.copy(), "newton_h_values": p.h_floats.copy(),
            "newton_parts": np.zeros(3 * p.nnz),
            # the solve's three vectors (naug each), then a touching element's T_e, K_e T_e
            # and C_e T_e (`newton_rigid.touching_tangent`; none without clusters)
            "newton_scratch": np.zeros(3 * c.counts["naug"]
                                       + 3 * c.rigid.max_m * c.rigid.max_mz)}
