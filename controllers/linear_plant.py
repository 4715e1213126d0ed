"""The linear plant: the scene's state space, advanced exactly under the held input.

The loop on the linearised model (`flexure.core.state_space` at the static equilibrium under
the scene's loads) is what a designer runs to tune a controller quickly, and what the chapter
evaluated its loops on ("an input-output state space model can be derived to design and
evaluate the control system"). Its difference from the nonlinear plant is what the geometric
nonlinearity does to the loop.

With the state z (deviations from the equilibrium, `state_space`'s units) and the input held
at u over a step of h seconds (zero-order hold), the step is exact:

    z(t + h) = e^(A h) z(t) + (integral_0^h e^(A s) ds) B (u - u0)      y = y0 + C z

In the eigenvector basis A = V diag(lambda) V^-1 both factors are diagonal: the modal state
w = V^-1 z advances as w <- exp(lambda h) w + h phi1(lambda h) (V^-1 B)(u - u0), with
phi1(x) = (e^x - 1) / x, so a step costs O(n (n_inputs + n_outputs)) whatever its length, and
the stiffest modes (lambda h << -1) are exact too rather than merely stable. Where V is too
ill-conditioned for that (nearly defective eigenvalues: cond_1(V) above `MODAL_CONDITION`), the
step uses e^(A h) and its integral from one matrix exponential instead (Van Loan), O(n^2) a
step. Units: inputs N, N m (V for an actuator's drive signal), outputs m, rad, m/s, rad/s, s.
"""

from __future__ import annotations

import numpy as np

from flexure.core import SimulationError

# Above this condition number of the eigenvectors (rounding in the modal step grows with
# it, about cond_1(V) * 1e-16 relative), the step uses the matrix exponential instead.
MODAL_CONDITION = 1e8


class LinearPlant:
    """The scene's linearised model, advanced exactly with the input held over each step.

    It takes the same absolute inputs and gives the same absolute outputs as the nonlinear
    plants (plants.py), and starts where they start (`Simulator.reset`): at rest at the
    scene's initial coordinates, which under constant loads lie away from the equilibrium it
    is linearised at (z0 = [q0 - q_eq, 0]). The outputs are y = y_start + C (z - z0): exact
    at the start, where a loop holds its plant, and within the second order of q0 - q_eq
    elsewhere (on the 19-DOF stage under its 1 N, 6.7 um on the y of the bar at its loaded
    equilibrium; an output on a DOF coordinate is exact everywhere). The coil currents of
    voltage-driven actuators start at their values in the linearisation: zero, as in
    Simulator, unless it was made under held inputs.

    Parameters
    ----------
    model : Model
        With [inputs] and [outputs].
    linear_model : LinearModel, optional
        The linearisation (default: `flexure.core.linearize(model)`, the static equilibrium
        under the scene's loads).
    modal : bool, optional
        Force the modal step (True) or the matrix exponential (False); default: modal when
        the eigenvectors' 1-norm condition number is below `MODAL_CONDITION`.

    Attributes
    ----------
    A, B, C, D : ndarray
        `state_space(model)`'s matrices (states [dq, dq', di]; see its units).
    u0 : ndarray (n_inputs,)
        The inputs of the linearisation (N, N m, V); the plant is driven by u - u0.
    y_start : ndarray (n_outputs,)
        The outputs at the start (m, rad, m/s, rad/s).
    initial_state : ndarray (n_states,)
        z0, the start's deviation from the linearisation.
    modal : bool
        Whether it steps in the eigenvector basis.
    condition : float
        The eigenvectors' 1-norm condition number.
    time : float
        The time (s) it has reached.
    factor_updates : int
        How many times the step's factors were computed (once per step length).
    """

    kind = "linear"

    def __init__(self, model, *, linear_model=None, modal=None):
        from scipy.linalg import eig

        from flexure.core import Kinematics, linearize, output_value, state_space

        lin = linear_model if linear_model is not None else linearize(model)
        system = state_space(model, linear_model=lin)
        self.input_names = [port.name for port in model.inputs]
        self.output_names = [port.name for port in model.outputs]
        held = lin.solution.inputs
        self.u0 = np.zeros(len(model.inputs)) if held is None else np.asarray(held, float)
        self.A, self.B, self.C = (np.asarray(m, float) for m in (system.A, system.B, system.C))
        self.D = np.asarray(system.D, float)
        x0 = model.initial_coordinates
        q0 = Kinematics(model).dofs_of(x0)
        self.initial_state = np.zeros(self.A.shape[0])
        self.initial_state[: q0.size] = q0 - lin.solution.q
        self.y_start = np.array([output_value(model, port, x0, np.zeros_like(x0))
                                 for port in model.outputs])
        self._output_constant = self.y_start - self.C @ self.initial_state
        eigenvalues, V = eig(self.A)
        V_inv = np.linalg.inv(V)
        # the 1-norm condition number: from the inverse the modal step needs anyway, where
        # the 2-norm's SVD would take longer than the eigenvectors themselves
        self.condition = float(np.linalg.norm(V, 1) * np.linalg.norm(V_inv, 1))
        self.modal = self.condition < MODAL_CONDITION if modal is None else bool(modal)
        if self.modal:
            self.eigenvalues = eigenvalues
            self._input_modes = V_inv @ self.B
            self._output_modes = self.C @ V
            self._initial_modes = V_inv @ self.initial_state
        self._h = None
        self.factor_updates = 0
        self.time = 0.0
        self.reset()

    def reset(self):
        """Back to rest at the scene's initial coordinates; returns the outputs (t = 0)."""
        self.state = (self._initial_modes if self.modal else self.initial_state).copy()
        self.du = np.zeros(self.B.shape[1])
        self.time = 0.0
        return self.output()

    def set_input(self, u):
        """Hold the inputs u (n_inputs,) from now on: N, N m, or V for a drive signal."""
        u = np.asarray(u, float).reshape(-1)
        if u.shape != self.u0.shape or not np.all(np.isfinite(u)):
            raise SimulationError(f"the linear plant takes {self.u0.size} finite inputs, "
                                  f"got {u.tolist()!r}")
        self.du = u - self.u0

    def advance(self, t_end):
        """Advance to t_end (s) with the held inputs, exactly."""
        h = float(t_end) - self.time
        if not (h > 0 and np.isfinite(h)):
            raise SimulationError(f"the linear plant at t = {self.time:.9g} s cannot advance "
                                  f"to t = {float(t_end):.9g} s")
        # k/fs - (k-1)/fs wobbles by a rounding unit of t: a relative 1e-9 (below the modal
        # step's own rounding, cond * 1e-16) keeps one set of factors for a whole loop
        if self._h is None or abs(h - self._h) > 1e-9 * h:
            self._factors(h)
        decayed = self._decay * self.state if self.modal else self._decay @ self.state
        self.state = decayed + self._drive @ self.du
        self.time = float(t_end)

    def output(self):
        """The outputs (n_outputs,) now: m, rad, m/s, rad/s."""
        z = (self._output_modes @ self.state).real if self.modal else self.C @ self.state
        return self._output_constant + z + self.D @ self.du

    def close(self):
        """Nothing to release (the plants' common interface)."""

    def _factors(self, h):
        """The step's state factor and input factor for a step of h seconds."""
        if self.modal:
            x = self.eigenvalues * h
            small = np.abs(x) < 1e-8  # phi1(x) = 1 + x/2 + ..., to rounding there
            phi1 = np.where(small, 1 + x / 2, np.expm1(x) / np.where(small, 1, x))
            self._decay = np.exp(x)
            self._drive = (h * phi1)[:, None] * self._input_modes
        else:
            from scipy.linalg import expm

            n, m = self.B.shape
            block = np.zeros((n + m, n + m))
            block[:n, :n], block[:n, n:] = self.A * h, self.B * h
            E = expm(block)
            self._decay, self._drive = E[:n, :n], E[:n, n:]
        self._h = h
        self.factor_updates += 1
