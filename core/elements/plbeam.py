"""PLBEAM: the planar beam element (SPACAR), three deformations.

Nodal coordinates of one element, in this order (m, rad):

    x = [x^p, y^p, phi^p, x^q, y^q, phi^q]

With l = r^q - r^p and n_y^p, n_y^q the element's initial y axis rotated with the nodes:

    e2 = -(n_y^p . l)                                          bending at p (m)
    e3 =  (n_y^q . l)                                          bending at q (m)
    e1 = |l| - l0 + (2 e2^2 + e2 e3 + 2 e3^2) / (30 l0)        elongation (m)

The second-order terms in e1 are those of the cubic bending line; they give the consistent
geometric stiffness, hence 10 EI / l0^2 per clamped-guided spring with one element.

Stress resultants: sigma1 = EA / l0 e1 (N), and the bending moments
[sigma2, sigma3] = EI / l0^3 [[4, -2], [-2, 4]] [e2, e3] (N, as e2 and e3 are lengths).

Distributed mass: the position along the beam is the cubic (Hermite) interpolation between the
end positions r^p, r^q and the end tangents l0 t^p, l0 t^q (t the initial element x axis rotated
with the node), which gives the consistent mass rho A l0 / 420 [[156, 22, 54, -13], ...] on
those eight inertia points. The cross-section's own rotational inertia is neglected.

Every function works on all elements of this type at once: arrays shaped (n_elements, ...).
"""

import numpy as np

type_name = "PLBEAM"
dimension = 2
node_kinds = ("translational", "rotational", "translational", "rotational")
node_roles = ("p", "p", "q", "q")
deformation_names = ("e1", "e2", "e3")
deformation_stiffness = {"e1": "EA", "e2": "EI", "e3": "EI"}  # property per deformation
coordinates_per_element = 6
inertia_point_kinds = ("position", "tangent", "position", "tangent")
properties = ("EA", "EI", "EdA", "EdI", "rho_A")  # section properties used

_DL = np.array([[-1.0, 0.0, 0.0, 1.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0, 1.0, 0.0]])
_PHI_P, _PHI_Q = 2, 5
HERMITE_MASS = np.array(
    [[156.0, 22.0, 54.0, -13.0], [22.0, 4.0, 13.0, -3.0], [54.0, 13.0, 156.0, -22.0],
     [-13.0, -3.0, -22.0, 4.0]]
) / 420.0


def reference(x0):
    """Reference data from the initial coordinates x0 (n, 6).

    l0 (m); offset_p, offset_q (rad): the angle of the element's initial x axis minus the
    initial node angle, so that the current x axis at a node has angle phi + offset.
    """
    l_vec = x0 @ _DL.T
    angle = np.arctan2(l_vec[:, 1], l_vec[:, 0])
    return {
        "l0": np.linalg.norm(l_vec, axis=1),
        "offset_p": angle - x0[:, _PHI_P],
        "offset_q": angle - x0[:, _PHI_Q],
    }


def _unit(angle):
    return np.stack([np.cos(angle), np.sin(angle)], axis=1)


def _bending(x, l_vec, angle, sign, phi_index, order):
    """One bending deformation e = sign * (n_y . l), n_y = unit(angle + pi/2), as (e, De, D2e)."""
    n_y = _unit(angle + 0.5 * np.pi)
    dn_y = -_unit(angle)  # d n_y / d phi
    e = sign * np.einsum("na,na->n", n_y, l_vec)
    if order == 0:
        return e, None, None
    De = sign * (n_y @ _DL)
    De[:, phi_index] += sign * np.einsum("na,na->n", dn_y, l_vec)
    if order == 1:
        return e, De, None
    n = x.shape[0]
    D2e = np.zeros((n, 6, 6))
    cross = sign * (dn_y @ _DL)
    D2e[:, phi_index, :] += cross
    D2e[:, :, phi_index] += cross
    D2e[:, phi_index, phi_index] += -e  # d2 n_y / d phi2 = -n_y
    return e, De, D2e


def deformations(x, ref, order=2):
    """Deformations e (n, 3) m, first (n, 3, 6) and second (n, 3, 6, 6) derivatives."""
    l0 = ref["l0"]
    l_vec = x @ _DL.T
    length = np.linalg.norm(l_vec, axis=1)
    e2, De2, D2e2 = _bending(x, l_vec, x[:, _PHI_P] + ref["offset_p"], -1.0, _PHI_P, order)
    e3, De3, D2e3 = _bending(x, l_vec, x[:, _PHI_Q] + ref["offset_q"], 1.0, _PHI_Q, order)
    c = 1.0 / (30.0 * l0)
    e1 = length - l0 + c * (2 * e2**2 + e2 * e3 + 2 * e3**2)
    e = np.stack([e1, e2, e3], axis=1)
    if order == 0:
        return (e,)
    unit = l_vec / length[:, None]
    de1_de2 = c * (4 * e2 + e3)
    de1_de3 = c * (e2 + 4 * e3)
    De1 = unit @ _DL + de1_de2[:, None] * De2 + de1_de3[:, None] * De3
    De = np.stack([De1, De2, De3], axis=1)
    if order == 1:
        return e, De
    projector = (np.eye(2)[None] - unit[:, :, None] * unit[:, None, :]) / length[:, None, None]
    outer = lambda a, b: a[:, :, None] * b[:, None, :]  # noqa: E731
    D2e1 = (
        np.einsum("ai,nab,bj->nij", _DL, projector, _DL)
        + c[:, None, None]
        * (4 * outer(De2, De2) + outer(De2, De3) + outer(De3, De2) + 4 * outer(De3, De3))
        + de1_de2[:, None, None] * D2e2
        + de1_de3[:, None, None] * D2e3
    )
    return e, De, np.stack([D2e1, D2e2, D2e3], axis=1)


def stiffness(ref, props):
    """Deformation stiffness (n, 3, 3): EA / l0 and EI / l0^3 [[4, -2], [-2, 4]] (N/m)."""
    return _constitutive(ref["l0"], props["EA"], props["EI"])


def damping(ref, props):
    """Deformation damping (n, 3, 3) from EdA and EdI, as the stiffness (N s/m)."""
    return _constitutive(ref["l0"], props["EdA"], props["EdI"])


def _constitutive(l0, axial, flexural):
    matrix = np.zeros((l0.size, 3, 3))
    matrix[:, 0, 0] = axial / l0
    matrix[:, 1:, 1:] = (flexural / l0**3)[:, None, None] * np.array([[4.0, -2.0], [-2.0, 4.0]])
    return matrix


def inertia_points(x, ref, order=2):
    """The Hermite interpolation points [r^p, l0 t^p, r^q, l0 t^q] (n, 8) and derivatives."""
    l0 = ref["l0"]
    t_p = _unit(x[:, _PHI_P] + ref["offset_p"])
    t_q = _unit(x[:, _PHI_Q] + ref["offset_q"])
    p = np.concatenate([x[:, 0:2], l0[:, None] * t_p, x[:, 3:5], l0[:, None] * t_q], axis=1)
    if order == 0:
        return (p,)
    n = x.shape[0]
    Dp = np.zeros((n, 8, 6))
    Dp[:, 0:2, 0:2] = np.eye(2)
    Dp[:, 4:6, 3:5] = np.eye(2)
    perp = lambda t: np.stack([-t[:, 1], t[:, 0]], axis=1)  # noqa: E731
    Dp[:, 2:4, _PHI_P] = l0[:, None] * perp(t_p)
    Dp[:, 6:8, _PHI_Q] = l0[:, None] * perp(t_q)
    if order == 1:
        return p, Dp
    D2p = np.zeros((n, 8, 6, 6))
    D2p[:, 2:4, _PHI_P, _PHI_P] = -l0[:, None] * t_p
    D2p[:, 6:8, _PHI_Q, _PHI_Q] = -l0[:, None] * t_q
    return p, Dp, D2p


def inertia_matrix(ref, props):
    """Consistent mass (n, 8, 8) in kg on the inertia points of `inertia_points`."""
    mass = props["rho_A"] * ref["l0"]
    return mass[:, None, None] * np.kron(HERMITE_MASS, np.eye(2))[None]
