"""A spatial rigid cluster's element masses as one rigid body on its master, packed once.

Within a rigid cluster (`rigid`) every inertia point p of an element whose nodes all belong
to the cluster moves with the master, z = (x_m (3, m), lambda_m (4, Euler parameters)): the
slaves' translations are x_m + C_r lambda_m lambda_m / 2 and their Euler parameters
Q lambda_m, and the points of the spatial elements (a BEAM's positions and rotated axes, a
node inertia's rotated axes) are affine in the node translations and quadratic in the node
Euler parameters. So each point is p(z) = A x_m + lambda_m^T C lambda_m / 2 with constant A
(P, 3) and C (P, 4, 4), and its velocity Jacobian is affine in lambda_m:

    G(lambda) = dp/dz = [A | sum_b lambda_b C_b],    C_b = C[:, :, b] (P, 4),
    pddot = G zddot + (sum_b lambdadot_b C_b) lambdadot.

The elements' share of the equations of motion on z, G^T Mp (g_p - pddot), is then, with the
cluster's constant tensors summed once here over its elements (Mp their masses, g_p gravity
on their points, N/kg),

    mass        M_tt = A^T Mp A (3, 3; kg)
    first       F_b = A^T Mp C_b (4 x (3, 4); kg m)
    second      K_bc = C_b^T Mp C_c (4 x 4 x (4, 4); kg m^2)
    gravity     g_t = A^T Mp g_p (3; N), g_b = C_b^T Mp g_p (4 x (4,); N m)

the mass block M_z = [[M_tt, sum_b lambda_b F_b], [., sum_bc lambda_b lambda_c K_bc]], the
gravity force [g_t; sum_b lambda_b g_b] and the convective force [sum_c lambdadot_c F_c
lambdadot; sum_bc lambda_b lambdadot_c K_bc lambdadot]: what the elements' points give
through Dp T_e, (D2p v) v and Dp c (`motion.touching_element_mass`), summed in another order, so
equal to round-off, at a cost independent of the cluster's element count
(`rigid_inertia_kernels`).

A and the C_b are read off the elements' own inertia points at lambda_m = e_b (G = [A | C_b]
there), and each element is folded only if G at a random master pose (translation and
rotation) matches the affine form to AFFINE_TOLERANCE of its size; an element that does not
(an element type whose points are not of that form) keeps its own evaluation, as do planar
clusters. The mass block goes into the augmented system through the entries of one folded
element (the carrier) whose z-coordinates cover every folded element's.

Tables (slots rigid_bodies, rigid_body_tensors), per folded cluster:

    ints     BODY_WIDTH: the master's translation (3) and rotation (4) coordinates, the
             carrier's touching index, the places of the seven in the carrier's z (-1: none)
    floats   TENSOR_WIDTH: M_tt, F (b, k, a), K (b, c, a, d), g_t, g_b (b, a), flat
"""

import numpy as np

from ..mechanics.assembly import point_gravity

BODY_WIDTH = 15
B_TRANSLATION, B_ROTATION, B_CARRIER, B_PLACES = 0, 3, 7, 8
T_MASS, T_FIRST, T_SECOND, T_GRAVITY, T_GRAVITY_TURN, TENSOR_WIDTH = 0, 9, 57, 313, 316, 332
# floats of slot rigid_local that `rigid_inertia_kernels.add_rigid_bodies` works in: L (4, 4,
# 4), M_z (7, 7), the carrier's Me (at most 7 x 7), lambda and its rate (4 each)
BODY_SCRATCH = 64 + 49 + 49 + 4 + 4
# relative to the largest entry of G: the affine form holds to round-off (1e-15) where it
# holds at all; an element outside it misses by the size of G
AFFINE_TOLERANCE = 1e-10


class ClusterInertia:
    """The spatial clusters' folded element masses (see the module docstring).

    Parameters
    ----------
    model : Model
    groups : list of ElementGroup
        Every packed element group, in the engine's order.
    inertia : dict
        {id of a group with inertia points: its Mp (n, P, P)}.
    packing : RigidPacking
        The clusters and their touching elements (`rigid`; its tables but E_FOLDED set).

    Attributes
    ----------
    folded : list of int
        The touching indices of the folded elements.
    ints, tensors : ndarray
        The slots rigid_bodies (int64) and rigid_body_tensors (float64), flat.
    per_cluster : list of (cluster index, [touching indices])
        The folded clusters and their folded elements, in the tables' order.
    """

    def __init__(self, model, groups, inertia, packing):
        self.folded, self.per_cluster = [], []
        self.ints = np.zeros(0, dtype=np.int64)
        self.tensors = np.zeros(0)
        if model.dimension != 3 or not packing.clusters:
            return
        masters, candidates = _candidates(model, groups, inertia, packing)
        if not any(candidates):
            return
        jacobians, checked = _jacobians(model, groups, packing, masters, candidates)
        ints, tensors = [], []
        for c, elements in enumerate(candidates):
            elements = [t for t in elements if checked[t]]
            carrier = _carrier(packing, elements)
            if carrier is None:
                continue
            z = packing.touching[carrier][2]
            places = [int(np.flatnonzero(z == coordinate)[0]) if coordinate in z else -1
                      for coordinate in masters[c]]
            ints.append(np.concatenate([masters[c], [carrier], places]))
            tensors.append(_tensors(model, groups, inertia, packing, elements, jacobians))
            self.folded.extend(elements)
            self.per_cluster.append((c, elements))
        if ints:
            self.ints = np.concatenate(ints).astype(np.int64)
            self.tensors = np.concatenate(tensors)


def _candidates(model, groups, inertia, packing):
    """(the masters' coordinates (n_clusters, 7), per cluster the touching elements with
    mass whose coordinates all belong to it)."""
    nodes = {node.name: node for node in model.nodes}
    owner = np.full(model.nx, -1, dtype=np.int64)
    masters = []
    for c, cluster in enumerate(packing.clusters):
        for name in (cluster.master_translation, cluster.master_rotation, *cluster.slaves):
            owner[list(nodes[name].coordinates)] = c
        masters.append(np.array([*nodes[cluster.master_translation].coordinates,
                                 *nodes[cluster.master_rotation].coordinates], dtype=np.int64))
    candidates = [[] for _ in packing.clusters]
    for t, (gp, i, _) in enumerate(packing.touching):
        group = groups[gp]
        if id(group) not in inertia or not np.any(inertia[id(group)][i]):
            continue
        owners = owner[group.coordinate_index[i]]
        if owners[0] >= 0 and np.all(owners == owners[0]) and masters[owners[0]].size == 7:
            candidates[owners[0]].append(t)
    return masters, candidates


def _jacobians(model, groups, packing, masters, candidates):
    """({touching index: [G at lambda_m = e_0 .. e_3]}, {touching index: whether G at a
    random master pose is affine in lambda_m as the module docstring says})."""
    rng = np.random.default_rng(20261129)  # a fixed pose: the packing is deterministic
    x0 = model.initial_coordinates.astype(float)
    poses = [np.eye(4)[b] for b in range(4)]
    turn = rng.standard_normal((len(masters), 4))
    turn /= np.linalg.norm(turn, axis=1)[:, None]
    shift = rng.standard_normal((len(masters), 3))
    elements = [t for per in candidates for t in per]
    found = {t: [] for t in elements}
    for pose in [*poses, None]:
        x = x0.copy()
        for c, coordinates in enumerate(masters):
            x[coordinates[3:]] = turn[c] if pose is None else pose
            if pose is None:
                x[coordinates[:3]] += shift[c]
        x = packing.layout.fill(x)
        weights = packing.layout.weights(x)
        points = {}
        for t in elements:
            gp, i, z = packing.touching[t]
            group = groups[gp]
            if gp not in points:
                points[gp] = group.kind.inertia_points(group.local(x), group.reference,
                                                       order=1)[1]
            coords = group.coordinate_index[i]
            Te = packing.element_transform(gp, i, coords, x, weights)
            owner = next(c for c, per in enumerate(candidates) if t in per)
            G = np.zeros((points[gp].shape[1], 7))
            for j, coordinate in enumerate(masters[owner]):
                at = np.flatnonzero(z == coordinate)
                if at.size:
                    G[:, j] = points[gp][i] @ Te[:, at[0]]
            found[t].append(G)
    checked = {}
    for t in elements:
        G = found[t]
        owner = next(c for c, per in enumerate(candidates) if t in per)
        expected = np.concatenate([G[0][:, :3], sum(turn[owner][b] * G[b][:, 3:]
                                                    for b in range(4))], axis=1)
        scale = max(np.max(np.abs(G[4])), np.max(np.abs(expected)), 1e-300)
        same_translation = all(np.max(np.abs(G[b][:, :3] - G[0][:, :3])) <= AFFINE_TOLERANCE
                               * scale for b in range(1, 4))
        checked[t] = bool(same_translation and np.max(np.abs(G[4] - expected))
                          <= AFFINE_TOLERANCE * scale)
    return {t: found[t][:4] for t in elements}, checked


def _carrier(packing, elements):
    """The first of the elements whose z-coordinates hold every one's, or None."""
    if not elements:
        return None
    union = set()
    for t in elements:
        union.update(packing.touching[t][2].tolist())
    for t in elements:
        if union <= set(packing.touching[t][2].tolist()):
            return t
    return None


def _tensors(model, groups, inertia, packing, elements, jacobians):
    """One cluster's TENSOR_WIDTH constants summed over its folded elements."""
    mass, first = np.zeros((3, 3)), np.zeros((4, 3, 4))
    second, gravity, turn = np.zeros((4, 4, 4, 4)), np.zeros(3), np.zeros((4, 4))
    for t in elements:
        gp, i, _ = packing.touching[t]
        group = groups[gp]
        Mp = np.asarray(inertia[id(group)][i], float)
        g = Mp @ point_gravity(group, model.gravity).astype(float)
        A = jacobians[t][0][:, :3]
        C = [jacobians[t][b][:, 3:] for b in range(4)]
        mass += A.T @ Mp @ A
        gravity += A.T @ g
        for b in range(4):
            first[b] += A.T @ Mp @ C[b]
            turn[b] += C[b].T @ g
            for c in range(4):
                second[b, c] += C[b].T @ Mp @ C[c]
    return np.concatenate([mass.ravel(), first.ravel(), second.ravel(), gravity, turn.ravel()])
