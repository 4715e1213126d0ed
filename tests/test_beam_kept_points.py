"""The BEAM's inertia points kept by its rates (`beam_directional.points_kernel`, slot
beam_points, `formed_rates`) and the products that read them (`beam_mass.kept_point_products`,
`kept_point_product`): the fused kernel's h and points bitwise those of the separate
`directional_kernel` and `inertia_kernel` (the same formulas, evaluated once), Dp's constant
entries as the layout says, the kept products bitwise the products from a (24, 14) Dp and
within round-off of the plain formula Dp^T Mp (f - Dp a) of the numpy reference's points;
and the engine's right-hand side, a refinement's products and the Jacobian on
manipulator_control bitwise those with the points not kept (group field points_offset -1).

The kernels run as plain Python (`py_func`): the bitwise comparisons hold there as compiled
(IEEE double arithmetic, no contraction), and the helpers compile small.
"""

import numpy as np
import pytest

from flexure.core import Mechanics, load_scene
from flexure.core.elements import beam, beam_directional, beam_kernels, beam_mass
from flexure.core.elements.beam_directional import ACC_AT, POINTS_WIDTH
from flexure.core.elements.beam_kernels import VECTORS_AT
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData

COUNT = 6
ROWS = (3, 9, 12, 15, 18, 21)  # Dp's rows of the kept blocks, and their Euler parameters
COLUMNS = (3, 10, 3, 3, 10, 10)


def plain(kernel):
    return getattr(kernel, "py_func", kernel)


@pytest.fixture(scope="module")
def beams():
    rng = np.random.default_rng(20261202)
    x0, x = beam.random_coordinates(rng, COUNT)
    ref = beam.reference(x0, rng.normal(size=(COUNT, 3)),
                         properties={"Ip_A": rng.uniform(0.01, 0.1, COUNT)})
    v = rng.normal(size=x.shape) * rng.choice([1e-3, 1.0, 1e3], size=x.shape)
    props = {"rho_A": rng.uniform(0.5, 2.0, COUNT), "rho_Iy": rng.uniform(1e-4, 1e-3, COUNT),
             "rho_Iz": rng.uniform(1e-4, 1e-3, COUNT)}
    return x, v, ref, beam.pack_reference(ref), beam.inertia_matrix(ref, props)


def kept(x, v, packed):
    """h (n, 6) and the kept points (n, POINTS_WIDTH) of `points_kernel`."""
    h, points = np.full((x.shape[0], 6), np.nan), np.full((x.shape[0], POINTS_WIDTH), np.nan)
    for i in range(x.shape[0]):
        plain(beam_directional.points_kernel)(x[i], v[i], packed[i], h[i], points[i])
    return h, points


def separate(x, v, packed):
    """h, Dp (n, 24, 14) and acc (n, 24) of `directional_kernel` and `inertia_kernel`."""
    n = x.shape[0]
    h, p = np.full((n, 6), np.nan), np.full((n, 24), np.nan)
    Dp, acc = np.full((n, 24, 14), np.nan), np.full((n, 24), np.nan)
    for i in range(n):
        plain(beam_directional.directional_kernel)(x[i], v[i], packed[i], h[i])
        plain(beam_kernels.inertia_kernel)(x[i], v[i], packed[i], 2, p[i], Dp[i], acc[i])
    return h, Dp, acc


def test_the_fused_kernel_is_the_two_kernels_bitwise(beams):
    """h, Dp's six blocks and acc of `points_kernel` equal those of `directional_kernel`
    and `inertia_kernel` (order 2) bit for bit; Dp's other entries are 1 on the
    translations' points at their coordinates and 0 elsewhere, as the layout leaves them."""
    x, v, _, packed, _ = beams
    h, points = kept(x, v, packed)
    h_ref, Dp, acc = separate(x, v, packed)
    assert np.all(np.isfinite(points[:, :VECTORS_AT])) and np.any(points[:, ACC_AT:] != 0.0)
    assert np.array_equal(h, h_ref)
    assert np.array_equal(points[:, ACC_AT:VECTORS_AT], acc)
    constant = Dp.copy()
    for j, (row, col) in enumerate(zip(ROWS, COLUMNS, strict=True)):
        block = points[:, 12 * j: 12 * (j + 1)].reshape(-1, 4, 3).transpose(0, 2, 1)
        assert np.array_equal(block, Dp[:, row: row + 3, col: col + 4])
        constant[:, row: row + 3, col: col + 4] = 0.0
    unit = np.zeros((24, 14))
    unit[0:3, 0:3] = unit[6:9, 7:10] = np.eye(3)
    assert np.array_equal(constant, np.broadcast_to(unit, constant.shape))


def test_the_kept_rotations_are_the_kernels(beams):
    """`kept_deformations_kernel` gives `deformations_kernel`'s e and De (order 1) bit for
    bit and keeps Dp's blocks 2 ... 5 as `points_kernel` gives them; `kept_points_kernel`
    then completes them to `points_kernel`'s h and points, bit for bit; the node vectors
    it kept are the reference's section axes n_z'^p, n_z'^q, n_y'^p, n_y'^q (`beam.
    inertia_points`, to 1e-14 of |lambda|^2)."""
    x, v, ref, packed, _ = beams
    h, points = kept(x, v, packed)
    reference_points, _ = beam.inertia_points(x, ref, order=1)
    for i in range(x.shape[0]):
        e, De, D2e = np.full(6, np.nan), np.full((6, 14), np.nan), np.zeros((6, 14, 14))
        plain(beam_kernels.deformations_kernel)(x[i], packed[i], 1, e, De, D2e)
        e_kept, De_kept = np.full(6, np.nan), np.full((6, 14), np.nan)
        rotations = np.full(POINTS_WIDTH, np.nan)
        plain(beam_kernels.kept_deformations_kernel)(x[i], packed[i], e_kept, De_kept,
                                                      rotations)
        assert np.array_equal(e_kept, e) and np.array_equal(De_kept, De)
        assert np.array_equal(rotations[24:72], points[i, 24:72])
        assert np.all(np.isnan(rotations[:24])) and np.all(np.isnan(rotations[72:96]))
        h_kept = np.full(6, np.nan)
        plain(beam_directional.kept_points_kernel)(x[i], v[i], packed[i], h_kept, rotations)
        assert np.array_equal(h_kept, h[i])
        assert np.array_equal(rotations[:96], points[i, :96])
        axes = reference_points[i].reshape(8, 3)[[5, 7, 4, 6]]  # n_z'^p, n_z'^q, ...
        vectors = rotations[VECTORS_AT:].reshape(4, 3)
        assert np.max(np.abs(vectors - axes)) <= 1e-14 * np.max(np.abs(x[i]) ** 2)


def test_the_fused_kernel_is_the_reference_points(beams):
    """Dp and acc of the kept points against the numpy reference `beam.inertia_points`
    (Dp, and (D2p v) v from its constant D2p), to 1e-13 of their magnitudes."""
    x, v, ref, packed, _ = beams
    _, points = kept(x, v, packed)
    _, Dp, D2p = beam.inertia_points(x, ref, order=2)
    acc = np.einsum("npij,ni,nj->np", D2p, v, v)
    magnitude = np.einsum("npij,ni,nj->np", np.abs(D2p), np.abs(v), np.abs(v))
    assert np.all(np.abs(points[:, ACC_AT:VECTORS_AT] - acc) <= 1e-13 * magnitude + 1e-300)
    for j, (row, col) in enumerate(zip(ROWS, COLUMNS, strict=True)):
        block = points[:, 12 * j: 12 * (j + 1)].reshape(-1, 4, 3).transpose(0, 2, 1)
        expected = Dp[:, row: row + 3, col: col + 4]
        assert np.max(np.abs(block - expected)) <= 1e-13 * np.max(np.abs(expected))


def test_the_kept_products_are_the_dense_ones_bitwise(beams):
    """`kept_point_products` and `kept_point_product` equal `beam_point_products` and
    `beam_point_product` with the inertia kernel's Dp bit for bit, and Dp^T Mp (f - Dp a)
    and Dp^T Mp f of the numpy reference's Dp to 1e-13 of the largest term."""
    x, v, ref, packed, Mp = beams
    rng = np.random.default_rng(7)
    _, points = kept(x, v, packed)
    _, Dp, _ = separate(x, v, packed)
    _, Dp_ref = beam.inertia_points(x, ref, order=1)
    for i in range(x.shape[0]):
        f, a = rng.normal(size=24), rng.normal(size=14)
        mass = Mp[i].ravel()
        results = []
        for product, D in ((beam_mass.kept_point_products, points[i]),
                           (beam_mass.beam_point_products, Dp[i])):
            a_io, point, w, out, w0 = a.copy(), f.copy(), np.zeros(24), np.zeros(14), np.zeros(24)
            plain(product)(mass, D, a_io, point, w, out, f.copy(), w0)
            results.append((out, a_io, point, w, w0))
        for single, D in ((beam_mass.kept_point_product, points[i]),
                          (beam_mass.beam_point_product, Dp[i])):
            point, w, out = f.copy(), np.zeros(24), np.zeros(14)
            plain(single)(mass, D, a, point, w, out)
            results.append((out, point, w))
        for got, expected in zip(results[0], results[1], strict=True):
            assert np.array_equal(got, expected)
        for got, expected in zip(results[2], results[3], strict=True):
            assert np.array_equal(got, expected)
        D = Dp_ref[i]
        scale = np.max(np.abs(D)) ** 2 * np.max(np.abs(Mp[i])) * (
            np.max(np.abs(f)) + np.max(np.abs(D)) * np.max(np.abs(a)))
        assert np.max(np.abs(results[0][0] - D.T @ Mp[i] @ (f - D @ a))) <= 1e-13 * scale
        assert np.max(np.abs(results[0][1] - D.T @ Mp[i] @ f)) <= 1e-13 * scale
        assert np.array_equal(results[2][0], results[0][0])


def test_packing_keeps_the_beams_points():
    """manipulator_control: points_offset on its BEAM group alone, slot beam_points of
    POINTS_WIDTH per element of it; after a moving OP_RHS dims points_current and
    rotations_kept are 1, after the kinematics alone points_current is 0."""
    model = load_scene("manipulator_control")
    data = EngineData(model, augmented=True)
    dims = data.int_array("dims")
    groups = data.int_array("groups").reshape(-1, ed.G_WIDTH)[: dims[ed.NGROUPS]]
    marked = np.flatnonzero(groups[:, ed.G_POINTS_OFFSET] >= 0)
    assert marked.size == 1 and groups[marked[0], ed.G_POINT_BLOCKS] == 1
    assert data.float_array("beam_points").size == POINTS_WIDTH * groups[marked[0], ed.G_COUNT]
    y = _state(model, data, np.random.default_rng(3))
    assert engine.call(data, engine.OP_RHS, y, np.zeros_like(y)) == ed.OK
    assert dims[ed.POINTS_CURRENT] == 1 and dims[ed.ROTATIONS_KEPT] == 1
    q = y[: y.size // 2] + data.float_array("q_ref")
    assert engine.call(data, engine.OP_CONFIGURATION, q) == ed.OK
    assert dims[ed.POINTS_CURRENT] == 0


def _state(model, data, rng):
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    q, qdot = q0 + 1e-4 * rng.standard_normal(q0.size), 0.05 * rng.standard_normal(q0.size)
    return np.concatenate([q - data.float_array("q_ref"), qdot])


@pytest.mark.parametrize("rigid", [True, False])
def test_the_rhs_and_jacobian_are_those_without_kept_points(rigid):
    """OP_RHS at two states 1e-4 apart (the second refined with the first's factors: its
    products read the kept points), then OP_JACOBIAN, with velocities 0.05 and inputs of 1:
    bitwise equal with the points kept and with group field points_offset cleared."""
    model = load_scene("manipulator_control")
    results = []
    for keep in (True, False):
        data = EngineData(model, augmented=True, rigid=rigid)
        dims = data.int_array("dims")
        groups = data.int_array("groups").reshape(-1, ed.G_WIDTH)[: dims[ed.NGROUPS]]
        if not keep:
            groups[:, ed.G_POINTS_OFFSET] = -1
        data.float_array("inputs")[:] = 1.0
        rng = np.random.default_rng(5)
        first, second = _state(model, data, rng), _state(model, data, rng)
        out = []
        for y in (first, second):
            ydot = np.zeros_like(y)
            assert engine.call(data, engine.OP_RHS, y, ydot) == ed.OK
            out.append(ydot)
        if keep:
            assert dims[ed.POINTS_CURRENT] == 1
        jac = np.zeros(second.size ** 2)
        assert engine.call(data, engine.OP_JACOBIAN, second, jac) == ed.OK
        results.append((*out, jac))
    assert np.any(results[0][1] != 0.0)
    for got, expected in zip(results[0], results[1], strict=True):
        assert np.array_equal(got, expected)

