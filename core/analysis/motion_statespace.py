"""The state space whose inputs are the kinematic inputs' positions (SPACAR's INX).

Linearised at a static solution (the kinematic inputs at their held values), with q split into
the DOFs proper y = dq_f and the prescribed values u = dq_k, and M, C, K = K0 + G0 the full
matrices on q (the tangent of the generalised force, its multipliers included):

    M_ff y'' + C_ff y' + K_ff y = -(M_fk u'' + C_fk u' + K_fk u)
    F = M_kf y'' + C_kf y' + K_kf y + M_kk u'' + C_kk u' + K_kk u        (the efforts)

A position input drives the free DOFs through the coupling stiffness, damping and mass. The
derivatives of u leave the states by the change of variables (with E2 = M_ff^-1 (-M_fk) and
E1 = M_ff^-1 (-C_fk - C_ff E2))

    z1 = y - E2 u,   z2 = z1' - E1 u:
    z' = A z + B u,  A = [[0, I], [-M_ff^-1 K_ff, -M_ff^-1 C_ff]],
                     B = [[E1], [M_ff^-1 (-K_fk - C_ff E1 - K_ff E2)]],
    y = z1 + E2 u,   y' = z2 + E1 u + E2 u'

so a position output reads C z + D u with the feed-through D = C_f E2 + C_k (C_f, C_k its
rows on y and u). What may still need the input's rates is returned, not dropped: every
output is

    C z + D u + D1 u' + D2 u''

where D1, D2 are zero for positions, D1 = C_f E2 + C_k for a velocity, for an acceleration
y'' = A_lower z + B_lower u + E1 u' + E2 u'' read by its rows (C_f A_lower, C_f B_lower,
D1 = C_f E1, D2 = C_f E2 + C_k), and for an effort
D2 = M_kf E2 + M_kk (the inertia the input moves along) and D1 = M_kf E1 + C_kf E2 + C_kk:
a position-driven mass needs the acceleration of its input, which no proper state space has.
`MotionStateSpace.system()` gives the python-control object of the outputs that need no rate
(D1 = D2 = 0: the positions, the efforts of massless, undamped inputs), and
`frequency_response` every output's exact transfer.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SceneError
from ..mechanics.element_outputs import element_output_rows
from ..mechanics.mechanics import Mechanics
from ..mechanics.output_quantities import output_order
from ..mechanics.ports import output_rows
from ..numerics.blas import blas_threads
from .statics import StaticSolution, static_equilibrium

if TYPE_CHECKING:  # names for the annotations only
    import control

    from ..model import Model


@dataclass
class MotionStateSpace:
    """z' = A z + B u; outputs C z + D u + D1 u' + D2 u'' (module docstring).

    inputs: the kinematic inputs' names (u in m or rad); outputs: the model's outputs, its
    outputs on elements (m, N), then "NAME.effort" for each kinematic input (N, N m);
    states: the DOFs proper and their "_dot" (z1, z2 of the module docstring: y - E2 u and
    its rate less E1 u).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    D1: np.ndarray
    D2: np.ndarray
    inputs: list[str]
    outputs: list[str]
    states: list[str]

    def frequency_response(self, s: complex) -> np.ndarray:
        """The transfer matrix C (sI - A)^-1 B + D + D1 s + D2 s^2 at the Laplace variable s.

        Parameters
        ----------
        s : complex
            rad/s (j omega on the imaginary axis).

        Returns
        -------
        ndarray (n_outputs, n_inputs), complex
            Per m or rad of input: m, m/s, N, ... as the outputs.
        """
        n = self.A.shape[0]
        states = np.linalg.solve(s * np.eye(n) - self.A, self.B) if n else np.zeros((0,
                                                                                  self.B.shape[1]))
        return self.C @ states + self.D + self.D1 * s + self.D2 * s * s

    def needs_rates(self) -> list[str]:
        """The outputs that need the rate or acceleration of an input.

        Returns
        -------
        list of str
            The outputs whose D1 or D2 row is not zero (beyond 1e-12 of the largest |D|, or
            of 1), in output order.
        """
        scale = max(np.abs(self.D).max(initial=0.0), 1.0)
        return [name for name, d1, d2 in zip(self.outputs, self.D1, self.D2, strict=True)
                if max(np.abs(d1).max(initial=0.0), np.abs(d2).max(initial=0.0)) > 1e-12 * scale]

    def system(self, outputs: list[str] | None = None) -> control.StateSpace:
        """The python-control StateSpace of (A, B, C, D) on outputs that need no input rate.

        Parameters
        ----------
        outputs : list of str, optional
            The outputs to keep (default: every one that needs no rate, `needs_rates`).

        Returns
        -------
        control.StateSpace
            Inputs the kinematic inputs (m, rad), outputs those kept, states `states`.

        Raises
        ------
        SceneError
            A named output is unknown, or needs the input's velocity or acceleration (D1 or
            D2 not zero: no proper state space has it; use `frequency_response`).
        """
        import control

        improper = self.needs_rates()
        names = [o for o in self.outputs if o not in improper] if outputs is None else outputs
        for name in names:
            if name not in self.outputs:
                raise SceneError(f"no output {name!r}; expected one of {', '.join(self.outputs)}")
            if name in improper:
                raise SceneError(f"output {name!r} needs the rate or acceleration of a "
                                 "kinematic input (D1, D2 not zero): no proper state space "
                                 "has it; use frequency_response")
        rows = [self.outputs.index(name) for name in names]
        return control.ss(self.A, self.B, self.C[rows], self.D[rows], inputs=self.inputs,
                          outputs=names, states=self.states)


@blas_threads()
def motion_state_space(model: Model, *, solution: StaticSolution | None = None,
                       mechanics: Mechanics | None = None) -> MotionStateSpace:
    """The linear state space from the kinematic inputs' positions (module docstring).

    Parameters
    ----------
    model : Model
        With at least one kinematic input.
    solution : StaticSolution, optional
        Where to linearise (default: the static equilibrium at the held values).
    mechanics : Mechanics, optional
        The model's mechanics to reuse.

    Returns
    -------
    MotionStateSpace

    Raises
    ------
    SceneError
        The model has no kinematic input.
    """
    if not model.kinematic_inputs:
        raise SceneError(f"{model.source}: a state space from positions needs a kinematic "
                         f"input ([inputs.NAME] kind = \"motion\"); {model.name!r} has none")
    mech = mechanics or Mechanics(model)
    if solution is None:
        solution = static_equilibrium(model, mechanics=mech)
    config = solution.config
    M = mech.mass_matrix(config)
    C = mech.damping_matrix(config)
    K = mech.structural_stiffness(config) + mech.geometric_stiffness(
        config, solution.stress_resultants, solution.load_factor, inputs=solution.port_values)
    f, k = model.free_dofs, model.prescribed_dofs
    n, m = f.size, k.size

    def part(matrix, rows, columns):
        return matrix[np.ix_(rows, columns)]

    Mff, Cff, Kff = part(M, f, f), part(C, f, f), part(K, f, f)
    E2 = np.linalg.solve(Mff, -part(M, f, k)) if n else np.zeros((0, m))
    E1 = np.linalg.solve(Mff, -part(C, f, k) - Cff @ E2) if n else np.zeros((0, m))
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    if n:
        A[n:, :n] = -np.linalg.solve(Mff, Kff)
        A[n:, n:] = -np.linalg.solve(Mff, Cff)
    lower = np.linalg.solve(Mff, -part(K, f, k) - Cff @ E1 - Kff @ E2) if n else E1
    B = np.vstack([E1, lower])
    # every output as a row on dq and one on dq' (a port is one or the other; an element's
    # stress resultant may be both): y = z1 + E2 u, y' = z2 + E1 u + E2 u'
    on_q, on_qdot = element_output_rows(model, mech, config)
    rows = output_rows(model, config.x, config.DF)
    order = np.array([output_order(port) for port in model.outputs], dtype=int)[:, None]
    on_q = np.vstack([np.where(order == 0, rows, 0.0), on_q])
    on_qdot = np.vstack([np.where(order == 1, rows, 0.0), on_qdot])
    n_out = on_q.shape[0]
    Cz = np.hstack([on_q[:, f], on_qdot[:, f]])
    D = on_q[:, f] @ E2 + on_q[:, k] + on_qdot[:, f] @ E1
    D1 = on_qdot[:, f] @ E2 + on_qdot[:, k]
    Cz, D, D1 = (np.vstack([a, np.zeros((m, a.shape[1]))]) for a in (Cz, D, D1))
    D2 = np.zeros((n_out + m, m))
    # an acceleration: y'' of the DOFs proper (below) on the free rows, u'' on the prescribed
    accelerations = np.flatnonzero(order[:, 0] == 2)
    Cz[accelerations] = rows[np.ix_(accelerations, f)] @ A[n:]
    D[accelerations] = rows[np.ix_(accelerations, f)] @ lower
    D1[accelerations] = rows[np.ix_(accelerations, f)] @ E1
    D2[accelerations] = rows[np.ix_(accelerations, f)] @ E2 + rows[np.ix_(accelerations, k)]
    # the efforts: y'' = A_lower z + B_lower u + E1 u' + E2 u''
    effort = slice(n_out, n_out + m)
    Mkf, Ckf, Kkf = part(M, k, f), part(C, k, f), part(K, k, f)
    Cz[effort] = Mkf @ A[n:] + np.hstack([Kkf, Ckf])
    D[effort] = Mkf @ lower + Ckf @ E1 + Kkf @ E2 + part(K, k, k)
    D1[effort] = Mkf @ E1 + Ckf @ E2 + part(C, k, k)
    D2[effort] = Mkf @ E2 + part(M, k, k)
    names = model.free_dof_names
    return MotionStateSpace(
        A, B, Cz, D, D1, D2, inputs=[port.name for port in model.kinematic_inputs],
        outputs=[port.name for port in model.outputs + model.element_outputs]
        + [f"{port.name}.effort" for port in model.kinematic_inputs],
        states=names + [f"{name}_dot" for name in names])


__all__ = ["MotionStateSpace", "motion_state_space"]
