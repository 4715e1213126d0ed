"""The engine's gathers and scatters that index with unsigned integers (numba then leaves
out its test for an index from the end): their precondition, the packed indices never
negative where they are read, and the kernels against plain Python loops in the order the
signed loops took (bitwise: the same sums in the same order) and against numpy formulas.

Kernels: `deformation_rates.stress_resultants` (S e + D edot), `scatter_stress` (r -=
De^T sigma), `rigid_kernels.rigid_de` (De_z = De T_e on J's rows) and
`refinement.constraint_products` (the rigid rows J_o and columns J_o^T times d), on
manipulator_control (57 BEAMs touching rigid clusters, rigid rows) and wire_tripod, after
an evaluation at a moving state. T^T and T v have their own tests (test_condense_pair.py,
test_rigid.py); the slaves' fill and rates are held by the bits of every rigid model's
test.
"""

import numpy as np
import pytest

from flexure.core import Mechanics, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine import rigid as rg
from flexure.core.engine.data import EngineData
from flexure.core.engine.deformation_rates import scatter_stress, stress_resultants
from flexure.core.engine.refinement import constraint_products
from flexure.core.engine.rigid_kernels import rigid_de
from flexure.core.mechanics.rigid_bodies import (
    DEPENDENCIES,
    PLANAR_ROTATION,
    PLANAR_TRANSLATION,
    SPATIAL_ROTATION,
    SPATIAL_TRANSLATION,
)

MODELS = ("manipulator_control", "wire_tripod")
EW = rg.ELEMENT_WIDTH


def _evaluated(name, seed=3):
    """EngineData of the scene `name` (augmented form) after OP_RHS at a moving state."""
    model = load_scene(name)
    data = EngineData(model, augmented=True)
    rng = np.random.default_rng(seed)
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    q, qdot = q0 + 1e-4 * rng.standard_normal(q0.size), 0.05 * rng.standard_normal(q0.size)
    data.float_array("inputs")[:] = rng.standard_normal(len(model.inputs))
    y = np.concatenate([q - data.float_array("q_ref"), qdot])
    assert engine.call(data, engine.OP_RHS, y, np.zeros_like(y)) == ed.OK
    return data


def _groups(data):
    """[(n, m, k, coords (n, m), defs (n, k), de_offset, element_offset)] per group."""
    dims = data.int_array("dims")
    rows = data.int_array("groups").reshape(dims[ed.NGROUPS], -1)
    coords_all, defs_all = data.int_array("coordinate_index"), data.int_array(
        "deformation_index")
    out = []
    for row in rows:
        n, m, k = row[ed.G_COUNT], row[ed.G_M], row[ed.G_K]
        c, d = row[ed.G_COORD_OFFSET], row[ed.G_DEF_OFFSET]
        out.append((n, m, k, coords_all[c: c + n * m].reshape(n, m),
                    defs_all[d: d + n * k].reshape(n, k), row[ed.G_DE_OFFSET],
                    row[ed.G_ELEMENT_OFFSET]))
    return out


@pytest.mark.parametrize("name", MODELS)
def test_the_indices_read_unsigned_are_never_negative(name):
    """Every index the unsigned loops read is within its array: the elements' coordinates
    and deformations, the stressed deformations and their columns, the slaves' records'
    fields that their kind reads, the slaves' coordinates and the free coordinates, and the
    touching elements' terms where they are read (a coordinate's terms before its -2)."""
    data = _evaluated(name)
    nx, ne = data.float_array("x").size, data.float_array("e").size
    for _, _, _, coords, defs, _, _ in _groups(data):
        assert ((coords >= 0) & (coords < nx)).all() and ((defs >= 0) & (defs < ne)).all()
    stressed = data.int_array("stressed")
    assert ((stressed >= 0) & (stressed < ne)).all()
    columns = data.int_array("stress_columns")
    assert ((columns >= 0) & (columns < stressed.size)).all()
    for key in ("rigid_coordinates", "free"):
        assert ((data.int_array(key) >= 0) & (data.int_array(key) < nx)).all()
    slaves, fields = data.int_array("rigid_slaves"), {  # the record fields each kind reads
        SPATIAL_TRANSLATION: (1, 2, 3, 5, 6, 7, 8, 9, 10, 11),
        SPATIAL_ROTATION: (1, 2, 3, 4, 8, 9, 10, 11), PLANAR_TRANSLATION: (1, 2, 5, 6, 8),
        PLANAR_ROTATION: (1, 8)}
    assert slaves.size > 0
    for o in range(0, slaves.size, rg.SLAVE_WIDTH):
        read = slaves[o + np.array(fields[slaves[o]])]
        assert ((read >= 0) & (read < nx)).all()
    deps = data.int_array("rigid_dependencies")
    assert (deps < nx).all() and (deps >= -1).all()  # -1 tested before it is an index
    terms, weights = data.int_array("rigid_terms"), data.float_array("rigid_weights").size
    groups = _groups(data)
    for _, g, _, _, mz, _, start in _touching_rows(data):
        for a in range(groups[g][1]):
            for u in range(DEPENDENCIES):
                zl, w = terms[start + 2 * (a * DEPENDENCIES + u): start + 2 * (a * DEPENDENCIES
                                                                                 + u) + 2]
                if w == -2:
                    break
                assert 0 <= zl < mz and -1 <= w < weights


@pytest.mark.parametrize("name", MODELS)
def test_the_stresses_and_their_scatter_against_plain_loops(name):
    """sigma = S e + D edot by compressed rows, and r -= De^T sigma: bitwise a plain loop in
    the kernels' order, and within 1e-14 of the magnitudes of numpy's sums."""
    data = _evaluated(name)
    table = data.address
    e, edot = data.float_array("e"), data.float_array("edot")
    stressed, pointers = data.int_array("stressed"), data.int_array("stress_pointers")
    columns, S, D = data.int_array("stress_columns"), data.float_array("S"), \
        data.float_array("D")
    damped = data.int_array("dims")[ed.HAS_DAMPING] == 1
    sigma = stress_resultants(table).copy()
    plain = np.zeros_like(sigma)
    for a in range(stressed.size):
        s = 0.0
        for p in range(pointers[a], pointers[a + 1]):
            b = stressed[columns[p]]
            s += S[p] * e[b]
            if damped:
                s += D[p] * edot[b]
        plain[stressed[a]] = s
    assert np.array_equal(sigma, plain)
    assert np.count_nonzero(sigma) > 0
    rng = np.random.default_rng(5)
    r0 = rng.standard_normal(data.float_array("x").size)
    r = r0.copy()
    scatter_stress(table, sigma, r)
    De = data.float_array("De")
    loop, summed, scale = r0.copy(), np.zeros_like(r0), np.zeros_like(r0)
    for n, m, k, coords, defs, offset, _ in _groups(data):
        blocks = De[offset: offset + n * k * m].reshape(n, k, m)
        for i in range(n):
            for b in range(k):
                s = sigma[defs[i, b]]
                if s == 0.0:
                    continue
                for a in range(m):
                    loop[coords[i, a]] -= blocks[i, b, a] * s
        forces = np.einsum("ikm,ik->im", blocks, sigma[defs])
        np.add.at(summed, coords.ravel(), forces.ravel())
        np.add.at(scale, coords.ravel(), np.abs(forces).ravel())
    assert np.array_equal(r, loop)
    assert np.all(np.abs(r - (r0 - summed)) <= 1e-14 * (np.abs(r0) + scale) + 1e-300)


def _touching_rows(data):
    """[(J's row, element group, element, b, mz, at in rigid_de, term offset)]."""
    rows, elements = data.int_array("touching_rows"), data.int_array("rigid_elements")
    out = []
    for j in range(rows.size // 3):
        e = rows[3 * j + 1] * EW
        b, mz = rows[3 * j + 2], elements[e + rg.E_MZ]
        out.append((rows[3 * j], elements[e + rg.E_GROUP], elements[e + rg.E_ELEMENT], b, mz,
                    elements[e + rg.E_DE_OFFSET] + b * mz, elements[e + rg.E_TERM_OFFSET]))
    return out


def _transform(data, m, mz, start):
    """T_e (m, mz) of a touching element from its terms: (z column, weight) per coordinate
    until -2, a weight -1 meaning 1."""
    terms, W = data.int_array("rigid_terms"), data.float_array("rigid_weights")
    T = np.zeros((m, mz))
    for a in range(m):
        for u in range(DEPENDENCIES):
            p = start + 2 * (a * DEPENDENCIES + u)
            zl, w = terms[p], terms[p + 1]
            if w == -2:
                break
            T[a, zl] += 1.0 if w == -1 else W[w]
    return T


@pytest.mark.parametrize("name", MODELS)
def test_rigid_de_against_de_times_the_transform(name):
    """De_z = De T_e on each of J's touching rows: bitwise a plain loop over De's non-zeros
    and each coordinate's terms, and within 1e-14 of |De| |T_e| of numpy's product."""
    data = _evaluated(name)
    rows = _touching_rows(data)
    assert rows
    rigid_de(data.address)
    rde, De = data.float_array("rigid_de"), data.float_array("De")
    terms, W = data.int_array("rigid_terms"), data.float_array("rigid_weights")
    groups = _groups(data)
    for _, g, i, b, mz, at, start in rows:
        _, m, k, _, _, offset, _ = groups[g]
        row = De[offset + (i * k + b) * m: offset + (i * k + b + 1) * m]
        loop = np.zeros(mz)
        for a in range(m):
            if row[a] == 0.0:
                continue
            for u in range(DEPENDENCIES):
                p = start + 2 * (a * DEPENDENCIES + u)
                zl, w = terms[p], terms[p + 1]
                if w == -2:
                    break
                loop[zl] += row[a] * (1.0 if w == -1 else W[w])
        assert np.array_equal(rde[at: at + mz], loop)
        T = _transform(data, m, mz, start)
        assert np.all(np.abs(rde[at: at + mz] - row @ T)
                      <= 1e-14 * (np.abs(row) @ np.abs(T)) + 1e-300)


@pytest.mark.parametrize("name", MODELS)
def test_the_constraint_products_against_the_rigid_rows(name):
    """out[:nf] -= J_o^T d_o and out[nf:] -= J_o d_f with J_o (n_rigid, n_free) formed
    densely from the touching rows' De_z and the other elements' De on the rigid rows:
    within 1e-14 of the magnitudes (the bits: the models' rhs hashes, docs/benchmarks.md)."""
    data = _evaluated(name)
    table = data.address
    dims = data.int_array("dims")
    nf, n_rigid = dims[ed.NFREE], dims[ed.NRIGID]
    assert n_rigid > 0  # both models have rigid rows
    row_of_def, col_of_coord = data.int_array("row_of_deformation"), data.int_array(
        "column_of_coordinate")
    rde, De = data.float_array("rigid_de"), data.float_array("De")
    z_all, elements = data.int_array("rigid_z"), data.int_array("rigid_elements")
    J = np.zeros((n_rigid, nf))
    groups = _groups(data)
    element_of = data.int_array("rigid_element_of")
    for j, (o, _, _, _, mz, at, _) in enumerate(_touching_rows(data)):
        if o >= n_rigid:
            continue
        t = data.int_array("touching_rows")[3 * j + 1]
        z = z_all[elements[t * EW + rg.E_Z_OFFSET]:][:mz]
        for a in range(mz):
            if col_of_coord[z[a]] >= 0:
                J[o, col_of_coord[z[a]]] += rde[at + a]
    for n, m, k, coords, defs, offset, first in groups:
        for i in range(n):
            if element_of[first + i] >= 0:
                continue
            for b in range(k):
                o = row_of_def[defs[i, b]]
                if 0 <= o < n_rigid:
                    for a in range(m):
                        if col_of_coord[coords[i, a]] >= 0:
                            J[o, col_of_coord[coords[i, a]]] += De[offset + (i * k + b) * m + a]
    rng = np.random.default_rng(8)
    d, out0 = rng.standard_normal(nf + n_rigid), rng.standard_normal(nf + n_rigid)
    out = out0.copy()
    constraint_products(table, d, out)
    expected = out0 - np.concatenate([J.T @ d[nf:], J @ d[:nf]])
    scale = np.abs(out0) + np.concatenate([np.abs(J.T) @ np.abs(d[nf:]),
                                           np.abs(J) @ np.abs(d[:nf])])
    assert np.all(np.abs(out - expected) <= 1e-14 * scale + 1e-300)
    assert np.count_nonzero(J) > 0
