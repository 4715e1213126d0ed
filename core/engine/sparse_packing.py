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
group at the offsets G_DE_OFFSET). Slots index `sparse_lu.matrix_values`. The engine's LU of
J is J^T's (`SparseFactors.kinematic`; its J map puts entry (r, c) of J at (c, r) of J^T),
J's own (`constraints`) is the sparse Newton matrix's.
"""

import functools

import numpy as np

from ..mechanics import assembly
from ..mechanics.rigid_bodies import DEPENDENCIES
from ..numerics.sparse_lu import StaticLU
from .rigid import E_DE_OFFSET, E_MASS_OFFSET, ELEMENT_WIDTH

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
    kinematic, augmented : StaticLU
        The LUs the engine factors: of J^T (`sparse_factors`) and of the augmented system.
    kinematic_map, augmented_map : ndarray of int
        Their scatter maps (the module docstring's).
    constraints : StaticLU
    constraint_map : ndarray of int
        J's own LU and its map (the sparse Newton matrix's), analysed when first asked for.
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
        jacobians = {}  # id(group): its elements' De (n, k, m) at x0
        for group, offset in groups:
            n, m = group.coordinate_index.shape
            k = group.deformation_index.shape[1]
            if not (n and k):
                continue
            _, local = group.kind.deformations(group.local(x0), group.reference, order=1)
            jacobians[id(group)] = local
            r = np.broadcast_to(row_of_def[group.deformation_index][:, :, None], (n, k, m))
            c = np.broadcast_to(col_of_coord[group.coordinate_index][:, None, :], (n, k, m))
            if rigid:  # a touching element's entries come from its De_z (below)
                r = np.where(_touching(packing, position[id(group)], n)[:, None, None], -1, r)
            de_rows.append(r.ravel())
            de_cols.append(c.ravel())
            de_index.append(offset + np.arange(n * k * m))
            de_values.append(np.asarray(local, dtype=float).ravel())
        # the touching elements' De_z, indexed after the De slot and the unit entries
        rde_base = de_size + n_xdof
        W0 = packing.layout.weights(x0) if rigid else None  # T's weights at x0
        for gp, i, z in (packing.touching if rigid else ()):
            group = groups[gp][0]
            element = packing.element_row(gp, i)
            k = group.deformation_index.shape[1]
            if element[E_DE_OFFSET] < 0:  # no rows
                continue
            coords = group.coordinate_index[i]
            De_z = jacobians[id(group)][i] @ packing.element_transform(gp, i, coords, x0,
                                                                       weights=W0)
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
        # J: the elements' entries, then the unit rows of the DOF coordinates, each with its
        # index in a J map
        self._j = (nf, np.concatenate([r[inside], unit_rows]),
                   np.concatenate([c[inside], unit_cols]),
                   np.concatenate([values[inside], unit_values]),
                   np.concatenate([index[inside], unit_index]),
                   slave_base + (DEPENDENCIES * n_xdof if rigid else 0))
        # the engine's LU of J is that of J^T (`sparse_factors`: on the manipulators it takes
        # a third fewer multiplications than J's own, with shorter solves)
        _, jr, jc, jv, _, _ = self._j
        self.kinematic = StaticLU(nf, jc, jr, jv, sparsest_rows=True)
        self.kinematic_map = self._j_map(lambda rows, columns: self.kinematic.slot(columns,
                                                                                   rows))
        # the augmented system: M_ff, J_o beside it and below it
        rigid_rows = inside & (r < n_rigid)
        mass_entries = [(np.arange(nf), np.arange(nf))]
        rigid_mass = []
        for group in inertia_groups:
            cols = col_of_coord[group.coordinate_index]
            n, m = cols.shape
            if rigid:
                gp = position[id(group)]
                cols[_touching(packing, gp, n)] = -1
                of = packing.element_of[packing.element_offsets[gp]:][:n]
                for t in of[of >= 0]:
                    if packing.elements[t * ELEMENT_WIDTH + E_MASS_OFFSET] >= 0:
                        z = col_of_coord[packing.touching[t][2]]
                        rigid_mass.append((np.repeat(z, z.size), np.tile(z, z.size)))
            mass_entries.append((np.broadcast_to(cols[:, :, None], (n, m, m)).ravel(),
                                 np.broadcast_to(cols[:, None, :], (n, m, m)).ravel()))
        mass_entries.extend(rigid_mass)
        mr = np.concatenate([a for a, _ in mass_entries])
        mc = np.concatenate([b for _, b in mass_entries])
        in_mass = (mr >= 0) & (mc >= 0)
        ar = np.concatenate([mr[in_mass], nf + r[rigid_rows], c[rigid_rows]])
        ac = np.concatenate([mc[in_mass], c[rigid_rows], nf + r[rigid_rows]])
        mass = mass_entries_at(model, x0, free[mr[in_mass]], free[mc[in_mass]],
                               packing.layout if rigid else None)
        dense_values = np.concatenate([mass, values[rigid_rows], values[rigid_rows]])
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

    @functools.cached_property
    def constraints(self):
        """J's own LU (not J^T's): the sparse Newton matrix's copy (`newton_packing`), analysed
        when first asked for."""
        n, jr, jc, jv, _, _ = self._j
        return StaticLU(n, jr, jc, jv, sparsest_rows=True)

    @functools.cached_property
    def constraint_map(self):
        """The J map of `constraints` (the module docstring's)."""
        return self._j_map(self.constraints.slot)

    def _j_map(self, slot):
        """A J map (the module docstring's) from slot(rows, columns) of J's entries."""
        _, jr, jc, _, index, size = self._j
        out = np.full(size, -1, dtype=np.int64)
        out[index] = slot(jr, jc)
        return out

    def multiplications(self):
        """{"j_factor", "j_solve", "a_factor", "a_solve"}: multiplications of each LU (J's:
        the engine's, of J^T)."""
        j, a = self.kinematic.multiplications, self.augmented.multiplications
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


def mass_entries_at(model, x, rows, columns, layout=None):
    """Entries (rows[i], columns[i]) of the mass matrix M(x) (`assembly.Inertia.mass_matrix`),
    or, with the rigid clusters' `layout`, of T^T M T (T = `RigidLayout.transform`): kg (kg m,
    kg m^2 on rotations), without forming an (NX, NX) matrix.

    M's entries are summed as `mass_matrix` sums them (the lumped mass, then each group's
    elements in their order), so they are M's to the bit; T^T M T is a sparse product whose
    entries with several terms differ from a dense (BLAS) product's by round-off (1e-16 of
    the entry)."""
    from scipy.sparse import csr_matrix

    nx = model.nx
    inertia = assembly.Inertia(model)
    keys, parts = [np.arange(nx, dtype=np.int64) * (nx + 1)], []
    for group, Mp in inertia.groups:
        n, m = group.coordinate_index.shape
        # the massive elements: a massless one adds zeros, which leave every sum as it is
        massive = np.flatnonzero(np.any(Mp, axis=(1, 2)))  # Mp (n, P, P)
        _, Dp = group.kind.inertia_points(group.local(x), group.reference, order=1)
        Dp, Mp = Dp[massive], Mp[massive]
        pairs = assembly.pair_index(group, nx).reshape(n, m * m)[massive]
        unique, at = np.unique(pairs, return_inverse=True)
        # each pair's sum in the elements' order, as `scatter_matrix`'s bincount sums it
        sums = np.bincount(at.ravel(), weights=np.einsum("npi,npr,nrj->nij", Dp, Mp,
                                                          Dp).ravel(), minlength=unique.size)
        keys.append(unique)
        parts.append((unique, sums))
    keys = np.unique(np.concatenate(keys))
    values = np.zeros(keys.size)
    values[np.searchsorted(keys, np.arange(nx, dtype=np.int64) * (nx + 1))] = inertia.lumped
    for unique, sums in parts:  # M += each group's sums (zero elsewhere), as mass_matrix
        added = np.zeros(keys.size)
        added[np.searchsorted(keys, unique)] = sums
        values += added
    rows, columns = np.asarray(rows, dtype=np.int64), np.asarray(columns, dtype=np.int64)
    if layout is None:  # M's entries; zero where no element and no lumped mass is
        wanted = rows * nx + columns
        at = np.minimum(np.searchsorted(keys, wanted), keys.size - 1)
        return np.where(keys[at] == wanted, values[at], 0.0)
    M = csr_matrix((values, (keys // nx, keys % nx)), shape=(nx, nx))
    T = _transform(layout, x, nx)
    TMT = (T.T @ M @ T).tocsr()
    return np.asarray(TMT[rows, columns]).ravel()


def _transform(layout, x, nx):
    """`RigidLayout.transform` as a CSR matrix: the identity on the coordinates but the
    slaves', whose rows hold T's weights on their masters."""
    from scipy.sparse import csr_matrix

    slave = np.zeros(nx, dtype=bool)
    slave[layout.slave_coordinates] = True
    kept = np.flatnonzero(~slave)
    W = layout.weights(x)
    s, d = np.nonzero(layout.dependencies >= 0)
    rows = np.concatenate([kept, layout.slave_coordinates[s]])
    columns = np.concatenate([kept, layout.dependencies[s, d]])
    return csr_matrix((np.concatenate([np.ones(kept.size), W[s, d]]), (rows, columns)),
                      shape=(nx, nx))


def _touching(packing, gp, n):
    """Per element of packed group gp (n of them): whether it touches a slave."""
    return packing.element_of[packing.element_offsets[gp]:][:n] >= 0
