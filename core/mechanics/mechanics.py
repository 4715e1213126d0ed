"""Forces and their tangents in a solved configuration: the pieces statics, linearisation
and the equations of motion share.

With sigma_c = S e (+ D edot) the constitutive stress resultants of the stressed (released
and DOF) deformations, the coordinate-space force balance is

    r_x = f(x) - De^T sigma_c                      (NX,)   N, N m

and the generalised force on the DOFs is Q = DF^T r_x. The multipliers lambda = J^-T r_x
give the stress resultants of the rigid deformations (reaction forces); together with sigma_c
they form the stress resultants sigma of every deformation. The tangent stiffness is

    K = DF^T (De_s^T S De_s) DF  +  DF^T (sum_i sigma_i d2e_i/dx2 - df/dx) DF
        structural K0               geometric G0 (at equilibrium; out of it, the unbalanced
                                    DOF forces enter through the DOF-deformation rows)
"""

from dataclasses import dataclass

import numpy as np

from . import assembly
from .kinematics import Kinematics
from .ports import input_forces, input_stiffness


@dataclass
class Mechanics:
    """A model's kinematics, inertia and constitutive matrices, built once and reused."""

    model: object

    def __post_init__(self):
        model = self.model
        self.kinematics = Kinematics(model)
        self.inertia = assembly.Inertia(model)
        S, D = assembly.stiffness_and_damping(model)
        stressed = model.stressed_deformations
        self.stressed = stressed
        self.S = S[np.ix_(stressed, stressed)]
        self.D = D[np.ix_(stressed, stressed)]
        self.has_damping = bool(np.any(self.D))

    def initial_configuration(self):
        """The configuration of the scene's initial coordinates."""
        x0 = self.model.initial_coordinates
        return self.kinematics.configuration(self.kinematics.dofs_of(x0), x0.copy())

    def external_force(self, x, load_factor=1.0, loads=None, inputs=None):
        """Nodal loads plus gravity (NX,), both scaled by load_factor; with `inputs`
        (n_inputs,) N, N m also their generalised force at x (`ports.input_forces`)."""
        loads = self.model.loads if loads is None else loads
        force = load_factor * (loads + self.inertia.gravity_force(x))
        if inputs is not None:
            force += load_factor * input_forces(self.model, x, inputs)
        return force

    def constitutive_stress(self, config, edot=None):
        """sigma_c (NE,): S e (+ D edot) on stressed deformations, zero on rigid ones."""
        sigma = np.zeros(config.e.size)
        stressed = self.stressed
        sigma[stressed] = self.S @ config.e[stressed]
        if edot is not None and self.has_damping:
            sigma[stressed] += self.D @ edot[stressed]
        return sigma

    def stress_resultants(self, config, force_balance, sigma_c):
        """sigma (NE,) of every deformation: sigma_c plus the multipliers lambda = J^-T r_x."""
        kin = self.kinematics
        multipliers = kin.multipliers(config, force_balance)
        sigma = sigma_c.copy()
        sigma[kin.constraint_rows] += multipliers[: kin.constraint_rows.size]
        return sigma

    def static_balance(self, config, load_factor=1.0, loads=None, inputs=None):
        """(Q, r_x, sigma): the generalised force on the DOFs at rest, its coordinate-space
        force balance and the stress resultants of all deformations (under the loads and,
        if given, the inputs (n_inputs,) N, N m)."""
        sigma_c = self.constitutive_stress(config)
        r_x = self.external_force(config.x, load_factor, loads, inputs) - config.De.T @ sigma_c
        Q = config.DF.T @ r_x
        return Q, r_x, self.stress_resultants(config, r_x, sigma_c)

    def structural_stiffness(self, config):
        """K0 = DF^T De_s^T S De_s DF (NDOF, NDOF)."""
        DeF = config.De[self.stressed] @ config.DF
        return DeF.T @ self.S @ DeF

    def damping_matrix(self, config):
        """C0 = DF^T De_s^T D De_s DF (NDOF, NDOF)."""
        DeF = config.De[self.stressed] @ config.DF
        return DeF.T @ self.D @ DeF

    def geometric_stiffness(self, config, sigma, load_factor=1.0, hessians=None, inputs=None):
        """G0 = DF^T (sum_i sigma_i d2e_i/dx2 - df/dx) DF (NDOF, NDOF); df/dx includes the
        load stiffness of the moment inputs when `inputs` (n_inputs,) are given."""
        if hessians is None:
            hessians = assembly.deformation_hessians(self.model, config.x)
        H = assembly.weighted_hessian(self.model, hessians, sigma)
        H -= load_factor * self.inertia.gravity_stiffness(config.x)
        if inputs is not None:
            H -= load_factor * input_stiffness(self.model, config.x, inputs)
        return config.DF.T @ H @ config.DF

    def mass_matrix(self, config):
        """M0 = DF^T M DF (NDOF, NDOF) in kg (and kg m, kg m^2 for rotations)."""
        return config.DF.T @ self.inertia.mass_matrix(config.x) @ config.DF
