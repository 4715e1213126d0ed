"""The sparse LU of a large model's J and augmented system, packed for the engine.

`data.EngineData` factors the constraint Jacobian J (free x free) and the augmented system
[M_ff J_o^T; J_o 0] of the accelerations with the banded LU (`numerics.banded`) in the
bandwidth-reducing order, or, where that band stays wide (closed loops: the six-DOF
manipulator's J has kl = 165), with the static-pivot sparse LU (`numerics.sparse_lu`). This
module builds the second: each matrix's pattern (every entry an element couples: the
elements' deformations with their coordinates for J, their mass blocks and the rigid rows for
the augmented system; the DOF coordinates' unit rows of J and the lumped masses), its
`StaticLU` from the values at the initial configuration, and the scatter maps that put the
elements' contributions straight into the sparse values, so the engine forms no dense (n, n)
matrix on this path:

    J map         [De entry -> slot (n_de), DOF coordinate j -> slot of its unit entry]
    augmented map [free coordinate -> its diagonal slot (n_free),
                   De entry -> slot of (rigid row, coordinate) (n_de),
                   De entry -> slot of (coordinate, rigid row) (n_de),
                   element mass entry (i, a, b) of each inertia group in turn -> slot]

with -1 where an entry does not enter the matrix (a fixed coordinate, a deformation that is
not a rigid row); n_de the size of the engine's De slot (element by element, group by
group at the offsets G_DE_OFFSET). Slots index `sparse_lu.matrix_values`.
"""

import numpy as np

from ..mechanics import assembly
from ..numerics.sparse_lu import StaticLU

# banded multiplications (the LU of J plus that of the augmented system) from which the
# sparse LU is analysed and weighed against the banded one: below it the banded LU costs a
# few hundred microseconds at most, and the stages and tutorials (at most 1e5) keep it, with
# their numbers, without paying for the analysis at packing
SPARSE_FROM = 1e6
# the time of one multiplication of the sparse LU in those of the banded LU (indirect
# addressing against contiguous rows the compiler vectorises): measured on the manipulator's
# J, 1.7 ns per multiplication for the sparse factor and 0.35 ns for the banded one
SPARSE_WEIGHT = 5.0


class SparseFactors:
    """The static-pivot LUs and scatter maps of J and of the augmented system of one model.

    Parameters
    ----------
    model : Model
    groups : list of (group, de_offset)
        Every packed element group in the engine's order, with the offset of its De in the
        engine's De slot.
    inertia_groups : list
        The groups with inertia points, in the engine's order.
    free, rows, row_of_def, col_of_coord : ndarray of int
        The engine's free coordinates, constraint rows and their inverse maps.
    de_size : int
        The size of the engine's De slot.

    Attributes
    ----------
    constraints, augmented : StaticLU
    constraint_map, augmented_map : ndarray of int
        The scatter maps of the module docstring.
    """

    def __init__(self, model, groups, inertia_groups, free, rows, row_of_def, col_of_coord,
                 de_size):
        x0 = model.initial_coordinates.astype(float)
        nf, n_rigid = free.size, model.rigid_deformations.size
        n_def = rows.size
        de_rows, de_cols, de_index, de_values = [], [], [], []
        for group, offset in groups:
            n, m = group.coordinate_index.shape
            k = group.deformation_index.shape[1]
            if not (n and k):
                continue
            _, local = group.kind.deformations(group.local(x0), group.reference, order=1)
            r = np.broadcast_to(row_of_def[group.deformation_index][:, :, None], (n, k, m))
            c = np.broadcast_to(col_of_coord[group.coordinate_index][:, None, :], (n, k, m))
            de_rows.append(r.ravel())
            de_cols.append(c.ravel())
            de_index.append(offset + np.arange(n * k * m))
            de_values.append(np.asarray(local, dtype=float).ravel())
        r, c, index, values = (np.concatenate(parts) if parts else np.zeros(0)
                               for parts in (de_rows, de_cols, de_index, de_values))
        r, c, index = r.astype(np.int64), c.astype(np.int64), index.astype(np.int64)
        inside = (r >= 0) & (c >= 0)
        dof_positions = np.searchsorted(free, model.dof_coordinates).astype(np.int64)
        unit_rows = n_def + np.arange(dof_positions.size)
        # J: the elements' entries, then the unit rows of the DOF coordinates
        self.constraints = StaticLU(nf, np.concatenate([r[inside], unit_rows]),
                                   np.concatenate([c[inside], dof_positions]),
                                   np.concatenate([values[inside], np.ones(unit_rows.size)]))
        self.constraint_map = np.full(de_size + unit_rows.size, -1, dtype=np.int64)
        self.constraint_map[index[inside]] = self.constraints.slot(r[inside], c[inside])
        self.constraint_map[de_size:] = self.constraints.slot(unit_rows, dof_positions)
        # the augmented system: M_ff, J_o beside it and below it
        rigid = inside & (r < n_rigid)
        mass = assembly.Inertia(model).mass_matrix(x0)[np.ix_(free, free)]
        mass_entries = [(np.arange(nf), np.arange(nf))]
        for group in inertia_groups:
            cols = col_of_coord[group.coordinate_index]
            n, m = cols.shape
            mass_entries.append((np.broadcast_to(cols[:, :, None], (n, m, m)).ravel(),
                                 np.broadcast_to(cols[:, None, :], (n, m, m)).ravel()))
        mr = np.concatenate([a for a, _ in mass_entries])
        mc = np.concatenate([b for _, b in mass_entries])
        in_mass = (mr >= 0) & (mc >= 0)
        ar = np.concatenate([mr[in_mass], nf + r[rigid], c[rigid]])
        ac = np.concatenate([mc[in_mass], c[rigid], nf + r[rigid]])
        dense_values = np.concatenate([mass[mr[in_mass], mc[in_mass]], values[rigid],
                                       values[rigid]])
        # unique entries: the mass blocks of neighbouring elements overlap, and the values
        # are those of the assembled matrix
        _, first = np.unique(ar * (nf + n_rigid) + ac, return_index=True)
        self.augmented = StaticLU(nf + n_rigid, ar[first], ac[first], dense_values[first])
        mass_slots = np.full(mr.size, -1, dtype=np.int64)
        mass_slots[in_mass] = self.augmented.slot(mr[in_mass], mc[in_mass])
        below, beside = (np.full(de_size, -1, dtype=np.int64) for _ in range(2))
        below[index[rigid]] = self.augmented.slot(nf + r[rigid], c[rigid])
        beside[index[rigid]] = self.augmented.slot(c[rigid], nf + r[rigid])
        self.augmented_map = np.concatenate([mass_slots[:nf], below, beside, mass_slots[nf:]])

    def multiplications(self):
        """{"j_factor", "j_solve", "a_factor", "a_solve"}: multiplications of each LU."""
        j, a = self.constraints.multiplications, self.augmented.multiplications
        return {"j_factor": j["factor"], "j_solve": j["solve"], "a_factor": a["factor"],
                "a_solve": a["solve"]}


def analyse(model, groups, inertia_groups, free, rows, row_of_def, col_of_coord, de_size,
            banded_multiplications):
    """`SparseFactors` of the model when its banded LUs cost at least SPARSE_FROM
    multiplications and both matrices have a static pivot order at the initial
    configuration; else None (the banded LU serves)."""
    if banded_multiplications < SPARSE_FROM:
        return None
    try:
        return SparseFactors(model, groups, inertia_groups, free, rows, row_of_def,
                             col_of_coord, de_size)
    except ValueError:  # singular at the initial configuration: no static pivots
        return None
