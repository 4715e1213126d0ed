"""Linearisation in a configuration: M0, C0, K0 and G0 on the DOFs.

    M0 dq'' + C0 dq' + (K0 + G0) dq = DF^T df

M0 = DF^T M DF is the reduced mass (kg), C0 the damping (N s/m), K0 the structural stiffness
(N/m) and G0 the geometric stiffness from the stress resultants (N/m), all in the DOF units
(m, rad). The default configuration is the static equilibrium under the scene's loads, so a
compressive preload lowers the stiffness K0 + G0 and with it the frequencies.

Voice-coil actuators (`flexure.core.mechanics.actuators`) enter the first-order form
(`LinearModel.state_matrices`) exactly: the state z = [dq, dq', di] with di the coil currents
of the voltage-driven actuators (A), the inputs du (N, N m for a force or moment, V for a
drive signal),

    A = [[0, I, 0], [-M0^-1 K, -M0^-1 C0, M0^-1 DF^T b_c Km], [0, -L^-1 Km b_c^T DF, -L^-1 R]]
    B = [[0], [M0^-1 DF^T b], [L^-1 b_i]]

with b_c the ports' unit generalised forces (`flexure.core.mechanics.ports.input_columns`:
a unit column on a coordinate, 2 E_k^T on the Euler parameters for a moment about axis k) of
the voltage-driven actuators, b those of the force and moment inputs and Km a'(u0) those of
the current-driven ones, b_i a'(u0) of the voltage-driven ones, a' the amplifier's slope (G
inside its limits, 0 where it saturates) at the held inputs u0 of the equilibrium (zero by
default). b_c^T DF dq' is the port's velocity (its back-EMF Km b_c^T xdot); the load
stiffness of a moment at its steady value is in G0. The back-EMF Km^2 / R damps the actuated
motion and the coil adds its pole near -R / L. M0, C0 and K stay the mechanical matrices: the
natural frequencies are those of the mechanism with its coils open (no current, no back-EMF
force).

Kinematic inputs (`flexure.core.mechanics.motions`) are held at their values: the matrices
are those of the DOFs proper q_f (the rows and columns of q_k dropped) and `DF` has their
columns only, so the modes, the force-driven state space and the compliance are those of the
mechanism with its prescribed coordinates held. The state space whose inputs are the
prescribed positions: `flexure.core.analysis.motion_statespace`.

M0, C0, K0 and G0 come from the compiled engine where the statics have packed it for the
model (`linear_engine`: its tangent at the equilibrium, within 1e-10 of the largest entry of
the numpy path's, tests/test_linear_engine.py), else from the numpy `Mechanics`; so do the
input columns DF^T b and the output rows d y / d q (`LinearModel.port_rows`: the engine's
OP_PORT_ROWS at the same evaluation, within round-off of the numpy ports', tests/
test_port_rows.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..mechanics.actuators import amplifier_slope
from ..mechanics.mechanics import Mechanics
from ..mechanics.ports import input_columns, output_rows
from ..numerics.blas import blas_threads
from . import linear_engine
from .statics import StaticSolution, static_equilibrium

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model


@dataclass
class LinearModel:
    """The linearised equations of motion of a model in one configuration."""

    model: Model
    solution: StaticSolution
    M0: np.ndarray
    C0: np.ndarray
    K0: np.ndarray
    G0: np.ndarray
    # the engine's rows at the configuration where it linearised (`port_rows`), else None
    input_rows: np.ndarray | None = None
    output_rows: np.ndarray | None = None

    @property
    def K(self) -> np.ndarray:
        """The full tangent stiffness K0 + G0 (NDOF, NDOF), N/m in the DOF units (m, rad)."""
        return self.K0 + self.G0

    @property
    def DF(self) -> np.ndarray:
        """The first-order transfer function dx/dq (NX, NDOF) of the configuration; with
        kinematic inputs dx/dq_f (NX, NDOF - NKI), on the DOFs proper."""
        if self.model.kinematic_inputs:
            return self.solution.config.DF[:, self.model.free_dofs]
        return self.solution.config.DF

    def port_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """The state space's input columns and output rows on the DOFs at the configuration:
        the engine's where it linearised (OP_PORT_ROWS at its tangent's evaluation), else the
        numpy ports' (`input_columns`, `output_rows`).

        Returns
        -------
        inputs : ndarray (n_inputs, NDOF)
            b_j^T DF: the generalised force on the DOFs of a unit input (N per N, N m per
            N m), and its port's velocity per DOF velocity (a coil's back-EMF row).
        outputs : ndarray (n_outputs, NDOF)
            d y / d q (a rate output's per that rate of q: m/m, rad/m, rad/rad, ...).

        On the DOFs proper (kinematic inputs held: their columns dropped).
        """
        if self.input_rows is not None:
            return self.input_rows, self.output_rows
        x, DF = self.solution.config.x, self.DF
        return (input_columns(self.model, x).T @ DF, output_rows(self.model, x, DF))

    def state_matrices(self) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """The first-order linear system dz/dt = A z + B du (module docstring).

        Returns
        -------
        A : ndarray (N, N)
            With N = 2 NDOF + the voltage-driven coils; the state z = [dq, dq', di] in the
            DOF units (m, rad), their rates (m/s, rad/s) and the coil currents (A).
        B : ndarray (N, n_inputs)
            The inputs du: N, N m for forces and moments, V for drive signals.
        names : list of str
            The states: the DOF names, then "<dof>_dot", then "<actuator>.current".
        """
        model = self.model
        n, coils = self.M0.shape[0], model.coil_actuators
        N = 2 * n + len(coils)
        u0 = (np.zeros(len(model.inputs)) if self.solution.inputs is None
              else self.solution.inputs)
        A, B = np.zeros((N, N)), np.zeros((N, len(model.inputs)))
        A[:n, n: 2 * n] = np.eye(n)
        A[n: 2 * n, :n] = -np.linalg.solve(self.M0, self.K)
        A[n: 2 * n, n: 2 * n] = -np.linalg.solve(self.M0, self.C0)
        # d force / d u on the DOFs: the ports' unit generalised forces at the configuration
        rows = self.port_rows()[0]
        forces = rows.T.copy()
        for actuator in model.actuators:
            j = actuator.input
            column = rows[j]  # b_j^T DF: the force per unit input, and the back-EMF's row
            slope = amplifier_slope(actuator, u0[j])
            if actuator.drive == "current":
                forces[:, j] = actuator.force_constant * slope * column
                continue
            k = 2 * n + coils.index(actuator)
            forces[:, j] = 0.0
            km, inductance = actuator.force_constant, actuator.inductance
            A[n: 2 * n, k] = np.linalg.solve(self.M0, km * column)
            A[k, n: 2 * n] = -km / inductance * column
            A[k, k] = -actuator.resistance / inductance
            B[k, j] = slope / inductance
        B[n: 2 * n] = np.linalg.solve(self.M0, forces)
        dofs = model.free_dof_names
        names = ([f"{d}" for d in dofs] + [f"{d}_dot" for d in dofs]
                 + [f"{a.name}.current" for a in coils])
        return A, B, names


@blas_threads()
def linearize(model: Model, solution: StaticSolution | None = None, *,
              mechanics: Mechanics | None = None,
              compiled: bool | None = None) -> LinearModel:
    """Linearise `model` at `solution`: M0, C0, K0 and G0 on the DOFs.

    Parameters
    ----------
    model : Model
    solution : StaticSolution, optional
        The configuration (default: the static equilibrium under the model's loads).
    mechanics : Mechanics, optional
        The model's mechanics to reuse (default: a new one).
    compiled : bool, optional
        Form M0, C0 and K0 + G0 through the compiled engine (True: `linear_engine`, where
        it takes the model) or through the numpy `Mechanics`, the plain reference (False).
        Default: the engine where the statics have packed it for this model
        (`linear_engine.preferred`: a model in the statics' window that they solved
        loaded).

    Returns
    -------
    LinearModel
        M0 (kg), C0 (N s/m), K0 and G0 (N/m), all in the DOF units (m, rad).

    Raises
    ------
    ConvergenceError
        The static equilibrium, when it is solved here, does not converge.
    """
    mech = mechanics or Mechanics(model)
    if solution is None:
        solution = static_equilibrium(model, mechanics=mech)
    config = solution.config
    engine = (linear_engine.preferred(model, mech) if compiled is None
              else compiled and linear_engine.supports(model, mech))
    rows = (None, None)
    if engine and solution.load_factor == 1.0:
        matrices = linear_engine.engine_matrices(model, solution, mech)
        rows = linear_engine.engine_port_rows(model)  # at that tangent's evaluation
    else:
        matrices = (mech.mass_matrix(config), mech.damping_matrix(config),
                    mech.structural_stiffness(config),
                    mech.geometric_stiffness(config, solution.stress_resultants,
                                             solution.load_factor,
                                             inputs=solution.port_values))
    if model.kinematic_inputs:  # held: the DOFs proper alone (module docstring)
        free = np.ix_(model.free_dofs, model.free_dofs)
        matrices = tuple(matrix[free] for matrix in matrices)
        if rows[0] is not None:
            rows = tuple(row[:, model.free_dofs] for row in rows)
    M0, C0, K0, G0 = matrices
    return LinearModel(model=model, solution=solution, M0=M0, C0=C0, K0=K0, G0=G0,
                       input_rows=rows[0], output_rows=rows[1])
