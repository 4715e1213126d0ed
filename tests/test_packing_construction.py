"""The packing's vectorised constructions against plain ones (core/engine/packing.py, rigid.py,
orders.py, sparse_packing.py, core/mechanics/rigid_bodies.py, core/numerics/pattern_slots.py).

Packing a model builds its rigid clusters' tables, J's and the augmented system's banded
orders, the stressed S and D and the sparse LUs' reference values with array operations. Each
is checked here against the plain construction it replaced (element by element, kept below as
the reference: the rigid clusters, the orders' pattern entries, the slaves' quaternion
matrices) or against an independent one (the dense (NE, NE) S and D, the dense mass matrix
and T^T M T, the dense transform T, the sparse LU's slot lookup by arrays). Integer tables
and copied values are compared exactly (the same numbers by construction); computed floats
within 1e-14 of the largest entry (bit-identical to the plain construction on the
development machine, docs/benchmarks.md 2026-12-01; T^T M T's entries that cancel differ from
a dense BLAS product's by round-off).
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from flexure.core import load_scene
from flexure.core.engine import data as ed  # noqa: F401  (imports the packing in its order)
from flexure.core.engine import orders, packing, sparse_packing
from flexure.core.engine.rigid import E_MZ, ELEMENT_WIDTH
from flexure.core.mechanics import assembly
from flexure.core.mechanics.rigid_bodies import RIGID_KINDS, find_clusters
from flexure.core.model import FIXED, ZERO
from flexure.core.numerics.banded import bandwidth_order
from flexure.core.numerics.graph_orders import matching
from flexure.core.numerics.rotations import compose

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from examples.benchmarks.spatial import spatial_cantilever  # noqa: E402

FAST = ["stage_planar_3dof", "stage_spatial_19dof", "cantilever8"]
SLOW = ["manipulator_control", "manipulator_reduced"]


def build(name):
    return spatial_cantilever(int(name[10:])) if name.startswith("cantilever") else \
        load_scene(name)


def context(model, rigid=True):
    return packing.Context(model, tolerance=1e-15, singular_ratio=1e-6, augmented=None,
                           sparse=None, rigid=rigid)


CASES = FAST + [pytest.param(name, marks=pytest.mark.slow) for name in SLOW]


@pytest.fixture(scope="module", params=CASES)
def packed(request):
    model = build(request.param)
    return model, context(model)


# -- the plain constructions, as they were written element by element ------------------------
def plain_find_clusters(model):
    """`find_clusters` as a loop over every element per cluster (its names as sets)."""
    nodes = {node.name: node for node in model.nodes}
    parent = {name: name for name in nodes}

    def root(name):
        while parent[name] != name:
            name = parent[name]
        return name

    def element_nodes(coords):
        return list(dict.fromkeys(model.coordinate_node[c] for c in coords))

    edges = []
    for g, group in enumerate(model.groups):
        if group.kind.type_name not in RIGID_KINDS:
            continue
        for i, (coords, defs) in enumerate(zip(group.coordinate_index,
                                               group.deformation_index, strict=True)):
            if np.all(model.deformation_status[defs] == ZERO):
                names = element_nodes(coords)
                edges.append((g, i, names))
                for name in names[1:]:
                    a, b = root(name), root(names[0])
                    if a != b:
                        parent[a] = b
    members = {}
    for _, _, names in edges:
        members.setdefault(root(names[0]), set()).update(names)
    inertia_nodes = {model.coordinate_node[index[0]] for index, _ in model.node_inertias}
    status, lumped = model.coordinate_status, model.lumped_mass
    clusters = []
    for key, names in members.items():
        ordered = [name for name in nodes if name in names]
        special = {name for name in ordered if any(
            status[c] == FIXED or lumped[c] != 0.0 for c in nodes[name].coordinates)}
        masters = []
        for kind in ("translational", "rotational"):
            of_kind = [name for name in ordered if nodes[name].kind == kind]
            chosen = [name for name in of_kind if name in special]
            if len(chosen) > 1 or not of_kind:
                break
            if not chosen and kind == "rotational":
                chosen = [name for name in of_kind if name in inertia_nodes]
            masters.append(chosen[0] if chosen else of_kind[0])
        if len(masters) < 2:
            continue
        slaves = tuple(name for name in ordered if name not in masters)
        internal = [(g, i) for g, i, names in edges if root(names[0]) == key]
        for g, group in enumerate(model.groups):
            if group.kind.type_name in RIGID_KINDS:
                continue
            for i, (coords, defs) in enumerate(zip(group.coordinate_index,
                                                   group.deformation_index, strict=True)):
                if (defs.size and np.all(model.deformation_status[defs] == ZERO)
                        and set(element_nodes(coords)) <= set(slaves)):
                    internal.append((g, i))
        if (sum(len(nodes[name].coordinates) for name in slaves)
                != sum(model.groups[g].deformation_index.shape[1] for g, _ in internal)):
            continue
        clusters.append((masters[0], masters[1], slaves, tuple(sorted(internal))))
    return clusters


def plain_pattern_coordinates(rigid, gp, group):
    """Per element: its coordinates, or a touching element's z-coordinates."""
    out = []
    for i, coords in enumerate(group.coordinate_index):
        t = rigid.element_of[rigid.element_offsets[gp] + i]
        out.append(coords if t < 0 else rigid.touching[t][2])
    return out


def plain_constraint_entries(model, c):
    """J's pattern entries (row, column) element by element, duplicates kept."""
    t, rigid = c.topology, c.rigid
    entries = []
    for gp, group in enumerate(model.groups):
        for coords, defs in zip(plain_pattern_coordinates(rigid, gp, group),
                                group.deformation_index, strict=True):
            cols = [t.col_of_coord[k] for k in coords if t.col_of_coord[k] >= 0]
            for d in defs:
                if t.row_of_def[d] >= 0:
                    entries.extend((t.row_of_def[d], k) for k in cols)
    for j, coordinate in enumerate(model.dof_coordinates):
        s = rigid.units[j]
        sources = [coordinate] if s < 0 else rigid.layout.dependencies[s]
        entries.extend((t.rows.size + j, t.col_of_coord[d]) for d in sources
                       if d >= 0 and t.col_of_coord[d] >= 0)
    return np.array(entries, dtype=np.int64).reshape(-1, 2).T


def plain_augmented_entries(model, c):
    """The augmented system's pattern entries element by element, duplicates kept."""
    t, rigid, nf = c.topology, c.rigid, c.topology.free.size
    entries = [(a, a) for a in range(nf)]
    for gp, group in enumerate(c.groups.all):
        if id(group) not in c.groups.inertia:
            continue
        for coords in plain_pattern_coordinates(rigid, gp, group):
            cols = [t.col_of_coord[k] for k in coords if t.col_of_coord[k] >= 0]
            entries.extend((a, b) for a in cols for b in cols)
    for gp, group in enumerate(model.groups):
        for coords, defs in zip(plain_pattern_coordinates(rigid, gp, group),
                                group.deformation_index, strict=True):
            cols = [t.col_of_coord[k] for k in coords if t.col_of_coord[k] >= 0]
            for d in defs:
                o = t.row_of_def[d]
                if 0 <= o < t.n_rigid:
                    entries.extend((nf + o, k) for k in cols)
                    entries.extend((k, nf + o) for k in cols)
    return np.array(entries, dtype=np.int64).reshape(-1, 2).T


# -- the tests ---------------------------------------------------------------------------------
def test_clusters_are_the_plain_ones(packed):
    model, _ = packed
    found = [(k.master_translation, k.master_rotation, k.slaves, k.internal)
             for k in find_clusters(model)]
    assert found == plain_find_clusters(model)


def test_slave_rotations_are_the_plain_quaternion_products(packed):
    """Q of each spatial rotation slave: column k the product e_k * relative, relative =
    lambda_m0^-1 * lambda_s0, computed slave by slave."""
    model, c = packed
    layout, x0 = c.rigid.layout, model.initial_coordinates.astype(float)
    rotations = np.flatnonzero(layout.kinds == 1)  # SPATIAL_ROTATION
    for j in rotations:
        lam0 = x0[layout.rotation[j]]
        conjugate = lam0 * np.array([1.0, -1.0, -1.0, -1.0]) / (lam0 @ lam0)
        relative = compose(conjugate, x0[layout.own[j]])
        Q = np.stack([compose(e, relative) for e in np.eye(4)], axis=1)
        scale = np.max(np.abs(Q))
        assert np.max(np.abs(layout.data[j, :16] - Q.ravel())) <= 1e-14 * scale


def test_touching_elements_and_their_transforms(packed):
    """The touching elements are those with a slave coordinate; each T_e is the dense T's
    block (its coordinates' rows, its z-coordinates' columns)."""
    model, c = packed
    rigid = c.rigid
    is_slave = rigid.slave_index >= 0
    expected = np.concatenate([np.any(is_slave[g.coordinate_index], axis=1)
                               for g in c.groups.all] or [np.zeros(0, dtype=bool)])
    np.testing.assert_array_equal(rigid.element_of >= 0, expected)
    np.testing.assert_array_equal(rigid.element_of[expected], np.arange(expected.sum()))
    if not rigid.active:
        return
    x = rigid.layout.fill(model.initial_coordinates.astype(float))
    T = rigid.layout.transform(x, model.nx)
    for t, (gp, i, z) in enumerate(rigid.touching):
        coords = c.groups.all[gp].coordinate_index[i]
        assert rigid.elements[t * ELEMENT_WIDTH + E_MZ] == z.size
        T_e = rigid.element_transform(gp, i, coords, x)
        np.testing.assert_allclose(T_e, T[np.ix_(coords, z)], rtol=0, atol=1e-14)


def test_orders_are_those_of_the_plain_entries(packed):
    """J's and the augmented system's orders and bands from the deduplicated entries are
    those of the plain entries (duplicates kept)."""
    model, c = packed
    t = c.topology
    nf = t.free.size
    got = orders.constraint_order(model, t.free, t.rows, t.row_of_def, t.col_of_coord,
                                  c.rigid)
    r, k = plain_constraint_entries(model, c)
    column_of_row = matching(r, k, nf)
    assert np.all(column_of_row >= 0)
    order, _, _ = bandwidth_order(column_of_row[r], k, nf)
    column_position = np.empty(nf, dtype=np.int64)
    column_position[order] = np.arange(nf)
    row_position = column_position[column_of_row]
    offsets = row_position[r] - column_position[k]
    np.testing.assert_array_equal(got[0], row_position)
    np.testing.assert_array_equal(got[1], column_position)
    assert got[2:] == (max(0, offsets.max()), max(0, -offsets.min()))
    got = orders.augmented_order(model, nf, t.n_rigid, t.row_of_def, t.col_of_coord,
                                 c.groups.all, c.groups.inertia, c.rigid)
    r, k = plain_augmented_entries(model, c)
    order, kl, ku = bandwidth_order(r, k, nf + t.n_rigid)
    position = np.empty(nf + t.n_rigid, dtype=np.int64)
    position[order] = np.arange(nf + t.n_rigid)
    np.testing.assert_array_equal(got[0], position)
    assert got[1:] == (kl, ku)


def test_stressed_stiffness_and_damping_are_the_dense_ones(packed):
    model, c = packed
    S, D = assembly.stiffness_and_damping(model)
    s = c.stressed
    np.testing.assert_array_equal(c.S, S[np.ix_(s, s)])
    np.testing.assert_array_equal(c.D, D[np.ix_(s, s)])


@pytest.mark.parametrize("rigid", [True, False])
def test_mass_entries_are_the_dense_ones(packed, rigid):
    """M's entries (and T^T M T's with the clusters) on every free pair of the augmented
    pattern and some pairs off it, against the dense M and T^T M T."""
    model, c = packed
    layout = c.rigid.layout if rigid and c.rigid.active else None
    x = model.initial_coordinates.astype(float)
    if layout is not None:
        x = layout.fill(x)
    M = assembly.Inertia(model).mass_matrix(x)
    if layout is not None:
        T = layout.transform(x, model.nx)
        M = T.T @ M @ T
    rows, columns = np.nonzero(M)
    rng = np.random.default_rng(3)
    rows = np.concatenate([rows, rng.integers(0, model.nx, 200)])
    columns = np.concatenate([columns, rng.integers(0, model.nx, 200)])
    got = sparse_packing.mass_entries_at(model, x, rows, columns, layout)
    assert np.max(np.abs(got - M[rows, columns])) <= 1e-14 * np.max(np.abs(M))


def test_one_slot_is_the_slot_of_the_arrays():
    """A sparse LU's slots looked up one by one (bisection of a list) are those of the
    array lookup, and an entry outside the pattern is refused either way."""
    model = build("stage_spatial_19dof")
    c = context(model)
    factors = sparse_packing.SparseFactors(
        model, c.groups.de_groups, [g for g in c.groups.all if id(g) in c.groups.inertia],
        c.topology.free, c.topology.rows, c.topology.row_of_def, c.topology.col_of_coord,
        c.groups.de_size, c.rigid)
    lu = factors.augmented
    dense = np.zeros((lu.n, lu.n), dtype=bool)
    pcol = lu._pcol[np.repeat(np.arange(lu.n), np.diff(lu._Ap))]
    dense[lu._Ai, pcol] = True
    rows, columns = np.nonzero(dense)
    many = lu.slot(rows, columns)
    np.testing.assert_array_equal(np.sort(many), np.arange(rows.size))
    one = [lu.slot([r], [k])[0] for r, k in zip(rows, columns, strict=True)]
    np.testing.assert_array_equal(one, many)
    r, k = np.argwhere(~dense)[0]
    for ask in (lambda: lu.slot([r], [k]), lambda: lu.slot([r, rows[0]], [k, columns[0]])):
        with pytest.raises(ValueError, match="not in the pattern"):
            ask()
