"""EULER: the normalisation constraint of one spatial rotational node, as a pseudo-element.

Nodal coordinates: the node's Euler parameters x = [lambda0, lambda1, lambda2, lambda3].
Its single "deformation", always prescribed zero (SPACAR's normalisation constraint):

    norm = (lambda . lambda - 1) / 2,     D norm = lambda,     D2 norm = I.

The scene builder adds one per free 3-D rotational node (a fixed node needs none), so the
kinematics, the constraint Jacobian, the second-order kinematics and the multipliers treat it
like any other rigid deformation. It is not in the element registry: a scene cannot name it.
It has no stiffness, damping or mass.
"""

import numpy as np

from ..numerics.jit import kernel
from . import entries

type_name = "EULER"
dimension = 3
node_kinds = ("rotational",)
node_roles = ("p",)
deformation_names = ("norm",)
deformation_units = ("1",)  # dimensionless: its tolerance is not a length (mechanics.scales)
deformation_stiffness = {"norm": "none"}
coordinates_per_element = 4
inertia_point_kinds = ()
properties = ()
_EYE4 = np.eye(4)


def reference(x0):
    """No reference data but the number of nodes: the constraint is the same for each."""
    return {"ones": np.ones(x0.shape[0])}


def deformations(x, ref, order=2):
    """norm (n, 1), its first (n, 1, 4) and second (n, 1, 4, 4) derivatives."""
    e = 0.5 * (np.einsum("ni,ni->n", x, x) - 1.0)[:, None]
    if order == 0:
        return (e,)
    De = x[:, None, :].copy()
    if order == 1:
        return e, De
    D2e = np.empty((x.shape[0], 1, 4, 4))
    D2e[:] = _EYE4
    return e, De, D2e


def stiffness(ref, props):
    """No stiffness: the constraint is always rigid."""
    return np.zeros((ref["ones"].size, 1, 1))


def damping(ref, props):
    """No damping."""
    return stiffness(ref, props)


# -- compiled kernel ------------------------------------------------------------------------

REFERENCE_WIDTH = 1  # nothing is needed; one placeholder so that every group has a row


def pack_reference(ref):
    """(n, 1) float64 of ones (the constraint is the same for each node)."""
    return np.ascontiguousarray(np.asarray(ref["ones"], float)[:, None])


@kernel
def deformations_kernel(x, ref, order, e, De, D2e):
    """One node: norm (1,) and, by order, D norm = lambda (1, 4), D2 norm = I (1, 4, 4)."""
    e[0] = 0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3] - 1.0)
    if order == 0:
        return
    for i in range(4):
        De[0, i] = x[i]
    if order == 1:
        return
    for i in range(4):
        for j in range(4):
            D2e[0, i, j] = 1.0 if i == j else 0.0


deformations_entry = entries.deformations_entry(deformations_kernel)
