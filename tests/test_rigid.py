"""Rigid clusters eliminated in the engine (core/mechanics/rigid_bodies.py, core/engine/rigid*.py).

The clusters found on small scenes and on the manipulator; the plain maps against the rigid
motion they stand for (the rigid beams' deformations stay zero) and against finite
differences; the compiled maps against the plain ones; and the engine with the elimination
against the engine without it (EngineData(rigid=False), the path of a model without
clusters): qddot, the tangent, DF, and a short simulation.
"""

import numpy as np
import pytest

from flexure.core import Mechanics, Simulator, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine, rigid_kernels
from flexure.core.engine import rigid as packed_rigid
from flexure.core.engine.data import EngineData
from flexure.core.engine.point_masses import point_columns
from flexure.core.mechanics.rigid_bodies import RigidLayout, find_clusters
from flexure.core.model import FIXED, ZERO
from flexure.core.numerics.rotations import rotation_matrix

SCENES = ("stage_planar_3dof", "stage_spatial_1dof", "stage_spatial_19dof",
          "manipulator_control")


@pytest.fixture(scope="module", params=SCENES)
def scene(request):
    """(name, model, RigidLayout) of a scene with rigid clusters."""
    model = load_scene(request.param)
    return request.param, model, RigidLayout(model, find_clusters(model))


def moved_masters(model, layout, seed, size=1e-2):
    """x0 with the masters' coordinates moved by about `size` (the Euler parameters kept
    normalised), the slaves filled from them."""
    rng = np.random.default_rng(seed)
    x = model.initial_coordinates.astype(float).copy()
    masters = np.unique(np.concatenate([layout.translation.ravel(), layout.rotation.ravel()]))
    masters = masters[masters >= 0]
    x[masters] += size * rng.standard_normal(masters.size)
    if model.dimension == 3:
        for rotation in np.unique(layout.rotation, axis=0):
            x[rotation] /= np.linalg.norm(x[rotation])
    return layout.fill(x)


# -- the clusters -------------------------------------------------------------------------------
@pytest.mark.parametrize("name, clusters, slave_coordinates", [
    ("stage_planar_1dof", 1, 3), ("stage_spatial_1dof", 1, 7), ("manipulator_control", 22, 630),
    ("truss_1dof_x", 0, 0)])
def test_clusters_found(name, clusters, slave_coordinates):
    """The clusters and slave coordinates of small scenes and of the manipulator (its 784
    free coordinates become 154, as the rigid beams' and normalisations' rows leave), each
    master a translational and a rotational node, no slave fixed or with lumped mass."""
    model = load_scene(name)
    found = find_clusters(model)
    layout = RigidLayout(model, found)
    assert len(found) == clusters
    assert layout.slave_coordinates.size == slave_coordinates
    nodes = {node.name: node for node in model.nodes}
    for cluster in found:
        assert nodes[cluster.master_translation].kind == "translational"
        assert nodes[cluster.master_rotation].kind == "rotational"
        for name_ in cluster.slaves:
            coords = list(nodes[name_].coordinates)
            assert not np.any(model.coordinate_status[coords] == FIXED)
            assert not np.any(model.lumped_mass[coords])
        for g, i in cluster.internal:  # every internal element entirely prescribed zero
            assert np.all(model.deformation_status[model.groups[g].deformation_index[i]]
                          == ZERO)
    data = EngineData(model)
    assert data.int_array("dims")[ed.NFREE] == model.free_coordinates.size - slave_coordinates
    if name == "manipulator_control":
        assert data.int_array("dims")[ed.NFREE] == 154


def test_plain_maps_move_rigidly(scene):
    """At x0 the maps give x0 back (1e-15 of the size); with the masters moved, the rigid
    beams' deformations stay zero (1e-14 of the length scale) and a spatial slave turns with
    its master: R(lambda_s) = R(lambda_m) R(lambda_m0)^T R(lambda_s0) to 1e-14."""
    name, model, layout = scene
    x0 = model.initial_coordinates.astype(float)
    assert np.max(np.abs(layout.fill(x0) - x0)) <= 1e-15 * np.max(np.abs(x0))
    x = moved_masters(model, layout, seed=1)
    length = Mechanics(model).kinematics.length_scale
    for cluster in find_clusters(model):
        for g, i in cluster.internal:
            group = model.groups[g]
            e = group.kind.deformations(x[group.coordinate_index[i]][None],
                                        {k: np.asarray(v)[i: i + 1]
                                         for k, v in group.reference.items()}, order=0)[0]
            assert np.max(np.abs(e)) <= 1e-14 * length, (name, group.names[i], e)
    if model.dimension == 3:
        for j in np.flatnonzero(layout.kinds == 1):
            own, mr = layout.own[j], layout.rotation[j]
            expected = rotation_matrix(x[mr]) @ rotation_matrix(x0[mr]).T @ rotation_matrix(
                x0[own])
            assert np.max(np.abs(rotation_matrix(x[own]) - expected)) <= 1e-14


def test_plain_derivatives_match_finite_differences(scene):
    """T = dx/dx_master, c = d2/dt2 x(x_master + t v) and the curvature sum_s f_s d2x_s
    against central differences of the map (relative 1e-7, 1e-6, 1e-6)."""
    name, model, layout = scene
    nx = model.nx
    x = moved_masters(model, layout, seed=2)
    rng = np.random.default_rng(3)
    v = rng.standard_normal(nx)
    v[layout.slave_coordinates] = 0.0
    h = 1e-6
    T = layout.transform(x, nx)
    fd = (layout.fill(x + h * v) - layout.fill(x - h * v)) / (2 * h)
    assert np.max(np.abs(T @ v - fd)) <= 1e-7 * np.max(np.abs(fd))
    h2 = 1e-4
    second = (layout.fill(x + h2 * v) - 2 * layout.fill(x) + layout.fill(x - h2 * v)) / h2**2
    c = layout.convective(x, v)
    assert np.max(np.abs(c - second)) <= 1e-6 * np.max(np.abs(second))
    f = np.zeros(nx)
    f[layout.slave_coordinates] = rng.standard_normal(layout.slave_coordinates.size)
    H = layout.curvature(x, f, nx)
    # d/dx (T^T f) with f held: central differences of T(x)^T f along v
    fd_H = (layout.transform(x + h * v, nx).T @ f - layout.transform(x - h * v, nx).T @ f) / (
        2 * h)
    assert np.max(np.abs(H @ v - fd_H)) <= 1e-6 * max(np.max(np.abs(fd_H)), 1e-300)


@pytest.mark.slow  # the kernels compiled for Python (11 s cold); the engine's tests run them
def test_compiled_maps_match_the_plain_ones(scene):
    """fill_slaves (x_s and T's weights), expand, convective, condense and the touching
    elements' De T_e on J's rows (`rigid_de`) against RigidLayout and RigidPacking to 1e-14;
    a touching element's points' mass on its z-coordinates and the forces of the slaves' c
    there (`touching_mass`) against the dense products to 1e-13."""
    name, model, layout = scene
    data = EngineData(model)
    table, nx = data.address, model.nx
    x = moved_masters(model, layout, seed=4)
    scrambled = x.copy()
    scrambled[layout.slave_coordinates] = 7.0  # overwritten by the fill
    rigid_kernels.fill_slaves(table, scrambled)
    assert np.max(np.abs(scrambled - x)) <= 1e-14 * np.max(np.abs(x))
    W = data.float_array("rigid_weights").reshape(layout.weights(x).shape)
    assert np.max(np.abs(W - layout.weights(x))) <= 1e-14 * np.max(np.abs(W))
    rng = np.random.default_rng(5)
    v = rng.standard_normal(nx)
    T = layout.transform(x, nx)
    masters_only = v.copy()
    masters_only[layout.slave_coordinates] = 0.0
    rigid_kernels.convective(table, x, masters_only)
    c = layout.convective(x, masters_only)
    assert np.max(np.abs(data.float_array("rigid_c") - c)) <= 1e-14 * np.max(np.abs(c))
    expanded = masters_only.copy()
    rigid_kernels.expand(table, expanded, True)
    expected = T @ masters_only + c
    assert np.max(np.abs(expanded - expected)) <= 1e-14 * np.max(np.abs(expected))
    free = data.int_array("free")
    out = np.zeros(free.size)
    rigid_kernels.condense(table, v, out)
    expected = (T.T @ v)[free]
    assert np.max(np.abs(out - expected)) <= 1e-14 * np.max(np.abs(expected))
    packing = data.rigid
    # the touching elements' De_z = De T_e on J's rows (slot touching_rows) for a random De
    # (zeros as a BEAM's), the other rows of slot rigid_de left as they were
    De = data.float_array("De")
    De[:] = rng.standard_normal(De.size)
    De[rng.random(De.size) < 0.3] = 0.0
    rigid_de = data.float_array("rigid_de")
    rigid_de[:] = np.nan
    rigid_kernels.rigid_de(table)
    written = np.zeros(rigid_de.size, dtype=bool)
    elements = data.int_array("rigid_elements").reshape(-1, packed_rigid.ELEMENT_WIDTH)
    groups = data.int_array("groups").reshape(data.int_array("dims")[ed.NGROUPS], -1)
    for _, t, b in data.int_array("touching_rows").reshape(-1, 3):
        gp, i, z = packing.touching[t]
        coords = model.groups[gp].coordinate_index[i]
        k = model.groups[gp].deformation_index.shape[1]
        offset = groups[gp, ed.G_DE_OFFSET] + i * k * coords.size  # the element's De rows
        row = De[offset + b * coords.size: offset + (b + 1) * coords.size]
        expected = row @ packing.element_transform(gp, i, coords, x)
        at = elements[t, packed_rigid.E_DE_OFFSET] + b * z.size
        assert np.max(np.abs(rigid_de[at: at + z.size] - expected)) <= 1e-14 * max(
            np.max(np.abs(expected)), 1e-300)
        written[at: at + z.size] = True
    assert np.all(np.isnan(rigid_de[~written]))
    for t, (gp, i, z) in enumerate(packing.touching):
        if gp >= len(model.groups):  # a node inertia's group
            continue
        coords = model.groups[gp].coordinate_index[i]
        # T_e itself in rows of a padded length, zero past mz
        stride = z.size + 5
        Te = np.full(coords.size * stride, np.nan)
        rigid_kernels.transform_rows(table, t, coords.size, Te, stride)
        Te = Te.reshape(coords.size, stride)
        assert np.array_equal(Te[:, z.size:], np.zeros((coords.size, 5)))
        assert np.allclose(Te[:, :z.size], packing.element_transform(gp, i, coords, x),
                           rtol=0, atol=1e-15)
        # its points' mass and the forces of the slaves' c on its z-coordinates:
        # T_e^T Dp^T Mp Dp T_e and T_e^T Dp^T Mp Dp c_e, for a random Dp (P, m; zeros as a
        # BEAM's) and a symmetric Mp on a pattern; P within the room the model packed
        P = min(3, int(data.int_array("dims")[ed.MAX_P]))
        Dp = rng.standard_normal((P, coords.size))
        Dp[rng.random(Dp.shape) < 0.5] = 0.0
        Mp = rng.standard_normal((P, P))
        Mp = Mp + Mp.T
        pattern = np.arange(P * P, dtype=np.int64)
        columns = np.zeros(P * (coords.size + 1) + coords.size, dtype=np.int64)
        point_columns(P, coords.size, Dp, columns)
        c = data.float_array("rigid_c")
        c[:] = 0.0
        c[layout.slave_coordinates] = rng.standard_normal(layout.slave_coordinates.size)
        Me, force = rigid_kernels.touching_mass(table, t, Mp.ravel(), pattern, P, coords.size,
                                                Dp, columns, coords, True)
        Te = packing.element_transform(gp, i, coords, x)
        expected = Te.T @ Dp.T @ Mp @ Dp @ Te
        assert np.max(np.abs(Me - expected.ravel())) <= 1e-13 * max(np.max(np.abs(expected)),
                                                                     1e-300)
        expected = Te.T @ Dp.T @ Mp @ Dp @ c[coords]
        assert np.max(np.abs(force - expected)) <= 1e-13 * max(np.max(np.abs(expected)),
                                                                 1e-300)
        Me2, force = rigid_kernels.touching_mass(table, t, Mp.ravel(), pattern, P,
                                                 coords.size, Dp, columns, coords, False)
        assert np.array_equal(Me2, Me) and not np.any(force)
        # and T_e is T's block: the element's rows, its z-columns
        assert np.allclose(packing.element_transform(gp, i, coords, x), T[np.ix_(coords, z)],
                           rtol=0, atol=1e-15)


# -- the engine with and without the elimination ------------------------------------------------
def engine_results(model, rigid, form, seed):
    """qddot, K, C at the evaluation's qddot, x and DF of two random states."""
    data = EngineData(model, rigid=rigid, augmented=form == "augmented")
    mechanics = Mechanics(model)
    q0 = mechanics.kinematics.dofs_of(model.initial_coordinates)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(2):
        q = q0 + 1e-4 * rng.standard_normal(q0.size)
        qdot = 0.05 * rng.standard_normal(q0.size)
        data.float_array("inputs")[:] = rng.standard_normal(len(model.inputs))
        assert engine.call(data, engine.OP_EVALUATE, q, qdot) == ed.OK
        qddot = data.float_array("qddot").copy()
        assert engine.call(data, engine.OP_TANGENT, 0.5 * qddot + 1.0) == ed.OK
        jacobian = np.zeros((2 * q0.size) ** 2)
        y = np.concatenate([q, qdot])  # q_ref is zero
        assert engine.call(data, engine.OP_JACOBIAN, y, jacobian, s=1.0) == ed.OK
        out.append({name: data.float_array(name).copy() for name in (
            "stiffness", "damping", "x", "DF", "xdot")} | {"qddot": qddot,
                                                           "jacobian": jacobian})
    return out, data


# relative tolerances of the elimination against the full system, per quantity: round-off of
# the full system's kinematics (solved to 1e-14 of the length scale) through each quantity;
# stage_spatial_19dof's M_bar has a condition of 1e9 (its stiff flexures' DOFs): its qddot in the
# reduced form and its Jacobian (M_bar^-1 K) follow the full system's to 1e-9, the round-off
# of the kinematics times that condition
TOLERANCES = {"qddot": 1e-12, "stiffness": 1e-12, "damping": 1e-13, "x": 1e-14, "DF": 1e-13,
              "xdot": 1e-13, "jacobian": 1e-12}


@pytest.mark.parametrize("form", ["reduced", "augmented"])
def test_engine_matches_the_full_system(scene, form):
    """qddot, the tangent (K at another qddot, C), the first-order Jacobian (CVODE's), x, DF
    and xdot with the elimination against the engine without it, relative to each
    quantity's largest entry."""
    name, model, _ = scene
    full, full_data = engine_results(model, False, form, seed=6)
    reduced, data = engine_results(model, True, form, seed=6)
    assert data.int_array("dims")[ed.NFREE] < full_data.int_array("dims")[ed.NFREE]
    for a, b in zip(full, reduced, strict=True):
        for quantity, tolerance in TOLERANCES.items():
            if name == "stage_spatial_19dof" and (
                    quantity == "jacobian" or (quantity == "qddot" and form == "reduced")):
                tolerance = 1e-9
            scale = max(np.max(np.abs(a[quantity])), 1e-300)
            error = np.max(np.abs(a[quantity] - b[quantity]))
            assert error <= tolerance * scale, (quantity, error / scale)


def test_models_without_clusters_are_untouched():
    """A model without rigid clusters packs and evaluates bit for bit as with the
    elimination switched off."""
    model = load_scene("truss_1dof_x")
    assert not find_clusters(model)
    a, _ = engine_results(model, True, "augmented", seed=7)
    b, _ = engine_results(model, False, "augmented", seed=7)
    for u, v in zip(a, b, strict=True):
        for quantity in u:
            assert np.array_equal(u[quantity], v[quantity])


@pytest.mark.parametrize("name", ["stage_spatial_19dof", "stage_planar_3dof"])
def test_simulation_matches_the_full_system(name):
    """A short simulation (CVODE BDF, rtol 1e-10) from a displaced state under an input
    step: the trajectories with and without the elimination agree to 1e-7 of their range."""
    model = load_scene(name)
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    displaced = q0 + 1e-4 * np.random.default_rng(8).standard_normal(q0.size)
    runs = []
    for rigid in (True, False):
        simulator = Simulator(model, rtol=1e-10, rigid=rigid)
        simulator.reset(q0=displaced)
        simulator.set_inputs(np.ones(len(model.inputs)))
        trajectory = []
        for t in np.linspace(0.002, 0.02, 10):
            simulator.advance_to(t)
            trajectory.append(simulator.q.copy())
        runs.append(np.array(trajectory))
    scale = np.max(np.ptp(runs[1], axis=0))
    assert np.max(np.abs(runs[0] - runs[1])) <= 1e-7 * scale


def test_full_newton_stops_on_the_residual():
    """A cold start at a solution takes no Newton step: x stays bit for bit the start (the
    step-size test alone would take one step of round-off first)."""
    for name in ("truss_1dof_x", "stage_spatial_1dof"):
        model = load_scene(name)
        data = EngineData(model)
        x0 = data.rigid.layout.fill(model.initial_coordinates.astype(float))
        data.float_array("x_start")[:] = x0
        data.int_array("dims")[ed.WARM] = 0
        q0 = Mechanics(model).kinematics.dofs_of(x0)
        assert engine.call(data, engine.OP_KINEMATICS, q0) == ed.OK
        assert np.array_equal(data.float_array("x"), x0)


def test_the_maps_read_rigid_de_on_js_rows_alone():
    """`rigid_kernels.rigid_de` forms the touching elements' De T_e on J's rows alone (slot
    touching_rows): the sparse maps that read slot rigid_de (J's, the Newton matrix's copy of
    it, the augmented system's rigid rows and their mirror) point at no other entry, on
    manipulator_control (the small scenes' J is banded: no map)."""
    model = load_scene("manipulator_control")
    data = EngineData(model, augmented=True)
    dims = data.int_array("dims")
    n_rde = data.float_array("rigid_de").size
    elements = data.int_array("rigid_elements").reshape(-1, packed_rigid.ELEMENT_WIDTH)
    on_rows = np.zeros(n_rde, dtype=bool)
    for _, t, b in data.int_array("touching_rows").reshape(-1, 3):
        mz = elements[t, packed_rigid.E_MZ]
        at = elements[t, packed_rigid.E_DE_OFFSET] + b * mz
        on_rows[at: at + mz] = True
    start = data.float_array("De").size + int(dims[ed.NXDOF])  # `constraint_values`' layout
    reads = {"j_map": [start], "newton_j_map": [start],
             "aug_map": [int(dims[ed.A_RIGID]), int(dims[ed.A_RIGID]) + n_rde]}
    checked = 0
    for name, starts in reads.items():
        entries = data.int_array(name)
        assert entries.size, name  # manipulator_control factors J and A sparse
        for first in starts:
            read = entries[first: first + n_rde] >= 0
            assert read.any() and not np.any(read & ~on_rows), name
            checked += 1
    assert checked == 4 and not on_rows.all()
