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

    J map         [De entry -> slot (n_de), DOF coordinate j -> slot of its unit entry,
                   with rigid clusters (`rigid`): De_z entry of a touching element -> slot,
                   DOF coordinate j on a slave, dependency d -> slot (DEPENDENCIES each)]
    augmented map [free coordinate -> its diagonal slot (n_free),
                   De entry -> slot of (rigid row, coordinate) (n_de),
                   De entry -> slot of (coordinate, rigid row) (n_de),
                   element mass entry (i, a, b) of each inertia group in turn -> slot,
                   with rigid clusters: the De_z entries below and beside, then each
                   touching element's mass entries (mz x mz) -> slot]

with -1 where an entry does not enter the matrix (a fixed coordinate, a deformation that is
not a rigid row); n_de the size of the engine's De slot (element by element, group by
group at the offsets G_DE_OFFSET). Slots index `sparse_lu.matrix_values`.
"""

import numpy as np

from ..mechanics import assembly
from ..mechanics.rigid_bodies import DEPENDENCIES
from ..numerics.sparse_lu import StaticLU
from .rigid import E_DE_OFFSET, E_MASS_OFFSET

# banded multiplications (the LU of J plus that of the augmented system) from which the
# sparse LU is analysed and weighed against the banded one: the built-in stages and
# tutorials (at most 2.6e4) keep the banded LU, with their numbers. Above it the weighing
# decides: the spatial cantilevers of 16 to 64 BEAMs (8.6e4 to 3.4e5) factor J sparse,
# measured faster at each size (J's factorisation 12 -> 7 us at 96 DOFs, 52 -> 28 us at
# 384); the analysis costs under 1 ms of packing at 384 DOFs
SPARSE_FROM = 5e4
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
                 de_size, packing=None):
        x0 = model.initial_coordinates.astype(float)
        nf = free.size
        n_xdof = model.dof_coordinates.size
        n_def = rows.size
        n_rigid = n_def - model.dof_deformations.size
        rigid = packing is not None and packing.active
        if rigid:  # the slaves at their masters' (round-off from the scene's x0)
            x0 = packing.layout.fill(x0)
        position = {id(group): gp for gp, (group, _) in enumerate(groups)}
        de_rows, de_cols, de_index, de_values = [], [], [], []
        for group, offset in groups:
            n, m = group.coordinate_index.shape
            k = group.deformation_index.shape[1]
            if not (n and k):
                continue
            _, local = group.kind.deformations(group.local(x0), group.reference, order=1)
            r = np.broadcast_to(row_of_def[group.deformation_index][:, :, None], (n, k, m))
            c = np.broadcast_to(col_of_coord[group.coordinate_index][:, None, :], (n, k, m))
            if rigid:  # a touching element's entries come from its De_z (below)
                gp = position[id(group)]
                touching = np.array([packing.element_row(gp, i) is not None
                                     for i in range(n)])
                r = np.where(touching[:, None, None], -1, r)
            de_rows.append(r.ravel())
            de_cols.append(c.ravel())
            de_index.append(offset + np.arange(n * k * m))
            de_values.append(np.asarray(local, dtype=float).ravel())
        # the touching elements' De_z, indexed after the De slot and the unit entries
        rde_base = de_size + n_xdof
        for gp, i, z in (packing.touching if rigid else ()):
            group = groups[gp][0]
            element = packing.element_row(gp, i)
            k = group.deformation_index.shape[1]
            if element[E_DE_OFFSET] < 0:  # no rows
                continue
            coords = group.coordinate_index[i]
            _, local = group.kind.deformations(x0[coords][None], _one(group.reference, i),
                                               order=1)
            De_z = local[0] @ packing.element_transform(gp, i, coords, x0)
            de_rows.append(np.repeat(row_of_def[group.deformation_index[i]], z.size))
            de_cols.append(np.tile(col_of_coord[z], k))
            de_index.append(rde_base + element[E_DE_OFFSET] + np.arange(k * z.size))
            de_values.append(De_z.ravel())
        r, c, index, values = (np.concatenate(parts) if parts else np.zeros(0)
                               for parts in (de_rows, de_cols, de_index, de_values))
        r, c, index = r.astype(np.int64), c.astype(np.int64), index.astype(np.int64)
        inside = (r >= 0) & (c >= 0)
        # the unit rows of the DOF coordinates: T's row on a slave's
        unit_rows, unit_cols, unit_values, unit_index = [], [], [], []
        slave_base = rde_base + (packing.de_size if rigid else 0)
        W0 = packing.layout.weights(x0) if rigid else None
        for j, coordinate in enumerate(model.dof_coordinates):
            s = packing.units[j] if rigid else -1
            if s < 0:
                unit_rows.append(n_def + j)
                unit_cols.append(col_of_coord[coordinate])
                unit_values.append(1.0)
                unit_index.append(de_size + j)
                continue
            for d, dep in enumerate(packing.layout.dependencies[s]):
                if dep >= 0 and col_of_coord[dep] >= 0:
                    unit_rows.append(n_def + j)
                    unit_cols.append(col_of_coord[dep])
                    unit_values.append(W0[s, d])
                    unit_index.append(slave_base + DEPENDENCIES * j + d)
        unit_rows, unit_cols, unit_index = (np.array(a, dtype=np.int64) for a in (
            unit_rows, unit_cols, unit_index))
        # J: the elements' entries, then the unit rows of the DOF coordinates
        self.constraints = StaticLU(nf, np.concatenate([r[inside], unit_rows]),
                                   np.concatenate([c[inside], unit_cols]),
                                   np.concatenate([values[inside], unit_values]))
        self.constraint_map = np.full(
            slave_base + (DEPENDENCIES * n_xdof if rigid else 0), -1, dtype=np.int64)
        self.constraint_map[index[inside]] = self.constraints.slot(r[inside], c[inside])
        self.constraint_map[unit_index] = self.constraints.slot(unit_rows, unit_cols)
        # the augmented system: M_ff, J_o beside it and below it
        rigid_rows = inside & (r < n_rigid)
        mass = assembly.Inertia(model).mass_matrix(x0)
        if rigid:
            T = packing.layout.transform(x0, model.nx)
            mass = T.T @ mass @ T
        mass = mass[np.ix_(free, free)]
        mass_entries = [(np.arange(nf), np.arange(nf))]
        rigid_mass = []
        for group in inertia_groups:
            cols = col_of_coord[group.coordinate_index]
            n, m = cols.shape
            if rigid:
                gp = position[id(group)]
                for i in range(n):
                    element = packing.element_row(gp, i)
                    if element is not None:
                        cols[i] = -1
                    if element is not None and element[E_MASS_OFFSET] >= 0:
                        z = col_of_coord[packing.touching[packing.element_of[
                            packing.element_offsets[gp] + i]][2]]
                        rigid_mass.append((np.repeat(z, z.size), np.tile(z, z.size)))
            mass_entries.append((np.broadcast_to(cols[:, :, None], (n, m, m)).ravel(),
                                 np.broadcast_to(cols[:, None, :], (n, m, m)).ravel()))
        mass_entries.extend(rigid_mass)
        mr = np.concatenate([a for a, _ in mass_entries])
        mc = np.concatenate([b for _, b in mass_entries])
        in_mass = (mr >= 0) & (mc >= 0)
        ar = np.concatenate([mr[in_mass], nf + r[rigid_rows], c[rigid_rows]])
        ac = np.concatenate([mc[in_mass], c[rigid_rows], nf + r[rigid_rows]])
        dense_values = np.concatenate([mass[mr[in_mass], mc[in_mass]], values[rigid_rows],
                                       values[rigid_rows]])
        # unique entries: the mass blocks of neighbouring elements overlap, and the values
        # are those of the assembled matrix
        _, first = np.unique(ar * (nf + n_rigid) + ac, return_index=True)
        self.augmented = StaticLU(nf + n_rigid, ar[first], ac[first], dense_values[first])
        mass_slots = np.full(mr.size, -1, dtype=np.int64)
        mass_slots[in_mass] = self.augmented.slot(mr[in_mass], mc[in_mass])
        n_source = slave_base  # De, the unit entries, the touching elements' De_z
        below, beside = (np.full(n_source, -1, dtype=np.int64) for _ in range(2))
        below[index[rigid_rows]] = self.augmented.slot(nf + r[rigid_rows], c[rigid_rows])
        beside[index[rigid_rows]] = self.augmented.slot(c[rigid_rows], nf + r[rigid_rows])
        n_rigid_mass = sum(a.size for a, _ in rigid_mass)
        normal_mass = mass_slots[nf: mass_slots.size - n_rigid_mass]
        self.augmented_map = np.concatenate([
            mass_slots[:nf], below[:de_size], beside[:de_size], normal_mass,
            below[rde_base:], beside[rde_base:], mass_slots[mass_slots.size - n_rigid_mass:]])
        # where the touching elements' part begins: [De_z below, De_z beside, their masses]
        self.rigid_start = nf + 2 * de_size + normal_mass.size

    def multiplications(self):
        """{"j_factor", "j_solve", "a_factor", "a_solve"}: multiplications of each LU."""
        j, a = self.constraints.multiplications, self.augmented.multiplications
        return {"j_factor": j["factor"], "j_solve": j["solve"], "a_factor": a["factor"],
                "a_solve": a["solve"]}


def analyse(model, groups, inertia_groups, free, rows, row_of_def, col_of_coord, de_size,
            banded_multiplications, packing=None):
    """`SparseFactors` of the model when its banded LUs cost at least SPARSE_FROM
    multiplications and both matrices have a static pivot order at the initial
    configuration; else None (the banded LU serves)."""
    if banded_multiplications < SPARSE_FROM:
        return None
    try:
        return SparseFactors(model, groups, inertia_groups, free, rows, row_of_def,
                             col_of_coord, de_size, packing)
    except ValueError:  # singular at the initial configuration: no static pivots
        return None


def _one(reference, i):
    """The reference of element i of a group, as a group of one."""
    return {key: np.asarray(value)[i: i + 1] for key, value in reference.items()}
