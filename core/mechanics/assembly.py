"""Assembly of element quantities into model vectors and matrices.

Each function evaluates every element group at once and scatters the result into the model's
coordinate (NX) and deformation (NE) numbering. Dense matrices for the models of tens to a
few hundred coordinates; the (NX, NX) Hessian and mass matrix also as scipy.sparse ones for
the large (`Mechanics.sparse`: from `kinematics.SPARSE_FROM` free coordinates on).

Scattering: an entry (deformation, coordinate) belongs to one element, so De is assigned;
elements share coordinates, so (coordinate, coordinate) entries and coordinate vectors are
summed with `np.bincount` over flat indices cached per group (`scatter_matrix`,
`scatter_vector`; `np.add.at` is an order of magnitude slower on small arrays).
"""

import weakref

import numpy as np

from ..elements.rotary_inertia import node_inertia_groups

# id(group) -> (weak reference to the group, nx, flat indices of its (coordinate, coordinate)
# pairs); an entry goes with its group, so that a process that builds model after model (an
# FMU host instantiating again and again) keeps none of them alive
_PAIRS = {}


def pair_index(group, nx):
    """Flat indices (n m m,) into an (NX, NX) matrix of each element's (coordinate, coordinate)
    pairs of `group`, in the order of its element matrices (n, m, m); cached per group."""
    key = id(group)
    hit = _PAIRS.get(key)
    if hit is None or hit[0]() is not group or hit[1] != nx:
        idx = group.coordinate_index
        reference = weakref.ref(group, lambda _, key=key: _PAIRS.pop(key, None))
        hit = (reference, nx, (idx[:, :, None] * nx + idx[:, None, :]).ravel())
        _PAIRS[key] = hit
    return hit[2]


def scatter_matrix(result, group, local):
    """Add the element matrices local (n, m, m) of `group` into result (NX, NX) in place."""
    nx = result.shape[0]
    result += np.bincount(pair_index(group, nx), weights=local.ravel(),
                          minlength=nx * nx).reshape(nx, nx)
    return result


def scatter_vector(result, group, local):
    """Add the element vectors local (n, m) of `group` into result (NX,) in place."""
    result += np.bincount(group.coordinate_index.ravel(), weights=local.ravel(),
                          minlength=result.size)
    return result


def deformations(model, x):
    """All deformations e (NE,) at coordinates x (NX,), in m (or as the element defines)."""
    e = np.zeros(len(model.deformation_names))
    for group in model.groups:
        (local,) = group.kind.deformations(group.local(x), group.reference, order=0)
        e[group.deformation_index] = local
    return e


def deformation_jacobian(model, x):
    """Deformations e (NE,) and their Jacobian De = de/dx (NE, NX)."""
    e = np.zeros(len(model.deformation_names))
    De = np.zeros((e.size, model.nx))
    for group in model.groups:
        local_e, local_De = group.kind.deformations(group.local(x), group.reference, order=1)
        e[group.deformation_index] = local_e
        # every (deformation, coordinate) pair belongs to one element: plain assignment
        De[group.deformation_index[:, :, None], group.coordinate_index[:, None, :]] = local_De
    return e, De


def deformation_hessians(model, x):
    """Per group: (group, D2e (n, k, m, m)), the second derivatives of the deformations."""
    return [
        (group, group.kind.deformations(group.local(x), group.reference, order=2)[2])
        for group in model.groups
    ]


def weighted_hessian(model, hessians, weights, *, sparse=False):
    """sum_i weights_i d2e_i/dx2 as an (NX, NX) matrix; weights (NE,). With `sparse`, a
    scipy.sparse CSR matrix (its entries, the elements' coordinate pairs, summed)."""
    if sparse:
        return sparse_sum(model.nx, [
            (group, (weights[group.deformation_index][:, None, :]
                     @ D2e.reshape(D2e.shape[0], D2e.shape[1], -1)))
            for group, D2e in hessians])
    result = np.zeros((model.nx, model.nx))
    for group, D2e in hessians:
        n, k, m, _ = D2e.shape
        local = weights[group.deformation_index][:, None, :] @ D2e.reshape(n, k, m * m)
        scatter_matrix(result, group, local)
    return result


def sparse_sum(nx, parts, diagonal=None):
    """The (NX, NX) CSR matrix of the element matrices of `parts`, [(group, local (n, m, m)
    or (n, 1, m m))], summed where elements share coordinates, plus `diagonal` (NX,)."""
    from scipy.sparse import coo_matrix  # large models only (`Mechanics.sparse`)

    rows, columns, data = [], [], []
    for group, local in parts:
        idx = group.coordinate_index
        m = idx.shape[1]
        rows.append(np.broadcast_to(idx[:, :, None], (idx.shape[0], m, m)).ravel())
        columns.append(np.broadcast_to(idx[:, None, :], (idx.shape[0], m, m)).ravel())
        data.append(np.ravel(local))
    if diagonal is not None:
        rows.append(np.arange(nx))
        columns.append(np.arange(nx))
        data.append(np.asarray(diagonal, dtype=float))
    if not data:
        return coo_matrix((nx, nx)).tocsr()
    return coo_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(columns))),
                      shape=(nx, nx)).tocsr()


def hessian_quadratic_forms(model, hessians, v):
    """v^T (d2e_i/dx2) v for every deformation i (NE,); v (NX,) or (NX, r) -> (NE, r)."""
    if v.ndim == 1:  # the convective term of every moving evaluation: batched matrix products
        result = np.zeros(len(model.deformation_names))
        for group, D2e in hessians:
            n, k, m, _ = D2e.shape
            local_v = v[group.coordinate_index]
            vv = (local_v[:, :, None] * local_v[:, None, :]).reshape(n, m * m, 1)
            result[group.deformation_index] = (D2e.reshape(n, k, m * m) @ vv)[:, :, 0]
        return result
    result = np.zeros((len(model.deformation_names), v.shape[1]))
    for group, D2e in hessians:
        local_v = v[group.coordinate_index]  # (n, m, r)
        result[group.deformation_index] = np.einsum("nkij,nir,njr->nkr", D2e, local_v, local_v)
    return result


def stiffness_and_damping(model):
    """Block-diagonal deformation stiffness S and damping D (NE, NE), N/m and N s/m."""
    size = len(model.deformation_names)
    S = np.zeros((size, size))
    D = np.zeros((size, size))
    for group in model.groups:
        idx = group.deformation_index
        rows, cols = idx[:, :, None], idx[:, None, :]
        S[rows, cols] = group.kind.stiffness(group.reference, group.properties)
        D[rows, cols] = group.kind.damping(group.reference, group.properties)
    return S, D


class Inertia:
    """The mass of a model: lumped masses plus the elements' consistent masses.

    Element mass acts through inertia points p(x) with a constant mass matrix Mp, so that
    the kinetic energy is 1/2 pdot^T Mp pdot with pdot = Dp xdot. Rigid-body inertias on
    3-D rotational nodes (Euler parameters) take the same form (`rotary_inertia`) and are one
    more entry of `groups`.
    """

    def __init__(self, model):
        self.model = model
        self.lumped = model.lumped_mass
        self.groups = [
            (group, group.kind.inertia_matrix(group.reference, group.properties))
            for group in model.groups
            if np.any(group.properties.get("rho_A", 0.0))
        ]
        self.groups += node_inertia_groups(model)

    def mass_matrix(self, x):
        """M(x) (NX, NX) in kg (kg m on translation-rotation, kg m^2 on rotations)."""
        M = np.diag(self.lumped).astype(float)
        for group, Mp in self.groups:
            _, Dp = group.kind.inertia_points(group.local(x), group.reference, order=1)
            scatter_matrix(M, group, np.einsum("npi,npr,nrj->nij", Dp, Mp, Dp))
        return M

    def sparse_mass_matrix(self, x):
        """M(x) as a scipy.sparse CSR matrix (NX, NX): the same entries as `mass_matrix`."""
        parts = []
        for group, Mp in self.groups:
            _, Dp = group.kind.inertia_points(group.local(x), group.reference, order=1)
            parts.append((group, np.einsum("npi,npr,nrj->nij", Dp, Mp, Dp)))
        return sparse_sum(self.model.nx, parts, diagonal=self.lumped)

    def convective_force(self, x, v):
        """The velocity-dependent inertia force sum Dp^T Mp (D2p v) v (NX,), in N."""
        result = np.zeros(self.model.nx)
        for group, Mp in self.groups:
            local_v = v[group.coordinate_index]
            _, Dp, D2p = group.kind.inertia_points(group.local(x), group.reference, order=2)
            accel = np.einsum("npij,ni,nj->np", D2p, local_v, local_v)
            scatter_vector(result, group, np.einsum("npi,npr,nr->ni", Dp, Mp, accel))
        return result

    def gravity_force(self, x):
        """Generalised gravity force (NX,) in N: lumped masses and distributed element mass."""
        model = self.model
        g = model.gravity
        result = np.zeros(model.nx)
        if not np.any(g):
            return result
        result += self.lumped * self._translation_gravity(g)
        for group, Mp in self.groups:
            _, Dp = group.kind.inertia_points(group.local(x), group.reference, order=1)
            g_points = point_gravity(group, g)
            scatter_vector(result, group, np.einsum("npi,npr,r->ni", Dp, Mp, g_points))
        return result

    def gravity_stiffness(self, x):
        """d(gravity force)/dx (NX, NX): non-zero where element mass hangs on a rotation."""
        model = self.model
        result = np.zeros((model.nx, model.nx))
        if not np.any(model.gravity):
            return result
        for group, Mp in self.groups:
            _, _, D2p = group.kind.inertia_points(group.local(x), group.reference, order=2)
            weights = Mp @ point_gravity(group, model.gravity)
            scatter_matrix(result, group, np.einsum("np,npij->nij", weights, D2p))
        return result

    def _translation_gravity(self, g):
        """g spread over the coordinates: component d of g on every translation along axis d
        (the model's node table)."""
        axes = "xyz"[: self.model.dimension]
        per_coordinate = np.zeros(self.model.nx)
        for i in self.model.translations:
            per_coordinate[i] = g[axes.index(self.model.coordinate_axis[i])]
        return per_coordinate


def point_gravity(group, g):
    """Gravity on the inertia points: g on position points, zero on tangent points."""
    return np.concatenate(
        [g if kind == "position" else np.zeros_like(g) for kind in group.kind.inertia_point_kinds]
    )
