"""The rigid clusters packed for the engine: which coordinates and rows leave the systems.

`mechanics.rigid_bodies` finds the model's rigid clusters; the engine then solves its
kinematics and its augmented system on the reduced free coordinates z (the free coordinates
but the slaves'), with the slaves' coordinates explicit in their masters' (`rigid_kernels`):

    x_s = S(z),  xdot_s = T zdot,  xddot_s = T zddot + c(zdot),  T = dS/dz,

and without the rows those make identically zero (the rigid beams', the slaves' Euler
normalisations). Everything else of an evaluation stays on the coordinates x: the elements
see the slaves' coordinates, DF, xdot and conv are filled on their rows through T and c.
The linear systems see each element that touches a slave ("touching" element) through its
own z-coordinates: De_z = De T_e and Dp_z = Dp T_e, T_e (m, mz) the element's block of T,
each row a sum of at most `rigid_bodies.DEPENDENCIES` weights.

Inertia. A massive element whose nodes all belong to one spatial cluster (a rigid beam with
a section mass, a node inertia on a slave) moves with the master as one rigid body: its
mass is folded at packing into the cluster's constant tensors (`rigid_inertia`), and the
augmented form's evaluation adds per cluster a 7 x 7 mass block on the master's coordinates
and its gravity and convective forces from closed formulas, visiting none of those elements
(`rigid_inertia_kernels`); the tangent adds their forces element by element, where they
sit. Massless cluster elements (the manipulator's rigid beams: its bodies' mass is on the
masters as lumped masses and node inertias) are skipped as before; the elements that join a
cluster to the rest (flexible beams on slaves) keep their own mass on their z-coordinates.

The packed tables (slots of `data`, read by `rigid_kernels`):

    rigid_slaves        per slave node: kind, own coordinates (4), the master's translation
                        (3) and rotation (4) coordinates, -1 padded (SLAVE_WIDTH)
    rigid_data          per slave node: its constants (`RigidLayout.data`, 48)
    slave_index         per coordinate: its row among the slave coordinates, or -1
    rigid_dependencies  per slave coordinate: its master coordinates (DEPENDENCIES, -1 padded)
    rigid_element_of    per packed element (group by group): -1, or its touching index t
    rigid_elements      per touching element: E_INTERNAL, E_MZ, E_Z_OFFSET, E_TERM_OFFSET,
                        E_DE_OFFSET (into rigid_de, -1: no rows), E_MASS_OFFSET (into the
                        rigid part of the augmented map, -1: no mass, not evaluated),
                        E_GROUP, E_ELEMENT (its packed group and index there),
                        E_FOLDED (1: its mass is in its cluster's rigid-body inertia,
                        `rigid_inertia`; the evaluations' rhs skip it)
    rigid_z             the touching elements' z-coordinates (model indices), flat
    rigid_terms         per touching element and local coordinate a: DEPENDENCIES pairs
                        (z-local column, weight index: -1 a unit weight, -2 none)
    rigid_units         per DOF coordinate: its slave coordinate row, or -1
    rigid_coordinates   the slave coordinates (model indices)
    rigid_bodies        per spatial cluster with folded masses: its master's coordinates
                        and where its mass block lands (`rigid_inertia`)
    touching_rows       per deformation of a touching element on a row of J: (that row, the
                        touching index t, the deformation's index in its element), flat
"""

import numpy as np

from ..mechanics.rigid_bodies import DEPENDENCIES, RigidLayout, find_clusters
from .point_masses import padded_width
from .rigid_inertia import BODY_SCRATCH, ClusterInertia

SLAVE_WIDTH = 12
(E_INTERNAL, E_MZ, E_Z_OFFSET, E_TERM_OFFSET, E_DE_OFFSET, E_MASS_OFFSET, E_GROUP,
 E_ELEMENT, E_FOLDED, ELEMENT_WIDTH) = range(10)


class RigidPacking:
    """The model's rigid clusters as the engine's tables (see the module docstring).

    Parameters
    ----------
    model : Model
    groups : list of ElementGroup
        Every packed element group, in the engine's order (the model's, then the node
        inertias').
    inertia : dict
        {id of a group with inertia points: its Mp (n, P, P)}.
    enabled : bool
        False: no cluster is eliminated (the tables empty; the engine as without clusters).
    """

    def __init__(self, model, groups, inertia, *, enabled=True):
        self.enabled = enabled
        self.clusters = find_clusters(model) if enabled else []
        layout = self.layout = RigidLayout(model, self.clusters)
        nx = model.nx
        self.slave_index = np.full(nx, -1, dtype=np.int64)
        self.slave_index[layout.slave_coordinates] = np.arange(layout.slave_coordinates.size)
        is_slave = self.slave_index >= 0
        internal = {element for cluster in self.clusters for element in cluster.internal}
        removed = [model.groups[g].deformation_index[i] for g, i in internal]
        removed = np.concatenate(removed) if removed else np.zeros(0, dtype=np.int64)
        free = model.free_coordinates
        self.free = free[~is_slave[free]].astype(np.int64)
        self.rigid_rows = np.setdiff1d(model.rigid_deformations, removed).astype(np.int64)
        self.rows = np.concatenate([self.rigid_rows, model.dof_deformations]).astype(np.int64)
        self.units = self.slave_index[model.dof_coordinates].astype(np.int64)
        slaves = np.full((layout.kinds.size, SLAVE_WIDTH), -1, dtype=np.int64)
        slaves[:, 0] = layout.kinds
        slaves[:, 1:5], slaves[:, 5:8], slaves[:, 8:12] = (layout.own, layout.translation,
                                                           layout.rotation)
        self.slaves = slaves
        element_of, elements, zs, terms = [], [], [], []
        self.touching = []  # (packed group index, element index, z-coordinates)
        self.groups_m = [group.coordinate_index.shape[1] for group in groups]
        self.element_offsets = []
        # as lists: the loop below walks them entry by entry
        slave_of, dependencies = self.slave_index.tolist(), layout.dependencies.tolist()
        de_size = mass_size = z_size = term_size = offset = 0
        for gp, group in enumerate(groups):
            n, m = group.coordinate_index.shape
            k = group.deformation_index.shape[1]
            self.element_offsets.append(offset)
            offset += n
            of = np.full(n, -1, dtype=np.int64)
            element_of.append(of)
            for i in np.flatnonzero(np.any(is_slave[group.coordinate_index], axis=1)).tolist():
                z = []
                pairs = np.full((m, DEPENDENCIES, 2), -2, dtype=np.int64)
                for a, c in enumerate(group.coordinate_index[i].tolist()):
                    s = slave_of[c]
                    sources = ([(c, -1)] if s < 0 else
                               [(d, s * DEPENDENCIES + j)
                                for j, d in enumerate(dependencies[s]) if d >= 0])
                    for u, (d, w) in enumerate(sources):
                        if d not in z:
                            z.append(d)
                        pairs[a, u] = z.index(d), w
                mz = len(z)
                is_internal = gp < len(model.groups) and (gp, i) in internal
                row = np.full(ELEMENT_WIDTH, -1, dtype=np.int64)
                row[E_FOLDED] = 0
                row[[E_INTERNAL, E_MZ, E_Z_OFFSET, E_TERM_OFFSET, E_GROUP, E_ELEMENT]] = (
                    int(is_internal), mz, z_size, term_size, gp, i)
                if k and not is_internal:
                    row[E_DE_OFFSET] = de_size
                    de_size += k * mz
                if id(group) in inertia and np.any(inertia[id(group)][i]):  # massless: none
                    row[E_MASS_OFFSET] = mass_size
                    mass_size += mz * mz
                of[i] = len(elements)
                elements.append(row)
                self.touching.append((gp, i, np.array(z, dtype=np.int64)))
                zs.append(np.array(z, dtype=np.int64))
                terms.append(pairs.ravel())
                z_size += mz
                term_size += pairs.size
        self.element_of = (np.concatenate(element_of) if element_of
                           else np.zeros(0, dtype=np.int64))
        self.elements = (np.array(elements, dtype=np.int64).ravel() if elements
                         else np.zeros(0, dtype=np.int64))
        self.z = np.concatenate(zs) if zs else np.zeros(0, dtype=np.int64)
        self.terms = np.concatenate(terms) if terms else np.zeros(0, dtype=np.int64)
        self.de_size, self.mass_size = de_size, mass_size
        # the rows of J that touching elements' deformations have (`rigid_kernels.
        # touching_row`): the three kernels that walk them read one list
        row_of = {int(d): r for r, d in enumerate(self.rows)}
        self.touching_rows = np.array(
            [(row_of[int(d)], t, b) for t, (gp, i, _) in enumerate(self.touching)
             if self.elements[t * ELEMENT_WIDTH + E_DE_OFFSET] >= 0
             for b, d in enumerate(groups[gp].deformation_index[i]) if int(d) in row_of],
            dtype=np.int64).reshape(-1, 3).ravel()
        # the internal elements' deformations: never evaluated (identically zero)
        self.internal_elements = {(gp, i) for gp, i, _ in self.touching
                                  if self.element_row(gp, i)[E_INTERNAL]}
        # each spatial cluster's element masses as one rigid body on its master (marks the
        # folded elements' rows E_FOLDED)
        self.bodies = ClusterInertia(model, groups, inertia, self)
        for t in self.bodies.folded:
            self.elements[t * ELEMENT_WIDTH + E_FOLDED] = 1

    @property
    def active(self):
        """Whether any cluster is eliminated."""
        return bool(self.clusters)

    def element_row(self, gp, i):
        """The touching element's row of `elements` (None for an element that is not one)."""
        t = self.element_of[self.element_offsets[gp] + i]
        return None if t < 0 else self.elements[t * ELEMENT_WIDTH: (t + 1) * ELEMENT_WIDTH]

    def element_transform(self, gp, i, coords, x, weights=None):
        """T_e (m, mz) of a touching element at x (the plain twin of the kernels' sums);
        `weights`: T's weights at x (`RigidLayout.weights`) when the caller has them."""
        row = self.element_row(gp, i)
        m, mz = len(coords), row[E_MZ]
        W = (self.layout.weights(x) if weights is None else weights).ravel()
        pairs = self.terms[row[E_TERM_OFFSET]: row[E_TERM_OFFSET] + m * DEPENDENCIES * 2]
        column, w = pairs[0::2], pairs[1::2]  # per (a, u): T_e[a, column] += 1 or W[w]
        a = np.repeat(np.arange(m), DEPENDENCIES)
        used = w >= -1
        T = np.zeros((m, mz))
        # the sums in (a, u) order, one entry after the other, as the kernels add them
        np.add.at(T, (a[used], column[used]),
                  np.where(w[used] == -1, 1.0, W[np.maximum(w[used], 0)]))
        return T

    def ints(self):
        """The int64 slots of the clusters, by name."""
        return {"rigid_slaves": self.slaves.ravel(), "slave_index": self.slave_index,
                "rigid_dependencies": self.layout.dependencies.ravel(),
                "rigid_element_of": self.element_of, "rigid_elements": self.elements,
                "rigid_z": self.z, "rigid_terms": self.terms, "rigid_units": self.units,
                "rigid_coordinates": self.layout.slave_coordinates,
                "touching_rows": self.touching_rows, "rigid_bodies": self.bodies.ints}

    @property
    def max_m(self):
        """The most coordinates of a touching element (0 without any)."""
        return max((self.groups_m[gp] for gp, _, _ in self.touching), default=0)

    @property
    def max_mz(self):
        """The most z-coordinates of a touching element (0 without any)."""
        return max((z.size for _, _, z in self.touching), default=0)

    def floats(self, nx, n_free, max_p):
        """The float64 slots of the clusters, by name (constants and workspace)."""
        n_sc = self.layout.slave_coordinates.size
        # the kernel's plain function: no compile; one more lane for the slaves' c
        padded = padded_width.py_func(self.max_mz + 1)
        return {"rigid_data": self.layout.data.ravel(),
                "rigid_body_tensors": self.bodies.tensors,
                "rigid_weights": np.zeros(n_sc * DEPENDENCIES),
                "rigid_de": np.zeros(self.de_size), "rigid_c": np.zeros(nx if n_sc else 0),
                "rigid_h": np.zeros(n_free if n_sc else 0),
                "rigid_force": np.zeros(nx if n_sc else 0),
                # a touching element's Dp_z and Mp Dp_z (max_p rows each), Me_z (max_mz)
                # and T_e (its m), in rows of the padded width (`point_masses.padded_width`),
                # then the forces of the slaves' c (max_mz; `rigid_kernels.touching_mass`)
                # (and a folded cluster's scratch: `rigid_inertia_kernels.add_rigid_bodies`)
                "rigid_local": np.zeros(max((2 * max_p + self.max_mz + self.max_m) * padded
                                            + self.max_mz,
                                            BODY_SCRATCH if self.bodies.folded else 0))}


def positions_among(free, coordinates):
    """The positions of the coordinates among the free ones (-1: not free, a slave's)."""
    at = np.searchsorted(free, coordinates)
    inside = at < free.size
    found = np.zeros(coordinates.size, dtype=bool)
    found[inside] = free[at[inside]] == coordinates[inside]
    return np.where(found, at, -1).astype(np.int64)
