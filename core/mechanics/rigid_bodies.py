"""Rigid bodies: clusters of nodes joined by beams whose every deformation is prescribed zero.

A beam (BEAM, PLBEAM) whose deformations are all prescribed zero keeps the relative pose of
its end nodes: its translational and rotational nodes move as one rigid body. The connected
components of such "rigid beams" are the model's rigid clusters. In each, one translational
node and one rotational node are the master (x_m, m; lambda_m, Euler parameters, or phi_m,
rad, in the plane); every other node of the cluster (a slave) follows in closed form,

    x_s = x_m + R(lambda_m) r_s,          r_s = R(lambda_m0)^T (x_s0 - x_m0)   (m)
    lambda_s = lambda_m * lambda_rel,     lambda_rel = lambda_m0^-1 * lambda_s0
    (plane: x_s = x_m + R(phi_m) r_s, phi_s = phi_m + phi_s0 - phi_m0)

with R(lambda) the homogeneous quadratic form of `numerics.rotations` (R(lambda) r =
C_r lambda lambda / 2, C_r the constant (3, 4, 4) tensor of r), so a spatial slave's position
has the constant second derivative C_r in lambda_m and its Euler parameters are linear in
lambda_m (the quaternion product). The rigid beams' deformations and the slaves' Euler
normalisations are then identically zero: they leave the kinematic system with the slaves'
coordinates (`engine.rigid`). A DOF coordinate on a slave stays a row of the kinematics,
x_s(x_master) = q, nonlinear in the master's rotation.

A cluster is used only where that is exact and counted: its slaves have no fixed coordinate
and no lumped mass (at most one such node of each kind, which becomes the master), and it
removes as many constraint rows as coordinates. Other clusters stay as they are.

This module finds the clusters (`find_clusters`) and holds the plain-numpy twin of the maps
(`RigidLayout`: the slaves' coordinates, their Jacobian T = dx/dx_master, the second-order
terms) that the compiled kernels (`engine.rigid_kernels`) are checked against.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import FIXED, ZERO
from ..numerics.rotations import ROTATION_TENSOR, compose

RIGID_KINDS = ("BEAM", "PLBEAM")  # element types whose zero deformations fix the relative pose
# slave node kinds (`RigidLayout.kinds`)
SPATIAL_TRANSLATION, SPATIAL_ROTATION, PLANAR_TRANSLATION, PLANAR_ROTATION = range(4)
DEPENDENCIES = 5  # master coordinates a slave coordinate depends on, at most


@dataclass(frozen=True)
class Cluster:
    """One rigid cluster: its master nodes (translational, rotational; names), its slave
    nodes (names), and the elements it makes identically satisfied ((group index, element
    index): the rigid beams and the slaves' Euler normalisations)."""

    master_translation: str
    master_rotation: str
    slaves: tuple
    internal: tuple


def _element_nodes(model, coords):
    return list(dict.fromkeys(model.coordinate_node[c] for c in coords))


def find_clusters(model):
    """The model's rigid clusters (list of `Cluster`) where elimination is exact."""
    nodes = {node.name: node for node in model.nodes}
    parent = {name: name for name in nodes}

    def root(name):
        while parent[name] != name:
            parent[name] = parent[parent[name]]
            name = parent[name]
        return name

    edges, others = [], []  # others: the non-rigid elements whose rows are all zero
    for g, group in enumerate(model.groups):
        defs = group.deformation_index
        rigid_kind = group.kind.type_name in RIGID_KINDS
        if not (rigid_kind or defs.shape[1]):
            continue
        zero = np.all(model.deformation_status[defs] == ZERO, axis=1)
        for i in np.flatnonzero(zero).tolist():
            names = _element_nodes(model, group.coordinate_index[i])
            if not rigid_kind:
                others.append((g, i, set(names)))
                continue
            edges.append((g, i, names))
            for name in names[1:]:
                parent[root(name)] = root(names[0])
    members, edges_of = {}, {}
    for g, i, names in edges:
        key = root(names[0])
        members.setdefault(key, set()).update(names)
        edges_of.setdefault(key, []).append((g, i))
    inertia_nodes = {model.coordinate_node[index[0]] for index, _ in model.node_inertias}
    status, lumped = model.coordinate_status, model.lumped_mass
    clusters = []
    for key, names in members.items():
        ordered = [name for name in nodes if name in names]  # model order
        special = {name for name in ordered if any(
            status[c] == FIXED or lumped[c] != 0.0 for c in nodes[name].coordinates)}
        masters = []
        for kind in ("translational", "rotational"):
            of_kind = [name for name in ordered if nodes[name].kind == kind]
            chosen = [name for name in of_kind if name in special]
            if len(chosen) > 1 or not of_kind:
                break
            if not chosen and kind == "rotational":  # a node inertia stays untransformed
                chosen = [name for name in of_kind if name in inertia_nodes]
            masters.append(chosen[0] if chosen else of_kind[0])
        if len(masters) < 2:
            continue
        slaves = tuple(name for name in ordered if name not in masters)
        slave_set = set(slaves)
        # the slaves' normalisations and the like
        internal = edges_of[key] + [(g, i) for g, i, names in others if names <= slave_set]
        removed_coordinates = sum(len(nodes[name].coordinates) for name in slaves)
        removed_rows = sum(model.groups[g].deformation_index.shape[1] for g, _ in internal)
        if removed_coordinates != removed_rows:
            continue
        clusters.append(Cluster(masters[0], masters[1], slaves, tuple(sorted(internal))))
    return clusters


class RigidLayout:
    """The slaves of a model's clusters as flat tables, and the plain-numpy maps.

    Attributes
    ----------
    kinds : ndarray (n_slaves,)
        Each slave node's kind (SPATIAL_TRANSLATION, ...).
    own, translation, rotation : ndarray (n_slaves, 4), (n_slaves, 3), (n_slaves, 4)
        The slave's own coordinates, its master's translational and rotational coordinates
        (model indices, -1 past the node's size).
    data : ndarray (n_slaves, 48)
        Per slave: C_r (3, 4, 4) for a spatial translation, Q (4, 4) with lambda_s = Q lambda_m
        for a spatial rotation, r_s (2,) for a planar translation, phi_s0 - phi_m0 for a
        planar rotation.
    slave_coordinates : ndarray (n_slave_coordinates,)
        Every slave coordinate, node by node.
    dependencies : ndarray (n_slave_coordinates, DEPENDENCIES)
        The master coordinates each depends on (-1: none).
    """

    def __init__(self, model, clusters):
        nodes = {node.name: node for node in model.nodes}
        x0 = model.initial_coordinates.astype(float)
        kinds, own, trans, rot, data = [], [], [], [], []
        rotations = []  # per spatial rotation slave: its row, its master's conjugate, coords
        for cluster in clusters:
            mt = np.array(nodes[cluster.master_translation].coordinates)
            mr = np.array(nodes[cluster.master_rotation].coordinates)
            R0 = conjugate = None  # the master's, once per cluster
            for name in cluster.slaves:
                node = nodes[name]
                coords = np.array(node.coordinates)
                row = np.zeros(48)
                if model.dimension == 3 and node.kind == "translational":
                    kind = SPATIAL_TRANSLATION
                    if R0 is None:
                        lam0 = x0[mr]
                        R0 = np.einsum("kmij,i,j->km", ROTATION_TENSOR, lam0, lam0)
                    r = R0.T @ (x0[coords] - x0[mt])
                    row[:] = (2.0 * np.einsum("kmij,m->kij", ROTATION_TENSOR, r)).ravel()
                elif model.dimension == 3:
                    kind = SPATIAL_ROTATION
                    if conjugate is None:
                        lam0 = x0[mr]
                        conjugate = lam0 * np.array([1.0, -1.0, -1.0, -1.0]) / (lam0 @ lam0)
                    rotations.append((len(data), conjugate, coords))  # Q below
                elif node.kind == "translational":
                    kind = PLANAR_TRANSLATION
                    row[:2] = _planar(x0[mr[0]]).T @ (x0[coords] - x0[mt])
                else:
                    kind = PLANAR_ROTATION
                    row[0] = x0[coords[0]] - x0[mr[0]]
                kinds.append(kind)
                own.append(_padded(coords, 4))
                trans.append(_padded(mt, 3))
                rot.append(_padded(mr, 4))
                data.append(row)
        self.kinds = np.array(kinds, dtype=np.int64)
        self.own = np.array(own, dtype=np.int64).reshape(-1, 4)
        self.translation = np.array(trans, dtype=np.int64).reshape(-1, 3)
        self.rotation = np.array(rot, dtype=np.int64).reshape(-1, 4)
        self.data = np.array(data, dtype=float).reshape(-1, 48)
        if rotations:  # Q's column k: e_k * relative, every slave's at once
            rows, conjugates, coords = zip(*rotations, strict=True)
            relative = compose(np.array(conjugates), x0[np.array(coords)])
            Q = compose(np.eye(4)[None], relative[:, None, :])  # [s, k]: e_k * relative_s
            self.data[list(rows), :16] = np.swapaxes(Q, 1, 2).reshape(-1, 16)
        slave_coordinates, dependencies = [], []
        for j, kind in enumerate(self.kinds):
            for a, c in enumerate(self.own[j]):
                if c < 0:
                    continue
                slave_coordinates.append(c)
                if kind in (SPATIAL_TRANSLATION, PLANAR_TRANSLATION):
                    deps = [self.translation[j, a], *self.rotation[j]]
                else:
                    deps = list(self.rotation[j])
                dependencies.append(_padded(np.array([d for d in deps if d >= 0]),
                                            DEPENDENCIES))
        self.slave_coordinates = np.array(slave_coordinates, dtype=np.int64)
        self.dependencies = np.array(dependencies, dtype=np.int64).reshape(-1, DEPENDENCIES)

    # -- the plain maps ---------------------------------------------------------------------
    def fill(self, x):
        """x (NX,) with every slave coordinate from its master's (a copy)."""
        x = np.array(x, dtype=float)
        for j, kind in enumerate(self.kinds):
            own, mt, mr, data = self.own[j], self.translation[j], self.rotation[j], self.data[j]
            if kind == SPATIAL_TRANSLATION:
                lam = x[mr]
                x[own[:3]] = x[mt] + 0.5 * np.einsum("kij,i,j->k", data.reshape(3, 4, 4), lam,
                                                      lam)
            elif kind == SPATIAL_ROTATION:
                x[own] = data[:16].reshape(4, 4) @ x[mr]
            elif kind == PLANAR_TRANSLATION:
                x[own[:2]] = x[mt[:2]] + _planar(x[mr[0]]) @ data[:2]
            else:
                x[own[0]] = x[mr[0]] + data[0]
        return x

    def weights(self, x):
        """T's entries (n_slave_coordinates, DEPENDENCIES): d x_s / d x_master at x, in the
        order of `dependencies`."""
        W = np.zeros(self.dependencies.shape)
        row = 0
        for j, kind in enumerate(self.kinds):
            mr, data = self.rotation[j], self.data[j]
            if kind == SPATIAL_TRANSLATION:
                C = data.reshape(3, 4, 4)
                for k in range(3):
                    W[row + k] = [1.0, *(C[k] @ x[mr])]
                row += 3
            elif kind == SPATIAL_ROTATION:
                W[row: row + 4, :4] = data[:16].reshape(4, 4)
                row += 4
            elif kind == PLANAR_TRANSLATION:
                d = _planar_derivative(x[mr[0]]) @ data[:2]
                W[row: row + 2, :2] = [[1.0, d[0]], [1.0, d[1]]]
                row += 2
            else:
                W[row, 0] = 1.0
                row += 1
        return W

    def transform(self, x, nx):
        """T (NX, NX) = dx/dx with the slaves' coordinates expressed by their masters':
        the identity on every other coordinate, zero columns on the slave coordinates."""
        T = np.eye(nx)
        T[:, self.slave_coordinates] = 0.0
        T[self.slave_coordinates] = 0.0
        W = self.weights(x)
        for s, c in enumerate(self.slave_coordinates):
            for d, dep in enumerate(self.dependencies[s]):
                if dep >= 0:
                    T[c, dep] += W[s, d]
        return T

    def convective(self, x, xdot):
        """c (NX,): the second-order part of the slaves' accelerations, xddot = T xddot_master
        + c, for the masters' velocities in xdot (zero but on slave translations)."""
        c = np.zeros(np.shape(x))
        for j, kind in enumerate(self.kinds):
            own, mr, data = self.own[j], self.rotation[j], self.data[j]
            if kind == SPATIAL_TRANSLATION:
                v = xdot[mr]
                c[own[:3]] = np.einsum("kij,i,j->k", data.reshape(3, 4, 4), v, v)
            elif kind == PLANAR_TRANSLATION:
                c[own[:2]] = -_planar(x[mr[0]]) @ data[:2] * xdot[mr[0]] ** 2
        return c

    def curvature(self, x, force, nx):
        """sum_s f_s d2 x_s / d x_master2 (NX, NX) for coordinate forces f (NX,) on the slave
        translations (N): nonzero on the masters' rotation coordinates only."""
        H = np.zeros((nx, nx))
        for j, kind in enumerate(self.kinds):
            own, mr, data = self.own[j], self.rotation[j], self.data[j]
            if kind == SPATIAL_TRANSLATION:
                H[np.ix_(mr, mr)] += np.einsum("k,kij->ij", force[own[:3]],
                                               data.reshape(3, 4, 4))
            elif kind == PLANAR_TRANSLATION:
                H[mr[0], mr[0]] -= force[own[:2]] @ (_planar(x[mr[0]]) @ data[:2])
        return H


def _padded(values, size):
    out = np.full(size, -1, dtype=np.int64)
    out[: len(values)] = values
    return out


def _planar(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


def _planar_derivative(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[-s, -c], [c, -s]])
