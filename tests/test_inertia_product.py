"""rhs_f - M_ff w_f without the mass (core/engine/inertia_product.py) against the assembled path.

The reference is the augmented system as `motion.evaluate` builds it, read back: after an
evaluation at a random state (moving or at rest, random inputs), the force before the
inertia r = f - De^T sigma_c is formed again as `evaluate` forms it, `inertia_forces` assembles
the mass block and the point forces, and rhs_f = T^T (r - M c) (r on the free coordinates
without clusters) is condensed as there; A is read out of its band or sparse storage into a
dense matrix. Then, for random accelerations w_f of the evaluation's size:

    force_minus_mass(w_f) = rhs_f - A_ff w_f

to 1e-14 of max |rhs_f| + max |A_ff w_f| (the same products summed in another order, through
T^T instead of T_e: at most 6e-16 seen), and at the evaluation's own solution [xddot_f;
lambda] of A, force_minus_mass(xddot_f) = A_fo lambda (J_o^T lambda: zero without rigid
rows) to 1e-12 of the same scale (the LU's residual: at most 2e-15 seen). The scale holds
max |A_ff w_f| as well as max |rhs_f| because w_f is of the solution's size (1e10 m/s^2 on
the stiff cantilever at a random state), where M_ff w_f is as large as rhs_f.

Models: the 16-BEAM spatial cantilever (the BEAMs' closed form), manipulator_control (57
BEAMs touching rigid clusters, lumped masses on the masters), the same with massive rigid
beams (22 folded clusters), stage_planar_3dof under gravity (planar clusters),
stage_spatial_1dof (a folded cluster, rigid rows), truss_1dof_x (lumped masses only) and
wire_tripod (lumped masses, clusters, rigid rows); the banded and the sparse storage of A.
The kernels it is made of against numpy: the BEAM's closed form
(`beam_mass.beam_point_product`, its structure check `beam_blocks_only`) and the generic
`element_product`, on random elements; the group field point_blocks, which takes the closed
form without that check, against the groups' types and masses, and the BEAM's inertia
kernel's Dp against the check at random states.
"""

import numpy as np
import pytest
from test_beam_mass import beam_elements
from test_engine import scene_with_gravity
from test_point_masses import element
from test_rigid_inertia import massive_manipulator

from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import Mechanics, load_scene
from flexure.core.elements import beam, beam_kernels
from flexure.core.elements.beam_mass import (
    PATTERN,
    beam_blocks_only,
    beam_point_product,
    beam_point_products,
)
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine import slots as slot
from flexure.core.engine.actuators import port_values
from flexure.core.engine.data import EngineData
from flexure.core.engine.deformation_rates import scatter_stress, stress_resultants
from flexure.core.engine.factors import add_rigid_rows, augmented_matrix
from flexure.core.engine.inertia_product import (
    element_product,
    element_products,
    force_minus_mass,
    forces_and_products,
)
from flexure.core.engine.motion import inertia_forces
from flexure.core.engine.operations import OP_RIGID_CONDENSE, run
from flexure.core.engine.ports import add_input_forces
from flexure.core.mechanics import assembly
from flexure.core.numerics import sparse_lu
from flexure.core.numerics.dense import copy
from flexure.core.numerics.jit import kernel

_i, _f = slot.int_array, slot.float_array

MODELS = {
    "spatial_cantilever_16": lambda: spatial_cantilever(16),
    "manipulator_control": lambda: load_scene("manipulator_control"),
    "manipulator_massive": massive_manipulator,
    "stage_planar_3dof_gravity": lambda: scene_with_gravity("stage_planar_3dof", [0.0, -9.81]),
    "stage_spatial_1dof": lambda: load_scene("stage_spatial_1dof"),
    "truss_1dof_x": lambda: load_scene("truss_1dof_x"),
    "wire_tripod": lambda: load_scene("wire_tripod"),
}


@kernel
def force_before_inertia(table, r):
    """r (NX,) = f - De^T sigma_c at the last evaluation's state, as `motion.evaluate` forms
    it before the inertia: the constant loads, the inputs' forces, the stress resultants."""
    copy(r, _f(table, slot.CONST_FORCE))
    add_input_forces(_i(table, slot.INPUT_PORTS), port_values(table), _f(table, slot.X), r)
    scatter_stress(table, stress_resultants(table), r)


@kernel
def assembled(table, moving, r_in, total, rhs_f):
    """The augmented system (its mass block and rigid rows) into its storage, cleared first,
    and rhs_f (n_free,) from the force r_in (NX,) with the inertia's point forces, as
    `motion.evaluate` (in slot force, where the BEAMs' closed form puts them)."""
    dims = _i(table, slot.DIMS)
    nf = dims[ed.NFREE]
    r = _f(table, slot.FORCE)
    copy(r, r_in)
    A = augmented_matrix(table)
    na = nf + dims[ed.NRIGID]
    inertia_forces(table, _f(table, slot.X), _f(table, slot.XDOT), moving, r, A, na)
    add_rigid_rows(table, A, na)
    if dims[ed.NSLAVES] > 0:
        rigid_force = _f(table, slot.RIGID_FORCE)
        for a in range(dims[ed.NX]):
            total[a] = r[a] + rigid_force[a]
        run(table, OP_RIGID_CONDENSE, total.ctypes.data, rhs_f.ctypes.data, 0.0)
    else:
        free = _i(table, slot.FREE)
        for a in range(nf):
            rhs_f[a] = r[free[a]]


def dense_augmented(data):
    """The augmented matrix (na, na) as last assembled, out of its sparse or band storage."""
    dims = data.int_array("dims")
    na = dims[ed.NFREE] + dims[ed.NRIGID]
    dense = np.zeros(na * na)
    if dims[ed.A_SPARSE] == 1:
        order = np.arange(na, dtype=np.int64)
        sparse_lu.scatter_dense(data.int_array("aug_sparse"),
                                data.float_array("aug_sparse_values"), dense, order, order)
        return dense.reshape(na, na)
    band, position = data.float_array("augmented"), data.int_array("augmented_position")
    kl, ku = dims[ed.A_KL], dims[ed.A_KU]
    step, shift = (na, 0) if band.size == na * na else (2 * kl + ku, kl)
    for i in range(na):
        for j in range(na):
            offset = position[j] - position[i]
            if -kl <= offset <= kl + ku:
                dense[i * na + j] = band[position[i] * step + shift + position[j]]
    return dense.reshape(na, na)


@pytest.fixture(scope="module", params=[(name, sparse) for name in MODELS
                                        for sparse in (False, True)],
                ids=lambda p: f"{p[0]}-{'sparse' if p[1] else 'banded'}")
def case(request):
    """(model, EngineData in the augmented form with A banded or sparse, q0)."""
    name, sparse = request.param
    model = MODELS[name]()
    data = EngineData(model, augmented=True, sparse=sparse)
    return model, data, Mechanics(model).kinematics.dofs_of(model.initial_coordinates)


@pytest.mark.parametrize("moving", [True, False], ids=["moving", "at-rest"])
def test_force_minus_mass_matches_the_assembled_system(case, moving):
    model, data, q0 = case
    dims = data.int_array("dims")
    nx, nf, n_rigid = dims[ed.NX], dims[ed.NFREE], dims[ed.NRIGID]
    rng = np.random.default_rng(7)
    for _ in range(2):
        q = q0 + 1e-4 * rng.standard_normal(q0.size)
        qdot = 0.05 * rng.standard_normal(q0.size) if moving else np.zeros(q0.size)
        data.float_array("inputs")[:] = rng.standard_normal(len(model.inputs))
        assert engine.call(data, engine.OP_ACCELERATIONS, q, qdot) == ed.OK
        solution = data.float_array("augmented_rhs")[: nf + n_rigid].copy()
        table = data.address
        r0, total, rhs_f = np.zeros(nx), np.zeros(nx), np.zeros(nf)
        force_before_inertia(table, r0)
        assembled(table, moving, r0, total, rhs_f)
        A = dense_augmented(data)
        x, xdot = data.float_array("x"), data.float_array("xdot")
        a, out = np.zeros(nx), np.zeros(nf)
        # the evaluation's own solution: rhs_f - A_ff xddot_f = A_fo lambda
        xddot_f, lam = solution[:nf], solution[nf:]
        assert force_minus_mass(table, x, xdot, moving, r0, xddot_f, a, total, out) == ed.OK
        scale = np.max(np.abs(rhs_f)) + np.max(np.abs(A[:nf, :nf] @ xddot_f))
        assert np.max(np.abs(out - A[:nf, nf:] @ lam)) <= 1e-12 * scale
        # random accelerations of the solution's size
        for _ in range(3):
            w_f = np.max(np.abs(xddot_f)) * rng.standard_normal(nf)
            assert force_minus_mass(table, x, xdot, moving, r0, w_f, a, total, out) == ed.OK
            expected = rhs_f - A[:nf, :nf] @ w_f
            scale = np.max(np.abs(rhs_f)) + np.max(np.abs(A[:nf, :nf] @ w_f))
            assert np.max(np.abs(out - expected)) <= 1e-14 * scale
            # the accelerations on x: w_f on the free coordinates, zero on the fixed
            assert np.array_equal(a[data.int_array("free")], w_f)


@pytest.mark.parametrize("moving", [True, False], ids=["moving", "at-rest"])
def test_forces_and_products_is_two_element_passes_in_one(case, moving):
    """The one pass's two sums, the element masses' forces at a = 0 and the forces less the
    inertia at a, are each `element_products`' (checked above against the assembled system)
    bit for bit: the same products in the same order, the points evaluated once."""
    model, data, q0 = case
    nx = data.int_array("dims")[ed.NX]
    rng = np.random.default_rng(11)
    q = q0 + 1e-4 * rng.standard_normal(q0.size)
    qdot = 0.05 * rng.standard_normal(q0.size) if moving else np.zeros(q0.size)
    assert engine.call(data, engine.OP_ACCELERATIONS, q, qdot) == ed.OK
    table, x, xdot = data.address, data.float_array("x"), data.float_array("xdot")
    a = rng.standard_normal(nx)
    forces, total = rng.standard_normal(nx), rng.standard_normal(nx)
    forces_ref, total_ref = forces.copy(), total.copy()
    forces_and_products(table, x, xdot, moving, a, forces, total)
    element_products(table, x, xdot, moving, True, np.zeros(nx), forces_ref)
    element_products(table, x, xdot, moving, True, a, total_ref)
    assert np.array_equal(forces, forces_ref)
    assert np.array_equal(total, total_ref)


def test_force_minus_mass_refuses_a_nonfinite_acceleration():
    """A NaN in w_f comes back as NONFINITE_RESULT, not as a force."""
    model = load_scene("truss_1dof_x")
    data = EngineData(model, augmented=True)
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    assert engine.call(data, engine.OP_ACCELERATIONS, q0, np.zeros(q0.size)) == ed.OK
    nx, nf = data.int_array("dims")[ed.NX], data.int_array("dims")[ed.NFREE]
    w_f = np.zeros(nf)
    w_f[-1] = np.nan
    status = force_minus_mass(data.address, data.float_array("x"), data.float_array("xdot"),
                              False, np.zeros(nx), w_f, np.zeros(nx), np.zeros(nx), np.zeros(nf))
    assert status == ed.NONFINITE_RESULT


def test_beam_point_product():
    """The BEAM's closed form: point - Dp a, w = Mp (point - Dp a) and Dp^T w against numpy
    to round-off (1e-13 of each one's largest entry) for random BEAMs (poses, y' axes,
    section masses), and the same through the generic `element_product`."""
    _, Dps, Mps = beam_elements(20, seed=3)
    rng = np.random.default_rng(4)
    for Dp, Mp in zip(Dps, Mps, strict=True):
        assert beam_blocks_only(Dp)
        a_e, f = rng.standard_normal(14), rng.standard_normal(24)
        points = f - Dp @ a_e
        forces = Mp @ points
        expected = Dp.T @ forces
        for product in ("beam", "generic"):
            point, w, out = f.copy(), np.full(24, np.nan), np.full(14, np.nan)
            if product == "beam":
                beam_point_product(Mp.ravel(), Dp, a_e, point, w, out)
            else:
                element_product(Mp.ravel(), PATTERN, 24, 14, Dp, a_e, point, w, out)
            for got, want in ((point, points), (w, forces), (out, expected)):
                assert np.max(np.abs(got - want)) <= 1e-13 * np.max(np.abs(want)), product


def test_beam_point_products_are_two_calls_in_one():
    """The fused kernel (`forces_and_products`' BEAMs) against two `beam_point_product`
    calls, at a and at a = 0 from the same points, bit for bit (array_equal: a zero's sign
    aside) for random BEAMs; a is overwritten with the product at a = 0."""
    _, Dps, Mps = beam_elements(20, seed=8)
    rng = np.random.default_rng(9)
    for Dp, Mp in zip(Dps, Mps, strict=True):
        a_e, f = rng.standard_normal(14), rng.standard_normal(24)
        point, w, out = f.copy(), np.full(24, np.nan), np.full(14, np.nan)
        beam_point_product(Mp.ravel(), Dp, a_e, point, w, out)
        point0, w0, out0 = f.copy(), np.full(24, np.nan), np.full(14, np.nan)
        beam_point_product(Mp.ravel(), Dp, np.zeros(14), point0, w0, out0)
        fused = (f.copy(), np.full(24, np.nan), np.full(14, np.nan), f.copy(),
                 np.full(24, np.nan))
        a = a_e.copy()
        beam_point_products(Mp.ravel(), Dp, a, *fused)
        for got, want in zip((fused[0], fused[1], fused[2], fused[3], fused[4], a),
                             (point, w, out, point0, w0, out0), strict=True):
            assert np.all(np.isfinite(got)) and np.array_equal(got, want)
        assert not np.array_equal(out, out0)  # a is not zero: two different products


def test_beam_blocks_only_refuses_a_nonzero_outside_its_block():
    """A non-zero outside its point's block (r^p on lambda_p, n_y'^q on x_q, l0 n_x'^p on
    lambda_q, n_z'^q on x_p) fails the check; a zero inside a block passes."""
    _, Dps, _ = beam_elements(1, seed=5)
    for row, column in ((0, 4), (19, 8), (4, 11), (23, 0)):
        Dp = Dps[0].copy()
        Dp[row, column] = 1e-300
        assert not beam_blocks_only(Dp)
    Dp = Dps[0].copy()
    Dp[0, 0] = 0.0
    assert beam_blocks_only(Dp)


@pytest.mark.parametrize("P, m", [(24, 14), (9, 4), (5, 17)])
def test_element_product(P, m):
    """Any element: point - Dp a, Mp over its pattern and Dp^T w against numpy, to 1e-13 of
    each one's largest entry, for a random symmetric Mp on a pattern and a Dp with zeros."""
    Mp, pattern, Dp = element(P, m, seed=P * m)
    rng = np.random.default_rng(6)
    a_e, f = rng.standard_normal(m), rng.standard_normal(P)
    a_e[1] = 0.0  # a fixed coordinate's
    point, w, out = f.copy(), np.full(P, np.nan), np.full(m, np.nan)
    element_product(Mp, pattern, P, m, Dp, a_e, point, w, out)
    M = Mp.reshape(P, P)
    points = f - Dp @ a_e
    for got, want in ((point, points), (w, M @ points), (out, Dp.T @ M @ points)):
        assert np.max(np.abs(got - want)) <= 1e-13 * np.max(np.abs(want))


def test_beam_kernel_points_have_the_blocks_at_every_state():
    """What group field point_blocks promises for a group of BEAMs: the BEAM's inertia kernel
    (run as plain Python) writes zero on every entry of Dp outside its point's block,
    whatever the state and order (Dp filled with NaN first: an entry left unwritten fails
    the check), so `beam_blocks_only` holds without being asked element by element."""
    rng = np.random.default_rng(6)
    x0, x = beam.random_coordinates(rng, 8)
    packed = beam.pack_reference(beam.reference(x0, rng.standard_normal((8, 3))))
    kernel_py = getattr(beam_kernels.inertia_kernel, "py_func", beam_kernels.inertia_kernel)
    for n in range(8):
        for order in (1, 2):
            p, Dp, acc = np.full(24, np.nan), np.full((24, 14), np.nan), np.full(24, np.nan)
            kernel_py(x[n], rng.standard_normal(14), packed[n], order, p, Dp, acc)
            assert beam_blocks_only(Dp)
            assert np.count_nonzero(Dp) > 24  # the blocks are filled: not a Dp of zeros


@pytest.mark.parametrize("name", ["manipulator_control", "manipulator_massive",
                                  "spatial_cantilever_16", "wire_tripod"])
def test_point_blocks_marks_the_groups_of_beams(name):
    """Packing sets point_blocks on exactly the inertia groups whose elements are BEAMs
    (type name) with the BEAM's full mass pattern (Mp's non-zeros, from the model's own
    element masses): the groups `element_products` takes through the closed form."""
    model = MODELS[name]()
    data = EngineData(model, augmented=True)
    dims = data.int_array("dims")
    groups = data.int_array("groups").reshape(-1, ed.G_WIDTH)[: dims[ed.NGROUPS]]
    flags = groups[:, ed.G_POINT_BLOCKS]
    assert set(flags.tolist()) <= {0, 1}
    inertia = {id(group): Mp for group, Mp in assembly.Inertia(model).groups}
    for g, group in enumerate(model.groups):  # the model's groups come first
        Mp = inertia.get(id(group))
        full = Mp is not None and np.array_equal(
            np.flatnonzero(np.any(np.asarray(Mp) != 0.0, axis=0).ravel()), PATTERN)
        assert flags[g] == int(group.kind.type_name == "BEAM" and full), group.kind.type_name
    assert flags[len(model.groups):].sum() == 0  # the node inertias' groups
