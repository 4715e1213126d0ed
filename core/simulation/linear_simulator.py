"""The `LinearSimulator`: a model's linearisation, advanced exactly under held inputs.

The linearised equations of motion (`flexure.core.state_space` at the static equilibrium under
the scene's loads) are what a designer tunes controllers on and what SPACAR hands to control
design; stepped exactly they run a large model far faster than the nonlinear `Simulator`
(the six-DOF manipulator's 507-DOF reduced model, 1014 states: about 16 us a step with its
inputs and outputs). Their difference from the nonlinear run is what the geometric
nonlinearity does.

With the state z (deviations from the equilibrium, `state_space`'s units) and the inputs held
at u over a step of h seconds (zero-order hold), the step is exact:

    z(t + h) = e^(A h) z(t) + (integral_0^h e^(A s) ds) B (u - u0)      y = y0 + C z + D (u - u0)

In the eigenvector basis A = V diag(lambda) V^-1 both factors are diagonal: the modal state
w = V^-1 z advances as w <- exp(lambda h) w + h phi1(lambda h) (V^-1 B)(u - u0), with
phi1(x) = (e^x - 1) / x, so a step costs O(n (n_inputs + n_outputs)) whatever its length, and
the stiffest modes (lambda h << -1) are exact too rather than merely stable. Where V is too
ill-conditioned for that (nearly defective eigenvalues: cond_1(V) above `MODAL_CONDITION`), a
step uses e^(A h) and its integral from one matrix exponential instead (Van Loan), O(n^2).

It starts where `Simulator` starts: at rest at the scene's initial coordinates, which under
constant loads lie away from the equilibrium (z0 = [q0 - q_eq, 0]). Its outputs are anchored
there, y = y_start + C (z - z0) + D (u - u0): exact at the start, where a loop holds its
plant, and elsewhere within the second order of q0 - q_eq (on the 19-DOF stage under its
1 N, 6.7 um on the bar's y at its loaded equilibrium; an output on a DOF coordinate is exact
everywhere). The coil currents of voltage-driven actuators start at their values in the
linearisation: zero, as in `Simulator`, unless it was made under held inputs.

    sim = LinearSimulator(model)
    sim.set_inputs([1.0])            # N, held
    sim.advance_to(0.5)              # s: the end time, not a step
    sim.outputs()                    # m, rad, m/s, rad/s

Units: inputs N, N m (V for an actuator's drive signal); outputs m, rad, m/s, rad/s; time s.
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SimulationError
from ..numerics.blas import blas_threads
from .held_inputs import checked_inputs

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..analysis.linearization import LinearModel
    from ..model import Model

# Above this condition number of the eigenvectors (rounding in the modal step grows with
# it, about cond_1(V) * 1e-16 relative), a step uses the matrix exponential instead.
MODAL_CONDITION = 1e8


class LinearSimulator:
    """The model's linearisation, advanced exactly with the inputs held over each step.

    Parameters
    ----------
    model : Model
        With [inputs] and [outputs].
    linear_model : LinearModel, optional
        The linearisation (default: `linearize(model)`, the static equilibrium under the
        scene's loads).
    modal : bool, optional
        Force the modal step (True) or the matrix exponential (False); default: modal when
        the eigenvectors' 1-norm condition number is below `MODAL_CONDITION`.

    Attributes
    ----------
    input_names, output_names : list of str
        The model's inputs and outputs, in order.
    A, B, C, D : ndarray
        `state_space(model)`'s matrices (states [dq, dq', di]; see its units).
    u0 : ndarray (n_inputs,)
        The inputs of the linearisation (N, N m, V); the model is driven by u - u0.
    y_start : ndarray (n_outputs,)
        The outputs at the start: the positions' (m, rad), the rates' of the linear model,
        C z0 (m/s, rad/s, ...: a velocity's zero at rest), before the inputs' D (u - u0).
    initial_state : ndarray (n_states,)
        z0, the start's deviation from the linearisation.
    modal : bool
        Whether it steps in the eigenvector basis.
    eigenvalues : ndarray (n_states,), complex
        Those of A, 1/s.
    condition : float
        The eigenvectors' 1-norm condition number.
    growth_rate : float
        The largest real part of the eigenvalues, 1/s: above 0 the linearisation is
        unstable (a buckled or negatively stiff equilibrium).
    factor_updates : int
        How many times the step's factors were computed (once per step length).

    Raises
    ------
    SceneError
        The model declares no inputs or no outputs.
    """

    @blas_threads()  # the eigenvectors of A: 9 s of CPU with two threads at load 7, 1.3 s
    def __init__(self, model: Model, *, linear_model: LinearModel | None = None,
                 modal: bool | None = None) -> None:
        from scipy.linalg import eig

        from ..analysis.linearization import linearize
        from ..analysis.statespace import state_space_matrices
        from ..mechanics.kinematics import Kinematics
        from ..mechanics.output_quantities import output_order
        from ..mechanics.ports import output_value

        lin = linear_model if linear_model is not None else linearize(model)
        # the matrices alone: python-control (a second of a process's start) is not needed
        A, B, C, D = state_space_matrices(model, linear_model=lin)
        self.input_names = [port.name for port in model.inputs]
        self.output_names = [port.name for port in model.outputs]
        held = lin.solution.inputs
        self.u0 = np.zeros(len(model.inputs)) if held is None else np.asarray(held, float)
        self.A, self.B, self.C, self.D = (np.asarray(m, float) for m in (A, B, C, D))
        x0 = model.initial_coordinates
        q0 = Kinematics(model).dofs_of(x0)
        self.initial_state = np.zeros(self.A.shape[0])
        self.initial_state[: q0.size] = q0 - lin.solution.q
        # a position's exact value at the start; a rate's (`output_quantities`) that of the
        # linear model, C z0 (a velocity's zero at rest): its value at the equilibrium is zero
        rates = self.C @ self.initial_state
        self.y_start = np.array([rates[j] if output_order(port) else output_value(model, port, x0)
                                 for j, port in enumerate(model.outputs)])
        self._output_constant = self.y_start - self.C @ self.initial_state
        eigenvalues, V = eig(self.A)
        # > 0: an unstable linearisation (a buckled or negatively stiff equilibrium), whose
        # state may overflow in a long run
        self.growth_rate = float(np.max(eigenvalues.real))
        V_inv = np.linalg.inv(V)
        # the 1-norm condition number: from the inverse the modal step needs anyway, where
        # the 2-norm's SVD would take longer than the eigenvectors themselves
        self.condition = float(np.linalg.norm(V, 1) * np.linalg.norm(V_inv, 1))
        self.modal = self.condition < MODAL_CONDITION if modal is None else bool(modal)
        self.eigenvalues = eigenvalues
        if self.modal:
            self._input_modes = V_inv @ self.B
            self._output_modes = self.C @ V
            self._initial_modes = V_inv @ self.initial_state
        self._h = None
        self.factor_updates = 0
        self._du = np.zeros(self.B.shape[1])  # the inputs of the linearisation
        self.reset()

    def reset(self, *, t0: float = 0.0) -> None:
        """Start again at rest at the scene's initial coordinates; the inputs are kept, as
        `Simulator.reset` keeps them.

        Parameters
        ----------
        t0 : float
            The start time, s.
        """
        self._z = (self._initial_modes if self.modal else self.initial_state).copy()
        self._t = float(t0)

    @property
    def time(self) -> float:
        """The time reached, s."""
        return self._t

    @property
    def inputs(self) -> np.ndarray:
        """The held inputs (n_inputs,): N, N m, V."""
        return self.u0 + self._du

    def set_inputs(self, u: ArrayLike) -> None:
        """Hold the inputs u from now on; the next steps are driven by u - u0.

        Parameters
        ----------
        u : array_like (n_inputs,)
            The absolute inputs, as `Simulator.set_inputs` takes them (N, N m, V).

        Raises
        ------
        SimulationError
            As `Simulator.set_inputs`: a wrong count, or an input that is not finite.
        """
        u, _ = checked_inputs(u, self.input_names, self._t)
        self._du = u - self.u0

    def advance(self, t_end: float) -> None:
        """Deprecated: `advance_to`, the same call under a name that says its argument is the
        absolute end time, not a step length.

        Parameters
        ----------
        t_end : float
            The end time, s, after the current one.
        """
        warnings.warn("LinearSimulator.advance(t_end) is renamed advance_to(t_end): t_end is "
                      "the absolute end time, not a step", DeprecationWarning, stacklevel=2)
        self.advance_to(t_end)

    def advance_to(self, t_end: float) -> None:
        """Advance to the absolute time t_end with the held inputs, exactly.

        Parameters
        ----------
        t_end : float
            The end time, s, after the current one (an absolute time, not a step).

        Raises
        ------
        SimulationError
            A t_end that is not a finite time after the current one, or a state that
            overflows (an unstable linearisation run long, or inputs near 1e308); the
            simulator then stays where it was.
        """
        t_end = float(t_end)
        h = t_end - self._t
        if not (math.isfinite(t_end) and h > 0):
            raise SimulationError(f"t = {self._t:.9g} s: advance to t_end = {t_end!r}: expected "
                                  "a finite time after the current one")
        self.step_factors(h)
        # an overflow is refused below, by name, rather than warned of by numpy (1 us a step)
        with np.errstate(over="ignore", invalid="ignore"):
            z = self._step()
            finite = np.isfinite(z.sum())  # an inf or NaN anywhere makes the sum one
        if not finite:
            raise SimulationError(f"t = {self._t:.9g} s: the linearised state overflows over "
                                  f"the step to {t_end:.9g} s (the linearisation's fastest "
                                  f"growth rate: {self.growth_rate:.6g} 1/s; the inputs' "
                                  f"largest distance from the linearisation's: "
                                  f"{np.max(np.abs(self._du), initial=0.0):.6g})")
        self._z = z
        self._t = t_end

    def step_factors(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        """The factors of a step of h seconds with the inputs held, as `advance_to` steps:
        computed for h, or those kept from a step within a relative 1e-9 of it.

        Parameters
        ----------
        h : float
            The step, s (> 0).

        Returns
        -------
        decay : ndarray
            Modal: e^(lambda h) (n_states,), complex; else e^(A h) (n_states, n_states).
        drive : ndarray (n_states, n_inputs)
            Modal: h phi1(lambda h) V^-1 B, complex; else (integral_0^h e^(A s) ds) B. The
            step is w <- decay * w + drive (u - u0) (decay @ z + ... without the modes).
        """
        # k/fs - (k-1)/fs wobbles by a rounding unit of t: a relative 1e-9 (below the modal
        # step's own rounding, cond * 1e-16) keeps one set of factors for a whole loop
        if self._h is None or abs(h - self._h) > 1e-9 * h:
            self._factors(h)
        return self._decay, self._drive

    @property
    def modal_state(self) -> np.ndarray:
        """The modal state w = V^-1 z now (n_states,), complex (a copy); modal only."""
        return self._z.copy()

    @property
    def output_modes(self) -> np.ndarray:
        """C V (n_outputs, n_states), complex: y = y_c + (C V w).real + D (u - u0); modal
        only."""
        return self._output_modes

    @property
    def output_constant(self) -> np.ndarray:
        """y_c = y_start - C z0 (n_outputs,): m, rad, m/s, rad/s."""
        return self._output_constant

    def continue_from(self, t: float, modal_state: ArrayLike, inputs: ArrayLike) -> None:
        """Take over where another stepper of this simulator's modal form left it (a compiled
        loop, `linear_loop`): at t, with the modal state w and the inputs held.

        Parameters
        ----------
        t : float
            s.
        modal_state : array_like (n_states,), complex
            w = V^-1 z.
        inputs : array_like (n_inputs,)
            The absolute inputs held (N, N m, V).
        """
        self._z = np.array(modal_state, dtype=complex)
        self._t = float(t)
        self._du = np.asarray(inputs, float) - self.u0

    def outputs(self) -> np.ndarray:
        """The declared outputs now.

        Returns
        -------
        ndarray (n_outputs,)
            Positions m, velocities m/s (angles rad, angular velocities rad/s).
        """
        z = (self._output_modes @ self._z).real if self.modal else self.C @ self._z
        return self._output_constant + z + self.D @ self._du

    def _step(self):
        """The state after one step with the current factors and inputs."""
        decayed = self._decay * self._z if self.modal else self._decay @ self._z
        return decayed + self._drive @ self._du

    def _factors(self, h):
        """The step's state factor and input factor for a step of h seconds."""
        if self.modal:
            x = self.eigenvalues * h
            small = np.abs(x) < 1e-8  # phi1(x) = 1 + x/2 + ..., to rounding there
            # an unstable mode over a long step overflows here: `advance` says so
            with np.errstate(over="ignore", invalid="ignore"):
                phi1 = np.where(small, 1 + x / 2, np.expm1(x) / np.where(small, 1, x))
                self._decay = np.exp(x)
                self._drive = (h * phi1)[:, None] * self._input_modes
        else:
            from scipy.linalg import expm

            n, m = self.B.shape
            block = np.zeros((n + m, n + m))
            block[:n, :n], block[:n, n:] = self.A * h, self.B * h
            with np.errstate(over="ignore", invalid="ignore"):  # as above
                E = expm(block)
            self._decay, self._drive = E[:n, :n], E[:n, n:]
        self._h = h
        self.factor_updates += 1
