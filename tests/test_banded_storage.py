"""The banded LU's compact storage (core/numerics/banded.py): the same factors, pivots and
solves as the dense (n, n) storage, bit for bit (the same products in the same order: the
property under test), and both within a backward-stable solve's bound of
scipy.linalg.solve_banded; the storage sizes the engine packs; the sparse LU's fallback
scattered into the compact storage puts every entry where the dense one has it."""

import numpy as np
import pytest
from scipy.linalg import solve_banded

from flexure.core import load_scene
from flexure.core.engine import data as ed
from flexure.core.engine.data import EngineData
from flexure.core.numerics import banded, sparse_lu

EPS = np.finfo(float).eps


def random_band(rng, n, kl, ku, pivoting):
    """A random (n, n) matrix zero outside kl sub- and ku super-diagonals; with `pivoting`
    its diagonal is small against the entries below it (1e-3), so that partial pivoting
    interchanges rows at most steps (where there are rows below: kl > 0)."""
    a = rng.standard_normal((n, n))
    i, j = np.indices((n, n))
    a[(i - j > kl) | (j - i > ku)] = 0.0
    if pivoting and kl > 0:
        a[np.arange(n), np.arange(n)] *= 1e-3
    return a


def compact(a, kl, ku):
    """The compact storage of a, by a plain loop: entry (i, j) at i (2 kl + ku) + kl + j."""
    n = a.shape[0]
    step = 2 * kl + ku
    out = np.zeros(n * (step + 1))
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + kl + ku + 1)):
            out[i * step + kl + j] = a[i, j]
    return out


def band_of(storage, n, kl, ku, step, shift):
    """The (n, n) matrix of the band entries (row i, columns i - kl to i + kl + ku) read from
    a storage with entry (i, j) at storage[i step + shift + j]; zero elsewhere."""
    out = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + kl + ku + 1)):
            out[i, j] = storage[i * step + shift + j]
    return out


def ab_form(a, kl, ku):
    """a in scipy.linalg.solve_banded's (kl + ku + 1, n) diagonal-ordered form."""
    n = a.shape[0]
    ab = np.zeros((kl + ku + 1, n))
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + ku + 1)):
            ab[ku + i - j, j] = a[i, j]
    return ab


@pytest.mark.parametrize("n, kl, ku", [(10, 1, 1), (40, 3, 5), (60, 8, 2), (33, 0, 4),
                                       (128, 14, 14), (200, 14, 6)])
@pytest.mark.parametrize("pivoting", [False, True])
def test_compact_storage_factors_and_solves_as_the_dense_one(n, kl, ku, pivoting):
    rng = np.random.default_rng(7 * n + kl + 100 * ku + pivoting)
    a = random_band(rng, n, kl, ku, pivoting)
    assert banded.storage_size(n, kl, ku) == n * (2 * kl + ku + 1) < n * n
    dense, small = a.ravel().copy(), compact(a, kl, ku)
    piv_dense, piv_small = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
    ratio_dense = banded.factor(dense, n, piv_dense, kl, ku)
    ratio_small = banded.factor(small, n, piv_small, kl, ku)
    assert ratio_small == ratio_dense > 0.0
    assert np.array_equal(piv_small, piv_dense)
    if pivoting and kl > 0:  # the case exercises the interchanges
        assert np.any(piv_small != np.arange(n))
    step = 2 * kl + ku
    assert np.array_equal(band_of(small, n, kl, ku, step, kl), band_of(dense, n, kl, ku, n, 0))
    b = rng.standard_normal(n)
    cond = np.linalg.cond(a)
    for transposed, solve in ((False, banded.solve), (True, banded.solve_transposed)):
        z_dense, z_small = b.copy(), b.copy()
        solve(dense, n, piv_dense, kl, ku, z_dense)
        solve(small, n, piv_small, kl, ku, z_small)
        assert np.array_equal(z_small, z_dense)
        matrix, lower, upper = (a.T, ku, kl) if transposed else (a, kl, ku)
        expected = solve_banded((lower, upper), ab_form(matrix, lower, upper), b)
        # the forward error bound of two backward-stable solves: cond(A) eps |z|, times 10
        assert np.max(np.abs(z_small - expected)) <= 10 * cond * EPS * np.max(np.abs(expected))


def test_a_singular_band_has_a_zero_pivot_ratio_in_compact_storage():
    a = np.diag([1.0, 2.0, 0.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    a[3, 2] = a[2, 1] = 0.0
    assert banded.factor(compact(a, 1, 1), 8, np.zeros(8, dtype=np.int64), 1, 1) == 0.0


@pytest.mark.parametrize("n, kl, ku, size", [(7, 6, 6, 49), (10, 3, 3, 100), (10, 2, 3, 80),
                                             (512, 14, 14, 512 * 43), (0, 0, 0, 0),
                                             (1, 0, 0, 1)])
def test_storage_size_is_compact_only_where_smaller(n, kl, ku, size):
    """n rows of 2 kl + ku + 1, or n * n when that is no more (then the dense storage)."""
    assert banded.storage_size(n, kl, ku) == size


def test_the_engine_packs_the_cantilevers_band_compact():
    """The 16-BEAM cantilever: J (sparse, its band kept for the fallback) and the augmented
    system (banded) each in n (2 kl + ku + 1) entries, under half of n^2."""
    from examples.benchmarks.spatial import spatial_cantilever

    data = EngineData(spatial_cantilever(16))
    dims = data.int_array("dims")
    nf, na = dims[ed.NFREE], dims[ed.NFREE] + dims[ed.NRIGID]
    j_width, a_width = 2 * dims[ed.J_KL] + dims[ed.J_KU] + 1, 2 * dims[ed.A_KL] + dims[ed.A_KU] + 1
    assert data.float_array("lu").size == nf * j_width < nf * nf / 2
    assert data.float_array("augmented").size == na * a_width < na * na / 2


def scatter_both(ints, floats, rows, columns, n, kl, ku, scatter=sparse_lu.scatter_rows):
    """The sparse matrix (its values made 1, 2, ... so that every entry is told apart) into
    the dense storage (row step n) and into the compact one (`sparse_lu.scatter_rows`, or
    transposed for J from the LU of J^T): (dense (n, n), compact as
    read back by `band_of`)."""
    floats = floats.copy()
    values = sparse_lu.matrix_values(ints, floats)
    values[:] = np.arange(1, values.size + 1)
    dense = np.zeros(n * n)
    scatter(ints, floats, dense, rows, columns, n, 0)
    step = 2 * kl + ku
    small = np.zeros(n * (step + 1))
    scatter(ints, floats, small, rows, columns, step, kl)
    return dense.reshape(n, n), band_of(small, n, kl, ku, step, kl), values.size


@pytest.mark.parametrize("scene", ["cantilever16", "manipulator_control"])
def test_the_sparse_fallback_scatters_inside_the_band(scene):
    """Every entry of the sparse LUs' patterns lies in the band of the banded order (kl, ku
    of dims), so the fallback's compact storage holds the matrix the dense storage would:
    J's and the augmented system's (the manipulator's augmented band, kl = ku = 96 of 233,
    is packed dense: there the check is that its pattern is inside the band)."""
    if scene == "cantilever16":
        from examples.benchmarks.spatial import spatial_cantilever

        model = spatial_cantilever(16)
    else:
        model = load_scene(scene)
    data = EngineData(model, sparse=True)
    dims = data.int_array("dims")
    assert dims[ed.J_SPARSE] == dims[ed.A_SPARSE] == 1
    nf, na = dims[ed.NFREE], dims[ed.NFREE] + dims[ed.NRIGID]
    systems = [("j_sparse", "j_sparse_values", "j_row_position", "j_column_position", nf,
                dims[ed.J_KL], dims[ed.J_KU],
                lambda *scatter_args: sparse_lu.scatter_rows(*scatter_args, True)),
               ("aug_sparse", "aug_sparse_values", "augmented_position",
                "augmented_position", na, dims[ed.A_KL], dims[ed.A_KU], sparse_lu.scatter_rows)]
    compact_ones = 0
    for ints, floats, rows, columns, n, kl, ku, scatter in systems:
        dense, small, count = scatter_both(data.int_array(ints), data.float_array(floats),
                                           data.int_array(rows), data.int_array(columns), n,
                                           kl, ku, scatter)
        assert np.count_nonzero(dense) == count  # each entry in its own place
        assert np.array_equal(band_of(dense.ravel(), n, kl, ku, n, 0), dense)  # in the band
        if banded.storage_size(n, kl, ku) < n * n:
            compact_ones += 1
            assert np.array_equal(small, dense)
    assert compact_ones >= 1  # J's, at least: the case under test
