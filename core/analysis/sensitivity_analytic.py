"""Analytic design sensitivities for parameters the matrices are linear in.

Which keys qualify (`nonlinearity`): a key p qualifies when the model built with p, p + d
and p + 2 d (d = |p|, or 1 in the key's unit where p = 0) differs only in

    the deformation stiffness S and damping D (NE, NE)     (EA/l0, EI/l0, ...)
    the lumped masses, the elements' inertia matrices Mp and the nodes' rigid-body inertias

and each of those is affine in p: its second difference X(p + 2d) - 2 X(p + d) + X(p) is
zero to round-off (1e-10 of the largest entry). Everything else (initial coordinates, the
elements' references l0 and Ip_A, statuses, loads, gravity, ports, actuators) must be equal
to the last bit. This is checked on the model for every key, not read from a list: a mass,
rho_A, EA, EI, GIt, E and rho qualify, and so does a planar section's width (EA, EI and rho_A
are all proportional to it), while its height (EI ~ height^3), a node's position (l0 and the
kinematics) or a spatial section's width (the torsion constant) do not. Where it holds,
K0 = DF^T De^T S De DF, C0 and M0 = DF^T M DF at a fixed configuration are affine in p, and so
is the generalised force Q = DF^T (f - De^T S e) (gravity is linear in the masses), so

    dK0/dp = (K0(p + d) - K0(p)) / d,   dM0/dp, dQ/dp likewise,

evaluated at the base model's configuration: exact, not a difference quotient.

The derivatives (`analytic_derivatives`), with K = K0 + G0 the tangent stiffness:

    eigenvalue lambda = omega^2, phi mass-normalised:
                                        dlambda/dp = phi^T (dK/dp - lambda dM/dp) phi
        and f = sign(lambda) sqrt|lambda| / (2 pi):     df/dp = dlambda/dp / (8 pi^2 |f|)
    static DOFs, Q(q(p), p) = 0:                        dq/dp = K^-1 dQ/dp
        (= -K^-1 dK/dp u for u = K^-1 f), and an output y(x(q)): dy/dp = (dy/dq) dq/dp
    compliance C = H DF K^-1 DF^T H^T:                  dC/dp = -H DF K^-1 dK/dp K^-1 DF^T H^T
    DC gain G = C_q K^-1 F (at DC M0 and C0 drop out):  dG/dp = -C_q K^-1 dK/dp X, X = K^-1 F

The static displacements are exact with a preload too: dQ/dp is taken at the equilibrium and
K there is the full tangent, G0 included. The frequencies, compliances and DC gains use
dK/dp = dK0/dp, which needs G0 not to depend on p: true for a scene without load (no force,
no moment, no gravity), whose equilibrium is the initial configuration with zero stress
resultants for every p. With a preload, G0 follows p through the stress resultants and the
deformed configuration; those quantities then go to the difference scheme, as do the
buckling factors (G0 of the reference load's equilibrium) and the largest von Mises stress
(neither linear in any key nor smooth where its place moves).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..mechanics import assembly
from ..mechanics.mechanics import Mechanics

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model
    from .sensitivity_quantities import Evaluation

AFFINE_RTOL = 1e-10  # a second difference within this of the largest entry is round-off


def _fixed_parts(model):
    """What must stay equal to the last bit for a key to qualify (module docstring)."""
    parts = [model.initial_coordinates, model.loads, model.gravity,
             np.asarray(model.coordinate_status, str), np.asarray(model.deformation_status, str),
             np.zeros(0) if model.buckling_loads is None else model.buckling_loads]
    for group in model.groups:
        parts += [group.coordinate_index, group.deformation_index]
        parts += [np.asarray(group.reference[key]) for key in sorted(group.reference)]
    parts += [np.asarray([idx for idx, _ in model.node_inertias])]
    return parts, (model.inputs, model.outputs, model.actuators, model.nodes,
                   [g.names for g in model.groups], [g.kind.__name__ for g in model.groups])


def _linear_parts(model):
    """The matrices that may change, each affine in the key (module docstring)."""
    S, D = assembly.stiffness_and_damping(model)
    parts = [S, D, model.lumped_mass]
    for group in model.groups:
        if hasattr(group.kind, "inertia_matrix"):
            parts.append(group.kind.inertia_matrix(group.reference, group.properties))
    parts += [np.asarray(J, float) for _, J in model.node_inertias]
    return parts


def nonlinearity(models: tuple[Model, Model, Model]) -> str:
    """Why the matrices are not linear in the key that `models` (built at p, p + d, p + 2 d)
    differ in, or "" when they are (module docstring)."""
    fixed = [_fixed_parts(m) for m in models]
    for other in fixed[1:]:
        if other[1] != fixed[0][1] or len(other[0]) != len(fixed[0][0]):
            return "it changes the model's structure or its ports"
        if not all(a.shape == b.shape and np.array_equal(a, b)
                   for a, b in zip(fixed[0][0], other[0], strict=True)):
            return "it changes the geometry, the references or the loads"
    linear = [_linear_parts(m) for m in models]
    if len({len(parts) for parts in linear}) != 1:
        return "it changes which elements carry mass"
    for a, b, c in zip(*linear, strict=True):
        scale = max(np.max(np.abs(a), initial=0.0), np.max(np.abs(c), initial=0.0))
        if np.max(np.abs(c - 2.0 * b + a), initial=0.0) > AFFINE_RTOL * scale:
            return "the stiffness or mass is not linear in it"
    return ""


def matrix_derivatives(base: Evaluation, stepped: Model, d: float) -> tuple:
    """(dK0/dp, dM0/dp, dQ/dp) at the base configuration: the exact slopes of quantities
    affine in p, from the model built at p + d (module docstring)."""
    config, solution = base.solution.config, base.solution
    mech, other = base.mechanics, Mechanics(stepped)
    dK = (other.structural_stiffness(config) - mech.structural_stiffness(config)) / d
    dM = (other.mass_matrix(config) - mech.mass_matrix(config)) / d
    balance = [m.static_balance(config, solution.load_factor, inputs=solution.port_values)[0]
               for m in (other, mech)]
    return dK, dM, (balance[0] - balance[1]) / d


def analytic_derivatives(base: Evaluation, stepped: Model, d: float, *,
                         preloaded: bool) -> tuple[np.ndarray, np.ndarray]:
    """(d quantity / dp (n,), which of them are analytic (n,) bool) for a key the matrices
    are linear in (module docstring); the others are NaN, left to the difference scheme."""
    dK, dM, dQ = matrix_derivatives(base, stepped, d)
    K = base.linear_model.K
    kinds = np.array(base.kinds, dtype=object)
    result = np.full(kinds.size, np.nan)
    outputs = np.flatnonzero(kinds == "output")
    if outputs.size:
        result[outputs] = base.output_rows @ np.linalg.solve(K, dQ)
    if not preloaded:
        frequencies = np.flatnonzero(kinds == "frequency")
        if frequencies.size:
            phi = base.shapes[:, :frequencies.size]
            lam = base.eigenvalues[:frequencies.size]
            dlam = np.einsum("ij,ik,kj->j", phi, dK, phi) - lam * np.einsum(
                "ij,ik,kj->j", phi, dM, phi)
            f = np.abs(base.values[frequencies])
            result[frequencies] = dlam / (8.0 * np.pi**2 * f)
        compliance = np.flatnonzero(kinds == "compliance")
        start = 0
        for rows, zero in base.compliance_rows:
            solved = np.linalg.solve(K, rows.T)  # K^-1 DF^T H^T
            dC = -solved.T @ dK @ solved
            dC = 0.5 * (dC + dC.T)  # symmetric in exact arithmetic (no load: conservative)
            dC[zero, :] = 0.0
            dC[:, zero] = 0.0
            result[compliance[start:start + dC.size]] = dC.ravel()
            start += dC.size
        gains = np.flatnonzero(kinds == "dc_gain")
        if gains.size:
            dG = -base.dc_rows @ np.linalg.solve(K, dK @ base.dc_displacements)
            result[gains] = dG.T.ravel()  # the order of `evaluate`: by input, then output
    return result, ~np.isnan(result)
