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
    r, c = [], []
    for gp, group in enumerate(model.groups):
        cols = pattern_columns(packing, gp, group, col_of_coord)
        of_row = row_of_def[group.deformation_index]
        rr = np.broadcast_to(of_row[:, :, None], of_row.shape + cols.shape[1:])
        cc = np.broadcast_to(cols[:, None, :], rr.shape)
        inside = (rr >= 0) & (cc >= 0)
        r.append(rr[inside])
        c.append(cc[inside])
    n_def = rows.size
    for j, coordinate in enumerate(model.dof_coordinates):
        s = packing.units[j]
        sources = np.array([coordinate]) if s < 0 else packing.layout.dependencies[s]
        sources = col_of_coord[sources[sources >= 0]]
        sources = sources[sources >= 0]
        r.append(np.full(sources.size, n_def + j, dtype=np.int64))
        c.append(sources)
    identity = np.arange(nf, dtype=np.int64)
    r, c = _unique_entries(r, c, nf)
    if nf == 0 or not r.size:
        return identity, identity.copy(), max(nf - 1, 0), max(nf - 1, 0)
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
    r, c = [np.arange(nf, dtype=np.int64)], [np.arange(nf, dtype=np.int64)]
    for gp, group in enumerate(groups):
        if id(group) not in inertia:
            continue
        cols = pattern_columns(packing, gp, group, col_of_coord)
        a = np.broadcast_to(cols[:, :, None], cols.shape + cols.shape[1:])
        b = np.broadcast_to(cols[:, None, :], a.shape)
        inside = (a >= 0) & (b >= 0)
        r.append(a[inside])
        c.append(b[inside])
    for gp, group in enumerate(model.groups):
        cols = pattern_columns(packing, gp, group, col_of_coord)
        of_row = row_of_def[group.deformation_index]
        o = np.broadcast_to(of_row[:, :, None], of_row.shape + cols.shape[1:])
        cc = np.broadcast_to(cols[:, None, :], o.shape)
        inside = (o >= 0) & (o < n_rigid) & (cc >= 0)
        r += [nf + o[inside], cc[inside]]
        c += [cc[inside], nf + o[inside]]
    if na == 0:
        return np.zeros(0, dtype=np.int64), 0, 0
    r, c = _unique_entries(r, c, na)
    order, kl, ku = bandwidth_order(r, c, na)
    position = np.empty(na, dtype=np.int64)
    position[order] = np.arange(na)
    return position, kl, ku


def pattern_columns(packing, gp, group, col_of_coord):
    """Per element of packed group gp, the columns (free-coordinate positions) its entries
    land on, -1 padded (n, width): its own coordinates', or a touching element's
    z-coordinates' (`RigidPacking.pattern_coordinates`, as one array)."""
    cols = col_of_coord[group.coordinate_index]
    n, m = cols.shape
    of = packing.element_of[packing.element_offsets[gp]:][:n]
    touching = np.flatnonzero(of >= 0)
    zs = [col_of_coord[packing.touching[of[i]][2]] for i in touching]
    out = np.full((n, max([m] + [z.size for z in zs])), -1, dtype=np.int64)
    out[:, :m] = cols
    for i, z in zip(touching, zs, strict=True):
        out[i] = -1
        out[i, :z.size] = z
    return out


def _unique_entries(rows, columns, n):
    """The distinct entries (row, column) of the parts `rows`, `columns` (lists of int
    arrays) of an (n, n) pattern, row by row: the orders see each node's neighbours as a set,
    so duplicates change nothing but their cost."""
    rows = np.concatenate(rows).astype(np.int64) if rows else np.zeros(0, dtype=np.int64)
    columns = (np.concatenate(columns).astype(np.int64) if columns
               else np.zeros(0, dtype=np.int64))
    keys = np.unique(rows * max(n, 1) + columns)
    return keys // max(n, 1), keys % max(n, 1)


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
        self.j_lu = factors.kinematic if self.j_sparse else None
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
