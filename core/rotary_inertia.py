"""Rotational inertia of 3-D rotational nodes described by Euler parameters.

A rigid body attached to a rotational node, with inertia tensor J (kg m^2) constant in the
node's body frame, has the kinetic energy

    T = 1/2 omega'^T J omega',     omega' = 2 G(lambda) lambda_dot     (body frame)

which is not of the form 1/2 pdot^T Mp pdot with a constant Mp that `assembly.Inertia` uses
for element mass, hence this extension. On the node's four Euler parameters:

    mass matrix            M(lambda) = 4 G(lambda)^T J G(lambda)
    convective force       h = d/dt(dT/d lambda_dot) - dT/d lambda - M lambda_ddot
                             = 4 G(lambda_dot)^T J omega'

(G is linear in its argument, G(a) a = 0, so dG/dt lambda_dot = G(lambda_dot) lambda_dot = 0
and dT/d lambda = -2 G(lambda_dot)^T J omega'). The parts of M and h along lambda are taken
by the normalisation constraint's multiplier; projected on the DOFs they give Euler's
equations J omega_dot' + omega' x J omega' = moment. The sources of J: lumped node inertias of
the scene (`Model.node_inertias`) and the section inertia of spatial beams, half at each end
(`node_inertias` of the element module). Rotational inertia carries no gravity.
"""

import numpy as np

from .rotations import body_rates_matrix


class RotaryInertia:
    """All rigid-body inertias on 3-D rotational nodes of a model: indices (m, 4), J (m, 3, 3)."""

    def __init__(self, model):
        self.nx = model.nx
        indices, tensors = [], []
        for index, J in getattr(model, "node_inertias", ()):
            indices.append(np.asarray(index, int)[None])
            tensors.append(np.asarray(J, float)[None])
        for group in model.groups:
            inertias = getattr(group.kind, "node_inertias", None)
            if inertias is None:
                continue
            J = inertias(group.reference, group.properties)  # (n, nodes, 3, 3)
            for node, slot in enumerate(group.kind.rotation_slots):
                indices.append(group.coordinate_index[:, slot])
                tensors.append(J[:, node])
        self.index = np.concatenate(indices) if indices else np.zeros((0, 4), int)
        self.J = np.concatenate(tensors) if tensors else np.zeros((0, 3, 3))
        keep = np.any(self.J != 0.0, axis=(1, 2))
        self.index, self.J = self.index[keep], self.J[keep]

    def __bool__(self):
        return bool(self.J.shape[0])

    def mass_matrix(self, x):
        """M (NX, NX) in kg m^2 on the Euler parameters: 4 G^T J G per node."""
        M = np.zeros((self.nx, self.nx))
        G = body_rates_matrix(x[self.index])
        local = 4.0 * np.einsum("nai,nab,nbj->nij", G, self.J, G)
        np.add.at(M, (self.index[:, :, None], self.index[:, None, :]), local)
        return M

    def convective_force(self, x, v):
        """h (NX,) in N m: 4 G(lambda_dot)^T J omega' per node."""
        result = np.zeros(self.nx)
        lam, lam_dot = x[self.index], v[self.index]
        omega = 2.0 * np.einsum("nai,ni->na", body_rates_matrix(lam), lam_dot)
        local = 4.0 * np.einsum("nai,nab,nb->ni", body_rates_matrix(lam_dot), self.J, omega)
        np.add.at(result, self.index, local)
        return result
