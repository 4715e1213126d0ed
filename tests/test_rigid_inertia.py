"""A spatial rigid cluster's element masses as one rigid body on its master
(core/engine/rigid_inertia.py, core/engine/rigid_inertia_kernels.py).

The closed-form mass block, gravity and convective force of each folded cluster against the
sum of its elements' contributions through their inertia points (the numpy reference's
inertia points and the plain maps of RigidLayout), the convective force against finite
differences of the kinetic energy 1/2 zdot^T M_z(lambda) zdot, and the engine with the folded
clusters against the engine without clusters (EngineData(rigid=False)). The manipulator's
rigid beams are massless in its scenes (its bodies' mass is on the masters); with the rigid
section given a mass per length they carry it, and 90 of them fold into 22 clusters.
"""

import numpy as np
import pytest
from test_rigid import engine_results

from flexure.core import load_scene
from flexure.core.engine import data as ed
from flexure.core.engine.data import EngineData
from flexure.core.engine.packing import ElementGroups
from flexure.core.engine.rigid_inertia import B_ROTATION, B_TRANSLATION, BODY_WIDTH
from flexure.core.engine.rigid_inertia_kernels import add_rigid_bodies
from flexure.core.mechanics.assembly import point_gravity

# the rigid beams' section with mass: rho A (kg/m) and the section's rotational inertias
# (kg m), which put mass on the beams' rotated axes as well as on their positions
MASSIVE = {"sections.rigid.rho_A": 0.12, "sections.rigid.rho_Iy": 2e-6,
           "sections.rigid.rho_Iz": 3e-6}


def massive_manipulator():
    return load_scene("manipulator_control", overrides=MASSIVE)


@pytest.mark.parametrize("name, massive, clusters, elements", [
    ("manipulator_control", False, 0, 0), ("manipulator_control", True, 22, 90),
    ("stage_spatial_1dof", False, 1, 1), ("stage_planar_3dof", False, 0, 0)])
def test_folded_clusters(name, massive, clusters, elements):
    """Which clusters fold: none where the rigid beams are massless (the manipulator's scenes)
    or the model is planar, every cluster where they carry mass."""
    model = load_scene(name, overrides=MASSIVE if massive else None)
    bodies = EngineData(model).rigid.bodies
    assert len(bodies.per_cluster) == clusters
    assert len(bodies.folded) == elements
    assert bodies.ints.size == BODY_WIDTH * clusters


def random_state(model, layout, seed):
    """(x, xdot) with the masters moved and turned at random (unit Euler parameters), random
    master velocities (lambda . lambdadot not zero: the formulas hold off that too) and the
    slaves filled: x_s = S(z), xdot_s = T zdot."""
    rng = np.random.default_rng(seed)
    x = model.initial_coordinates.astype(float).copy()
    masters = np.unique(np.concatenate([layout.translation.ravel(), layout.rotation.ravel()]))
    masters = masters[masters >= 0]
    x[masters] += 0.3 * rng.standard_normal(masters.size)
    for rotation in np.unique(layout.rotation, axis=0):
        x[rotation] /= np.linalg.norm(x[rotation])
    x = layout.fill(x)
    v = np.zeros(model.nx)
    v[masters] = rng.standard_normal(masters.size)
    return x, layout.transform(x, model.nx) @ v


def element_sums(model, packing, elements, masters, x, xdot):
    """(M_z (7, 7), f_z (7,)) of the elements (touching indices) on their cluster's master
    coordinates `masters`: sum T_e^T Dp^T Mp Dp T_e and sum T_e^T Dp^T Mp (g_p - (D2p v) v -
    Dp c), c the slaves' convective accelerations (RigidLayout.convective)."""
    groups = ElementGroups(model)
    layout = packing.layout
    weights = layout.weights(x)
    on_masters = np.zeros(model.nx)
    on_masters[masters] = xdot[masters]
    c = layout.convective(x, on_masters)
    M, f = np.zeros((7, 7)), np.zeros(7)
    for t in elements:
        gp, i, z = packing.touching[t]
        group = groups.all[gp]
        Mp = groups.inertia[id(group)][i]
        coords = group.coordinate_index[i]
        _, Dp, D2p = group.kind.inertia_points(group.local(x)[i: i + 1], {
            key: np.asarray(value)[i: i + 1] for key, value in group.reference.items()},
            order=2)
        Dp, D2p = Dp[0], D2p[0]
        Te = packing.element_transform(gp, i, coords, x, weights)
        Tm = np.zeros((coords.size, 7))
        for j, coordinate in enumerate(masters):
            at = np.flatnonzero(z == coordinate)
            if at.size:
                Tm[:, j] = Te[:, at[0]]
        G = Dp @ Tm
        v = xdot[coords]
        points = point_gravity(group, model.gravity) - np.einsum("pij,i,j->p", D2p, v, v) \
            - Dp @ c[coords]
        M += G.T @ Mp @ G
        f += G.T @ Mp @ points
    return M, f


def kernel_bodies(data, x, xdot):
    """Per folded cluster (its master coordinates, M_z (7, 7), f_z (7,)) from
    `add_rigid_bodies` on a dense augmented matrix."""
    dims = data.int_array("dims")
    assert dims[ed.A_SPARSE] == 0
    na = dims[ed.NFREE] + dims[ed.NRIGID]
    A = np.zeros(na * na)
    force = data.float_array("rigid_force")
    force[:] = 0.0
    add_rigid_bodies(data.address, x, xdot, True, A, na)
    A = A.reshape(na, na)
    position, column = data.int_array("augmented_position"), data.int_array("column_of_coordinate")
    ints = data.rigid.bodies.ints.reshape(-1, BODY_WIDTH)
    out = []
    for row in ints:
        masters = np.concatenate([row[B_TRANSLATION: B_TRANSLATION + 3],
                                  row[B_ROTATION: B_ROTATION + 4]])
        at = position[column[masters]]
        out.append((masters, A[np.ix_(at, at)].copy(), force[masters].copy()))
    return out


@pytest.mark.parametrize("name", ["massive_manipulator", "stage_spatial_19dof"])
def test_rigid_bodies_match_their_elements(name):
    """The compiled per-cluster mass block and force (gravity less the convective force)
    against the sum of the folded elements' contributions through their inertia points, at
    two random states with random velocities, to 1e-13 of each cluster's largest entry."""
    model = massive_manipulator() if name == "massive_manipulator" else load_scene(name)
    data = EngineData(model, augmented=True, sparse=False)
    packing = data.rigid
    for seed in (1, 2):
        x, xdot = random_state(model, packing.layout, seed)
        bodies = kernel_bodies(data, x, xdot)
        assert len(bodies) == len(packing.bodies.per_cluster) > 0
        for (masters, M, f), (_, elements) in zip(bodies, packing.bodies.per_cluster,
                                                  strict=True):
            M_ref, f_ref = element_sums(model, packing, elements, masters, x, xdot)
            assert np.max(np.abs(M - M_ref)) <= 1e-13 * np.max(np.abs(M_ref))
            assert np.max(np.abs(f - f_ref)) <= 1e-13 * np.max(np.abs(f_ref))
            assert np.array_equal(M, M.T)


def test_convective_force_from_the_kinetic_energy():
    """The convective force is d/dt (M_z) zdot - dT/dz of T = 1/2 zdot^T M_z(lambda) zdot
    (Lagrange's equations; every folded point is holonomic), with M_z the compiled one and
    both derivatives by central differences of step 1e-3 in lambda, exact for M_z quadratic
    in lambda but for round-off: to 1e-9 of the force. Gravity is switched off."""
    model = massive_manipulator()
    model.gravity[:] = 0.0
    data = EngineData(model, augmented=True, sparse=False)
    x, xdot = random_state(model, data.rigid.layout, seed=3)
    h = 1e-3

    def mass_at(lam_shift):
        moved = x.copy()
        for masters, _, _ in kernel_bodies(data, x, xdot):
            moved[masters[3:]] += lam_shift(masters)
        return {tuple(m): M for m, M, _ in kernel_bodies(data, moved, xdot)}

    forces = {tuple(m): f for m, _, f in kernel_bodies(data, x, xdot)}
    ahead = mass_at(lambda m: h * xdot[m[3:]])
    behind = mass_at(lambda m: -h * xdot[m[3:]])
    for key, f in forces.items():
        zdot = xdot[list(key)]
        rate = (ahead[key] - behind[key]) @ zdot / (2.0 * h)  # d/dt (M_z) zdot
        gradient = np.zeros(7)
        for a in range(4):
            step = np.zeros(7)
            step[3 + a] = h
            plus = mass_at(lambda m, a=a: h * np.eye(4)[a])[key]
            minus = mass_at(lambda m, a=a: -h * np.eye(4)[a])[key]
            gradient[3 + a] = 0.5 * zdot @ (plus - minus) @ zdot / (2.0 * h)
        expected = -(rate - gradient)  # f = gravity (zero) less the convective force
        assert np.max(np.abs(f - expected)) <= 1e-9 * np.max(np.abs(expected))


def test_engine_with_folded_clusters_matches_the_full_system():
    """The manipulator with massive rigid beams: qddot, the tangent's stiffness (with the
    slaves' geometric stiffness, which reads each element's forces where it sits) and the
    first-order Jacobian with the folded clusters against the engine without clusters, to
    1e-12 of each quantity's largest entry (as tests/test_rigid.py's elimination)."""
    model = massive_manipulator()
    folded, _ = engine_results(model, True, "augmented", seed=4)
    full, _ = engine_results(model, False, "augmented", seed=4)
    for a, b in zip(full, folded, strict=True):
        for quantity in ("qddot", "stiffness", "jacobian"):
            scale = np.max(np.abs(a[quantity]))
            assert np.max(np.abs(a[quantity] - b[quantity])) <= 1e-12 * scale, quantity
