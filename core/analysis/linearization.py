"""Linearisation in a configuration: M0, C0, K0 and G0 on the DOFs.

    M0 dq'' + C0 dq' + (K0 + G0) dq = DF^T df

M0 = DF^T M DF is the reduced mass (kg), C0 the damping (N s/m), K0 the structural stiffness
(N/m) and G0 the geometric stiffness from the stress resultants (N/m), all in the DOF units
(m, rad). The default configuration is the static equilibrium under the scene's loads, so a
compressive preload lowers the stiffness K0 + G0 and with it the frequencies.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..mechanics.mechanics import Mechanics
from ..numerics.blas import blas_threads
from .statics import StaticSolution, static_equilibrium

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model


@dataclass
class LinearModel:
    """The linearised equations of motion of a model in one configuration."""

    model: object
    solution: StaticSolution
    M0: np.ndarray
    C0: np.ndarray
    K0: np.ndarray
    G0: np.ndarray

    @property
    def K(self):
        """The full tangent stiffness K0 + G0 (N/m)."""
        return self.K0 + self.G0

    @property
    def DF(self):
        """The first-order transfer function dx/dq (NX, NDOF) of the configuration."""
        return self.solution.config.DF


@blas_threads()
def linearize(model: Model, solution: StaticSolution | None = None, *,
              mechanics: Mechanics | None = None) -> LinearModel:
    """Linearise `model` at `solution` (default: its static equilibrium under its loads)."""
    mech = mechanics or Mechanics(model)
    if solution is None:
        solution = static_equilibrium(model, mechanics=mech)
    config = solution.config
    return LinearModel(
        model=model,
        solution=solution,
        M0=mech.mass_matrix(config),
        C0=mech.damping_matrix(config),
        K0=mech.structural_stiffness(config),
        G0=mech.geometric_stiffness(config, solution.stress_resultants, solution.load_factor,
                                    inputs=solution.inputs),
    )
