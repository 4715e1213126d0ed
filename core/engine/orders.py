"""How J and the augmented system are ordered and factored: chosen once per model.

J (free x free) and the augmented system of the accelerations are factored banded in a
bandwidth-reducing order (`numerics.banded`) or, where that band stays wide, by the
static-pivot sparse LU (`sparse_packing`); the accelerations come from the reduced or the
augmented form. `FactorPlan` chooses, by counting multiplications (`data.evaluation_cost`),
and keeps the orders and the sparse analysis per live model (a Simulator packs its model twice).
Nothing here is compiled; `packing` puts the choice into the slots.
"""


import numpy as np

from ..live_models import PerLiveModel
from . import data, sparse_packing  # data: its cost model, which tests may replace

# the banded orders of a model's J and augmented system, computed once per live model (read
# only): {(id(model), rigid): (weak reference to the model, orders)}
_ORDERS = PerLiveModel()  # (model, clusters packed) -> orders and sparse analysis


def constraint_order(model, free, rows, row_of_def, col_of_coord, packing):
    """Positions of J's rows and columns in its banded order, and its (kl, ku): each row
    matched to a column (a structurally nonsingular J has a perfect matching), then reverse
    Cuthill-McKee on the matched pattern (core/numerics/banded.py). The identity order, dense,
    when there is no perfect matching."""
    from ..numerics.banded import bandwidth_order
    from ..numerics.graph_orders import matching

    nf = free.size
    entries = []
    for gp, group in enumerate(model.groups):
        for coords, defs in zip(packing.pattern_coordinates(gp, group),
                                group.deformation_index, strict=True):
            cols = [col_of_coord[c] for c in coords if col_of_coord[c] >= 0]
            for d in defs:
                if row_of_def[d] >= 0:
                    entries.extend((row_of_def[d], c) for c in cols)
    n_def = rows.size
    for j, c in enumerate(model.dof_coordinates):
        s = packing.units[j]
        sources = [c] if s < 0 else packing.layout.dependencies[s]
        entries.extend((n_def + j, col_of_coord[d]) for d in sources
                       if d >= 0 and col_of_coord[d] >= 0)
    identity = np.arange(nf, dtype=np.int64)
    if nf == 0 or not entries:
        return identity, identity.copy(), max(nf - 1, 0), max(nf - 1, 0)
    r, c = np.array(entries, dtype=np.int64).T
    column_of_row = matching(r, c, nf)
    if np.any(column_of_row < 0):
        return identity, identity.copy(), nf - 1, nf - 1
    order, _, _ = bandwidth_order(column_of_row[r], c, nf)  # rows renamed by their column
    column_position = np.empty(nf, dtype=np.int64)
    column_position[order] = np.arange(nf)
    row_position = column_position[column_of_row]
    offsets = row_position[r] - column_position[c]
    return (row_position, column_position, int(max(0, offsets.max())),
            int(max(0, -offsets.min())))


def augmented_order(model, nf, n_rigid, row_of_def, col_of_coord, groups, inertia, packing):
    """Positions of the augmented system's unknowns (the free coordinates, then the rigid
    rows' multipliers) in its banded order, and its (kl, ku)."""
    from ..numerics.banded import bandwidth_order

    na = nf + n_rigid
    entries = [(a, a) for a in range(nf)]
    for gp, group in enumerate(groups):
        if id(group) not in inertia:
            continue
        for coords in packing.pattern_coordinates(gp, group):
            cols = [col_of_coord[c] for c in coords if col_of_coord[c] >= 0]
            entries.extend((a, b) for a in cols for b in cols)
    for gp, group in enumerate(model.groups):
        for coords, defs in zip(packing.pattern_coordinates(gp, group),
                                group.deformation_index, strict=True):
            cols = [col_of_coord[c] for c in coords if col_of_coord[c] >= 0]
            for d in defs:
                o = row_of_def[d]
                if 0 <= o < n_rigid:
                    entries.extend((nf + o, c) for c in cols)
                    entries.extend((c, nf + o) for c in cols)
    if na == 0:
        return np.zeros(0, dtype=np.int64), 0, 0
    r, c = np.array(entries, dtype=np.int64).T
    order, kl, ku = bandwidth_order(r, c, na)
    position = np.empty(na, dtype=np.int64)
    position[order] = np.arange(na)
    return position, kl, ku


class FactorPlan:
    """How one packing of a model factors J and the augmented system, and which form gives
    the accelerations (see the module docstring).

    Attributes: j_rows, j_columns (J's rows and columns in its banded order), aug_position
    (the augmented system's unknowns in its), bands (j_kl, j_ku, a_kl, a_ku), costs
    (`evaluation_cost`), augmented, j_sparse, a_sparse (bools), j_lu, a_lu (the sparse LUs
    used, or None), factors (the `sparse_packing.SparseFactors` analysed, or None).

    Parameters
    ----------
    model : Model
    groups : packing.ElementGroups
    topology : packing.Topology
    rigid : RigidPacking
    augmented, sparse : bool or None
        As `EngineData`'s.
    """

    def __init__(self, model, groups, topology, rigid, *, augmented=None, sparse=None):
        free, rows, n_rigid = topology.free, topology.rows, topology.n_rigid
        found = _found(model, groups, topology, rigid)
        (self.j_rows, self.j_columns, j_kl, j_ku), (self.aug_position, a_kl, a_ku) = \
            found["orders"]
        self.bands = bands = (int(j_kl), int(j_ku), int(a_kl), int(a_ku))
        # a forced analysis (sparse=True) is kept apart from the chosen one (sparse=None):
        # below SPARSE_FROM the chosen one is None, and a later packing of the same model
        # must get the same factors as a fresh model would, whichever packed it first
        key = "sparse forced" if sparse else "sparse"
        if sparse is not False and key not in found:
            banded_lu = (data.banded_multiplications(free.size, *bands[:2])
                         + data.banded_multiplications(free.size + n_rigid, *bands[2:]))
            found[key] = sparse_packing.analyse(
                model, groups.de_groups, [group for group in groups.all
                                          if id(group) in groups.inertia],
                free, rows, topology.row_of_def, topology.col_of_coord, groups.de_size,
                np.inf if sparse else banded_lu, rigid)
        factors = self.factors = found.get(key) if sparse is not False else None
        costs = data.evaluation_cost(free.size, n_rigid, model.declared_dof_count,
                                groups.cost_shapes(), bands,
                                None if factors is None else factors.multiplications())
        if sparse and factors is not None:  # forced: both matrices sparse
            costs["constraint_lu"] = costs["augmented_lu"] = "sparse"
        self.costs = costs
        # the form with fewer multiplications (measured, one evaluation, both forms
        # alternating: reduced / augmented 6.6 / 7.4 us on stage_planar_1dof, 47 / 41 us on
        # stage_spatial_19dof, 21 / 14 us on the refined stage with 4 PLBEAMs per spring,
        # 244 / 50 us with 16; the counts order all of them the same way)
        self.augmented = (costs["augmented"] < costs["reduced"] if augmented is None
                          else bool(augmented))
        self.j_sparse = costs["constraint_lu"] == "sparse"
        self.a_sparse = costs["augmented_lu"] == "sparse"
        self.j_lu = factors.constraints if self.j_sparse else None
        self.a_lu = factors.augmented if self.a_sparse else None


def _found(model, groups, topology, rigid):
    """{"orders": ((J's row and column positions, kl, ku), (the augmented system's
    positions, kl, ku))} of the model, and later its "sparse" analysis: computed once per
    live model and packing of its rigid clusters ("sparse forced" for a packing that forces
    the sparse LUs)."""
    known = _ORDERS.get(model, rigid.enabled)  # a Simulator packs its model twice
    if known is not None:
        return known
    found = {"orders": (
        constraint_order(model, topology.free, topology.rows, topology.row_of_def,
                         topology.col_of_coord, rigid),
        augmented_order(model, topology.free.size, topology.n_rigid, topology.row_of_def,
                        topology.col_of_coord, groups.all, groups.inertia, rigid))}
    return _ORDERS.put(model, found, rigid.enabled)
