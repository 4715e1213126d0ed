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

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from . import assembly
from .kinematics import SPARSE_FROM, Kinematics
from .ports import input_forces, input_stiffness

if TYPE_CHECKING:  # names for the annotations only
    from scipy.sparse import csr_matrix

    from ..model import Model
    from .kinematics import Configuration, Hessians


@dataclass
class Mechanics:
    """A model's kinematics, inertia and constitutive matrices, built once and reused."""

    model: Model
    sparse: bool | None = None  # None: by the rule below (set only to compare the paths)

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
        # One rule for dense or sparse, the kinematics' (`SPARSE_FROM` free coordinates): a
        # large model's (NX, NX) Hessian, mass matrix and block-diagonal S and D are almost
        # empty, and their dense products with DF (NX, NDOF) took most of a Newton
        # iteration of the 507-DOF manipulator (0.13 of 0.18 s). The same matrices to
        # round-off (tests/test_sparse_mechanics.py).
        if self.sparse is None:
            self.sparse = model.free_coordinates.size >= SPARSE_FROM
        if self.sparse:
            from scipy.sparse import csr_matrix

            self._sparse_S, self._sparse_D = csr_matrix(self.S), csr_matrix(self.D)

    def initial_configuration(self, *, shared: bool = False) -> Configuration:
        """The configuration of the scene's initial coordinates.

        Parameters
        ----------
        shared : bool
            Return the one configuration this object keeps for its model's initial
            coordinates (formed on first use, and again when they change) instead of a new
            one: for readers that never change a configuration in place. The statics start
            every solve there, and forming it (DF for every DOF) took 25 ms of each of the
            manipulator report's 24 solves of the 507-DOF manipulator_reduced.

        Returns
        -------
        Configuration
            At the model's initial coordinates (m, rad), with their DOF values.
        """
        x0 = self.model.initial_coordinates
        if shared:
            kept = getattr(self, "_initial", None)
            if kept is None or not np.array_equal(kept.x, x0):
                kept = self._initial = self.initial_configuration()
            return kept
        return self.kinematics.configuration(self.kinematics.dofs_of(x0), x0.copy())

    def external_force(self, x: np.ndarray, load_factor: float = 1.0,
                       loads: np.ndarray | None = None,
                       inputs: np.ndarray | None = None) -> np.ndarray:
        """Nodal loads plus gravity, and the inputs' generalised force, scaled by a factor.

        Parameters
        ----------
        x : ndarray (NX,)
            The coordinates, m and rad (Euler parameters unitless).
        load_factor : float
            The factor on every load (unitless).
        loads : ndarray (NX,), optional
            Nodal forces, N (N m on rotations); default the model's loads.
        inputs : ndarray (n_inputs,), optional
            Values on the input ports, N or N m (`ports.input_forces` at x).

        Returns
        -------
        ndarray (NX,)
            f, N (N m on rotations).
        """
        loads = self.model.loads if loads is None else loads
        force = load_factor * (loads + self.inertia.gravity_force(x))
        if inputs is not None:
            force += load_factor * input_forces(self.model, x, inputs)
        return force

    def constitutive_stress(self, config: Configuration,
                            edot: np.ndarray | None = None) -> np.ndarray:
        """sigma_c = S e (+ D edot) on the stressed deformations, zero on the rigid ones.

        Parameters
        ----------
        config : Configuration
        edot : ndarray (NE,), optional
            The deformation rates, m/s, for the damping (default: none).

        Returns
        -------
        ndarray (NE,)
            sigma_c, N.
        """
        sigma = np.zeros(config.e.size)
        stressed = self.stressed
        sigma[stressed] = self.S @ config.e[stressed]
        if edot is not None and self.has_damping:
            sigma[stressed] += self.D @ edot[stressed]
        return sigma

    def stress_resultants(self, config: Configuration, force_balance: np.ndarray,
                          sigma_c: np.ndarray) -> np.ndarray:
        """sigma of every deformation: sigma_c plus the multipliers lambda = J^-T r_x.

        Parameters
        ----------
        config : Configuration
        force_balance : ndarray (NX,)
            r_x, the coordinate-space force balance, N (N m on rotations).
        sigma_c : ndarray (NE,)
            The constitutive stress resultants, N.

        Returns
        -------
        ndarray (NE,)
            sigma, N (reaction forces on the rigid deformations).
        """
        kin = self.kinematics
        multipliers = kin.multipliers(config, force_balance)
        sigma = sigma_c.copy()
        sigma[kin.constraint_rows] += multipliers[: kin.constraint_rows.size]
        return sigma

    def static_balance(self, config: Configuration, load_factor: float = 1.0,
                       loads: np.ndarray | None = None, inputs: np.ndarray | None = None,
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The force balance at rest under the loads and, if given, the inputs.

        Parameters
        ----------
        config : Configuration
        load_factor : float
            The factor on every load (unitless).
        loads : ndarray (NX,), optional
            Nodal forces, N (N m on rotations); default the model's loads.
        inputs : ndarray (n_inputs,), optional
            Values on the input ports, N or N m.

        Returns
        -------
        Q : ndarray (NDOF,)
            The unbalanced generalised force on the DOFs, N or N m.
        r_x : ndarray (NX,)
            Its coordinate-space force balance, N (N m on rotations).
        sigma : ndarray (NE,)
            The stress resultants of every deformation, N.
        """
        sigma_c = self.constitutive_stress(config)
        r_x = self.external_force(config.x, load_factor, loads, inputs) - config.De.T @ sigma_c
        Q = config.DF.T @ r_x
        return Q, r_x, self.stress_resultants(config, r_x, sigma_c)

    def structural_stiffness(self, config: Configuration) -> np.ndarray:
        """The structural stiffness K0 = DF^T De_s^T S De_s DF.

        Parameters
        ----------
        config : Configuration

        Returns
        -------
        ndarray (NDOF, NDOF)
            N/m in the DOF units (N m/rad on an angle DOF).
        """
        return self._on_dofs(config, self._sparse_S if self.sparse else self.S)

    def damping_matrix(self, config: Configuration) -> np.ndarray:
        """The damping matrix C0 = DF^T De_s^T D De_s DF.

        Parameters
        ----------
        config : Configuration

        Returns
        -------
        ndarray (NDOF, NDOF)
            N s/m in the DOF units (N m s/rad on an angle DOF).
        """
        return self._on_dofs(config, self._sparse_D if self.sparse else self.D)

    def _on_dofs(self, config, matrix):
        """DF^T De_s^T `matrix` De_s DF: a matrix on the stressed deformations (S or D) carried
        to the DOFs through the deformations' first-order transfer function De_s DF."""
        if self.sparse:
            DeF = self._stressed_jacobian(config.De) @ config.DF
            return DeF.T @ np.asarray(matrix @ DeF)
        DeF = config.De[self.stressed] @ config.DF
        return DeF.T @ matrix @ DeF

    def _stressed_jacobian(self, De):
        """De (NE, NX), dense or CSR, on the stressed deformations as a CSR matrix: a dense
        De gathered at the elements' (deformation, coordinate) pairs (scanning the dense De
        for its non-zeros took 6 ms a call, 4 s of the manipulator report's 50)."""
        from scipy.sparse import csr_matrix

        if not isinstance(De, np.ndarray):  # sparse already (`Kinematics.configuration`)
            return De.tocsr()[self.stressed]
        if getattr(self, "_pattern", None) is None:
            row_of = np.full(len(self.model.deformation_names), -1)
            row_of[self.stressed] = np.arange(self.stressed.size)
            pairs = [np.broadcast_arrays(group.deformation_index[:, :, None],
                                         group.coordinate_index[:, None, :])
                     for group in self.model.groups]
            rows = np.concatenate([d.ravel() for d, _ in pairs] or [np.zeros(0, int)])
            columns = np.concatenate([c.ravel() for _, c in pairs] or [np.zeros(0, int)])
            keep = row_of[rows] >= 0
            self._pattern = (rows[keep], columns[keep], row_of[rows[keep]])
        rows, columns, positions = self._pattern
        return csr_matrix((De[rows, columns], (positions, columns)),
                          shape=(self.stressed.size, De.shape[1]))

    def geometric_stiffness(self, config: Configuration, sigma: np.ndarray,
                            load_factor: float = 1.0, hessians: Hessians | None = None,
                            inputs: np.ndarray | None = None) -> np.ndarray:
        """The geometric stiffness G0 = DF^T (sum_i sigma_i d2e_i/dx2 - df/dx) DF.

        Parameters
        ----------
        config : Configuration
        sigma : ndarray (NE,)
            The stress resultants of every deformation, N.
        load_factor : float
            The factor on gravity and the inputs in df/dx (unitless).
        hessians : list of (ElementGroup, ndarray), optional
            The deformation Hessians at config.x, if already computed.
        inputs : ndarray (n_inputs,), optional
            Values on the input ports, N or N m: df/dx then includes the load stiffness of
            the moment inputs.

        Returns
        -------
        ndarray (NDOF, NDOF)
            N/m in the DOF units (N m/rad on an angle DOF).
        """
        if hessians is None:
            hessians = assembly.deformation_hessians(self.model, config.x)
        DF = config.DF
        if self.sparse:  # the Hessian sparse, the (rare) load stiffnesses dense beside it
            G = DF.T @ np.asarray(assembly.weighted_hessian(self.model, hessians, sigma,
                                                            sparse=True) @ DF)
            return G - self._load_stiffness(config, load_factor, inputs)
        H = assembly.weighted_hessian(self.model, hessians, sigma)
        H -= load_factor * self.inertia.gravity_stiffness(config.x)
        if inputs is not None:
            H -= load_factor * input_stiffness(self.model, config.x, inputs)
        return DF.T @ H @ DF

    def tangent_stiffness(self, config: Configuration, sigma: np.ndarray,
                          load_factor: float = 1.0,
                          inputs: np.ndarray | None = None) -> np.ndarray:
        """The tangent stiffness K0 + G0 = -dQ/dq of the statics, in one product.

        The same matrix as `structural_stiffness` plus `geometric_stiffness` (to round-off);
        on the sparse path the two coordinate-space matrices De_s^T S De_s and
        sum_i sigma_i d2e_i/dx2 are summed before they are carried to the DOFs, so that
        the dense product with DF (NX, NDOF), most of the cost, is made once, not twice
        (20 instead of 31 ms on the 507-DOF manipulator).

        Parameters
        ----------
        config : Configuration
        sigma : ndarray (NE,)
            The stress resultants of every deformation, N.
        load_factor : float
            The factor on gravity and the inputs in df/dx (unitless).
        inputs : ndarray (n_inputs,), optional
            Values on the input ports, N or N m (their load stiffness).

        Returns
        -------
        ndarray (NDOF, NDOF)
            N/m in the DOF units (N m/rad on an angle DOF).
        """
        if not self.sparse:
            return self.structural_stiffness(config) + self.geometric_stiffness(
                config, sigma, load_factor, inputs=inputs)
        DF = config.DF
        K = DF.T @ np.asarray(self.coordinate_stiffness(config, sigma) @ DF)
        return K - self._load_stiffness(config, load_factor, inputs)

    def coordinate_stiffness(self, config: Configuration, sigma: np.ndarray) -> csr_matrix:
        """De_s^T S De_s + sum_i sigma_i d2e_i/dx2 on the coordinates, sparse (a model on
        the sparse path only): `tangent_stiffness`' K is DF^T (this) DF less the load
        stiffness.

        Parameters
        ----------
        config : Configuration
            Its DF is not read.
        sigma : ndarray (NE,)
            The stress resultants of every deformation, N.

        Returns
        -------
        scipy.sparse.csr_matrix (NX, NX)
            N/m (N/rad, N m/rad where rotations are involved).
        """
        stressed = self._stressed_jacobian(config.De)
        hessians = assembly.deformation_hessians(self.model, config.x)
        return (stressed.T @ (self._sparse_S @ stressed)
                + assembly.weighted_hessian(self.model, hessians, sigma, sparse=True))

    def load_stiffness(self, x: np.ndarray, load_factor: float = 1.0,
                       inputs: np.ndarray | None = None) -> np.ndarray | None:
        """df/dx of gravity and the inputs on the coordinates, scaled by load_factor, or None
        where there is none (no gravity, no input values).

        Parameters
        ----------
        x : ndarray (NX,)
            The coordinates, m and rad.
        load_factor : float
            The factor on gravity and the inputs (unitless).
        inputs : ndarray (n_inputs,), optional
            Values on the input ports, N or N m.

        Returns
        -------
        ndarray (NX, NX) or None
            N/m (N m/rad on rotations).
        """
        parts = []
        if np.any(self.model.gravity):
            parts.append(self.inertia.gravity_stiffness(x))
        if inputs is not None and np.any(inputs):
            parts.append(input_stiffness(self.model, x, inputs))
        return load_factor * sum(parts) if parts else None

    def _load_stiffness(self, config, load_factor, inputs):
        """DF^T (df/dx) DF of gravity and the inputs (NDOF, NDOF), scaled by load_factor;
        dense beside the sparse Hessian (rare: element mass on rotations, moments about
        global axes)."""
        DF = config.DF
        K = np.zeros((DF.shape[1], DF.shape[1]))
        if np.any(self.model.gravity):
            K += load_factor * (DF.T @ (self.inertia.gravity_stiffness(config.x) @ DF))
        if inputs is not None and np.any(inputs):
            K += load_factor * (DF.T @ (input_stiffness(self.model, config.x, inputs) @ DF))
        return K

    def coordinate_mass(self, x: np.ndarray) -> np.ndarray | csr_matrix:
        """The mass matrix M on the coordinates, as `mass_matrix` takes it.

        Parameters
        ----------
        x : ndarray (NX,)
            The coordinates, m (translations) and the rotation parameters.

        Returns
        -------
        csr_matrix or ndarray (NX, NX)
            Sparse on a sparse Mechanics, else dense; kg (kg m, kg m^2 on rotation
            parameters).
        """
        if self.sparse:
            return self.inertia.sparse_mass_matrix(x)
        return self.inertia.mass_matrix(x)

    def mass_matrix(self, config: Configuration,
                    coordinate_mass: np.ndarray | csr_matrix | None = None) -> np.ndarray:
        """The reduced mass matrix M0 = DF^T M DF.

        Parameters
        ----------
        config : Configuration
        coordinate_mass : optional
            M at config.x as `coordinate_mass` gives it, where the caller has it already.

        Returns
        -------
        ndarray (NDOF, NDOF)
            kg (kg m, kg m^2 where an angle DOF is involved).
        """
        M = self.coordinate_mass(config.x) if coordinate_mass is None else coordinate_mass
        if self.sparse:
            return config.DF.T @ np.asarray(M @ config.DF)
        return config.DF.T @ M @ config.DF
