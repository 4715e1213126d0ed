"""A one-step, L-stable implicit Runge-Kutta integrator (ESDIRK), compiled, on the engine.

Why a one-step method next to SUNDIALS' CVODE: a held input's change makes BDF's history
wrong, so CVODE restarts at order 1 with a small step (in `flexure loop` at 4 kHz, 9 steps and
13 evaluations per sample); a one-step method keeps its step size, Jacobian and Newton matrix.
SUNDIALS' one-step stiff integrators (ARKODE) are not among the libraries scikit-sundae
ships, so this module implements ARKODE's default methods itself, in numba, calling the
engine through its C entry point: no Python per step.

Methods (tableaus in `esdirk_method`): ESDIRK4(3)6L[2]SA ("esdirk", s = 6 stages, g = 1/4,
order 4, embedded order 3) and ESDIRK3(2)4L[2]SA ("esdirk3", s = 4, order 3, embedded 2) of
Kennedy & Carpenter 2003, and TR-BDF2 ("esdirk2", s = 3, g = 1 - 1/sqrt(2), order 2, embedded
3), all L-stable and stiffly accurate; and Alexander's two-stage SDIRK ("sdirk2", order 2,
embedded 1) as an ESDIRK whose first stage nothing reads (its column zero: F_1 below is then
only the predictor's start, and an input change costs no input response). One step from
(t, y) with size h, f the engine's right-hand side at the held inputs (y = [q - q_ref,
qdot], m, rad, m/s, rad/s):

    F_1 = f(y)                                (F_s of the step before while inputs are held;
                                              after an input change see below)
    z_i = y + h sum_{j<i} a_ij F_j + h g f(z_i),  i = 2..s   (simplified Newton, started from
                                              f(z_i) predicted: below)
    F_i = (z_i - y - h sum_{j<i} a_ij F_j) / (h g)       (the stage equation: no evaluation)
    y_new = z_s
    err = (I - h g J)^-1 h sum_j (b_j - b_hat_j) F_j      (the filtered estimate, Hairer &
                                                          Wanner IV.8: stiff modes damped)

Error control: the step is accepted when the weighted RMS norm of err, weights
1 / (rtol max(|y_i|, |y_new,i|) + atol_i) as CVODE's, is at most 1; the next step is
h min(5, max(0.2, 0.9 |err|^(-1/(p + 1)))), p the lower of the two orders; after a second
error-test failure at the same t, where the error fell from the first failure's more slowly
than h^(p + 1), the observed order q (at least 0.5) replaces p + 1: h max(0.01, 0.9
|err|^(-1/q)) (`esdirk_kernels.observed_shrink`: a sudden load's first step). The last step
before t_stop is stretched or split so the integration lands on t_stop exactly, never past it
(the held input changes there). After an input change the first step is at most the one
proposed after the last input change's first step (`esdirk_kernels.restart`). With a step
budget (max_steps) the kernel stops at the last accepted step once it is spent
(TOO_MUCH_WORK).

Newton: matrix I - h g J with J the model's analytic tangent (the engine's first-order
Jacobian), kept across steps and samples; it is recomputed when a stage's Newton fails (a
stage that converges slowly but converges only counts its iterations, below), and I - h g J
is refactored only when J is new or h has moved more than 20 % from the h of the factors (on
the sparse Newton matrix at every new h: `esdirk_newton.SPARSE_LU_SLACK`); for large models
through its Schur complement (`newton_matrix`). On the sparse Newton matrix a stage's residual
takes its velocity half in mass form, M_bar (f_v(z) - a_c) with a_c = (v - base_v) / (h g)
(`engine.stage_force`): no factorisation of the augmented system per iteration, the same
root, iterates that differ by the change of M_bar from the Newton matrix's state.
Iterations stop when the estimated remaining error eta |dz| (eta =
theta / (1 - theta), theta the observed contraction) is at most 0.05 in the norm above, as in
Hairer's RADAU5; at most 7 iterations. eta grows (eta^0.8) at a step's first implicit
stage, on the sparse Newton matrix only once it has gone unmeasured for `ETA_HOLD` steps. A
failed Newton or an engine failure at a trial stage (kinematics not converged) recomputes J
or, with J fresh, quarters h and retries. J is also
renewed once the iterations its age cost add up to what a new one costs (`esdirk_newton.
jacobian_cost`: n / 4 evaluations, on the sparse Newton matrix at most 40): on the
manipulator's loop 8 Jacobians instead of 1, 9 % fewer evaluations, 0.93 of the time and a
plant 2.7 times closer to a tight run (docs/decisions.md).

Predictor: f(z_i) extrapolated from the F_j in c (through the last three stages); for
TR-BDF2 also the last accepted step's stage derivatives at c = 0, c2, 1 as a quadratic in t:
stage 2 adds that step's mean slope, stage 3 its curvature (zero after a restart). In the
loop at 4 kHz this cuts the evaluations per step by about a fifth (docs/decisions.md).

After an input change du, F_1 = F_s + [0; M^-1 B du]: the inputs enter qddot linearly, and
the engine solves for their change with the factors of its last evaluation (`engine.
input_response`): one solve, not an evaluation, and F_s is what FSAL takes while inputs are
held (within the Newton tolerance of f(y)). Where it cannot (reduced form, actuators,
kinematic inputs): f(y). sdirk2 needs neither: F_s of the old inputs starts its predictor.

Status (the kernel's return): OK = 0 or one of the negative codes below; the state is always
the last accepted one.
"""

import numpy as np

from ..engine import data as ed
from ..engine import engine
from ..errors import SimulationError, StepBudgetSpent
from .esdirk_layout import (
    FLAG_NAMES,
    I_BOUNDED_RESPONSE,
    I_ETA_AGE,
    I_ETA_HOLD,
    I_EXTRA,
    I_FACTORIZATIONS,
    I_FRESH,
    I_FSAL,
    I_HISTORY,
    I_JACOBIAN,
    I_JACOBIANS,
    I_LU,
    I_MASS_FORM,
    I_MAX_STEPS,
    I_NEWTON_FAILURES,
    I_ONE_STEP,
    I_REFRESH,
    I_REJECTED,
    I_RHS,
    I_SIZE,
    I_STEPS,
    M_ETA,
    M_EXPONENT,
    M_H,
    M_H_INPUT,
    M_H_LU,
    M_H_MAX,
    M_RTOL,
    M_SIZE,
    M_T,
    OK,
    TOO_MUCH_WORK,
    V_ROWS,
    V_Y,
)
from .esdirk_method import TABLEAUS
from .esdirk_newton import ETA_HOLD, factor
from .stepper import Stepper


class Esdirk(Stepper):
    """The ESDIRK integrator on ydot = f(y), y = [q - q_ref, qdot(, coil currents)], with the
    engine: a `Stepper` (reset, advance, statistics, restart memory).

    Parameters
    ----------
    data, rtol, atol, max_step
        As in `sundials.Cvode`.
    method : str
        "esdirk" (order 4, 6 stages), "esdirk3" (order 3, 4 stages), "esdirk2" (TR-BDF2,
        order 2, 3 stages) or "sdirk2" (Alexander's SDIRK, order 2, 2 implicit stages): the
        tableau of `esdirk_method.TABLEAUS`.
    """

    def __init__(self, data, *, rtol, atol, max_step=None, method="esdirk"):
        from .methods import REGISTRY

        self.method = REGISTRY[method]
        self.data = engine.connect(data, *(getattr(engine, op)
                                           for op in self.method.operations))
        self.tableau = tableau = TABLEAUS[self.method.variant]
        self.label = self.tableau.name
        self.tables = self.tableau.arrays()
        dims = data.int_array("dims")
        self.n = n = 2 * int(dims[ed.NDOF]) + int(dims[ed.NEL])  # with the coil currents
        self.sparse_newton = bool(dims[ed.NEWTON_SPARSE])  # `newton_matrix`: J not in self.J
        self.memory = np.zeros(M_SIZE)
        self.memory[M_RTOL] = float(rtol)
        self.memory[M_H_MAX] = float(max_step or 0.0)
        self.memory[M_ETA] = 1.0
        self.memory[M_EXPONENT] = 1.0 / (min(tableau.order, tableau.embedded_order) + 1)
        self.flags = np.zeros(I_SIZE, dtype=np.int64)
        self.flags[I_HISTORY] = int(tableau.history)
        self.flags[I_MASS_FORM] = 1  # the stages' residual in mass form on the sparse path
        self.flags[I_BOUNDED_RESPONSE] = 1  # the input response to the step's weighted bound
        self.flags[I_ETA_HOLD] = ETA_HOLD if self.sparse_newton else 0
        self.vectors = np.zeros((V_ROWS, n))
        self.J = np.zeros(n * n)
        self.LU = np.zeros(n * n)
        self.pivots = np.zeros(n, dtype=np.int64)
        self.atol = np.ascontiguousarray(atol, dtype=float)
        self.y_array = self.vectors[V_Y]
        self.counters = data.int_array("counters")
        # advance's arguments by address, for its C entry (`esdirk_entry`, which imports
        # this module), which Python and the compiled sampled loop call
        from .esdirk_entry import advance_entry, arguments, restart_now

        self.advance_entry, self._restart_now = advance_entry, restart_now
        self.arguments = arguments(data.address, self.memory, self.flags, self.vectors, self.J,
                                   self.LU, self.pivots, self.atol, self.tables)

    @classmethod
    def make(cls, data, method, *, rtol, atol, max_step=None, jacobian="analytic",
             max_order=None, input_function=None):
        """The ESDIRK of registry entry `method` (`Stepper.make`; it takes no max_order,
        finite-difference Jacobian or input functions: `Simulator` refuses them)."""
        return cls(data, rtol=rtol, atol=atol, max_step=max_step, method=method.name)

    def reset(self, t, y, *, inputs_changed=False):
        """Continue from time t (s) and state y (2 NDOF + coil currents,): the first stage's
        derivative is recomputed (with inputs_changed, at the integrator's own t and y: the
        last one plus the engine's input response), the step size, Jacobian and Newton matrix
        are kept (`restart`)."""
        inputs_only = bool(inputs_changed) and np.array_equal(y, self.y_array)
        self.y_array[:] = y
        self._restart_now(self.data.address, self.memory, self.flags, float(t), inputs_only)

    def forget(self):
        """Start the next step from nothing: an estimated first step, a new Jacobian."""
        self.memory[M_H] = self.memory[M_H_INPUT] = 0.0
        self.memory[M_ETA] = 1.0
        self.flags[[I_JACOBIAN, I_FRESH, I_REFRESH, I_LU, I_FSAL, I_EXTRA, I_ETA_AGE]] = 0

    def advance(self, t_stop, *, one_step=False, max_steps=None):
        """Integrate to t_stop (s), landing on it exactly (one accepted step only with
        one_step; at most max_steps steps, else StepBudgetSpent); returns t and a view of y.
        Raises SimulationError on failure."""
        self.flags[I_ONE_STEP], self.flags[I_MAX_STEPS] = bool(one_step), int(max_steps or 0)
        status = self.advance_entry.ctypes(self.arguments.ctypes.data, float(t_stop))
        if status == TOO_MUCH_WORK and max_steps:
            error = StepBudgetSpent(f"t = {self.memory[M_T]:.9g} s: the step budget of "
                                    f"{max_steps} integrator steps is spent")
            error.last_good = (float(self.memory[M_T]), self.y_array.copy())
            raise error
        if status != OK:
            raise self.failure(status, self.memory[M_T])
        return self.memory[M_T], self.y_array

    def failure(self, status, t):
        """A SimulationError naming the time and the cause; `last_good` is (t, y) of the last
        accepted step."""
        from ..engine.status import status_message

        cause = int(self.counters[ed.FAILED_STATUS])  # the engine's, where it failed
        detail = f" ({status_message(cause)})" if cause != ed.OK else ""
        error = SimulationError(f"t = {t:.9g} s: {self.label} failed with "
                                f"{FLAG_NAMES.get(status, status)}{detail}")
        error.last_good = (float(t), self.y_array.copy())
        self.forget()  # what it learnt led to the failure: the retry starts afresh
        return error

    def step_count(self):
        """Accepted steps since the integrator was made (cheap: for a step budget)."""
        return int(self.flags[I_STEPS])

    def statistics(self):
        """{"steps", "rejected_steps", "newton_failures", "solver_rhs_evaluations",
        "solver_jacobian_evaluations", "factorizations"} since the integrator was made."""
        f = self.flags
        return {"steps": int(f[I_STEPS]), "rejected_steps": int(f[I_REJECTED]),
                "newton_failures": int(f[I_NEWTON_FAILURES]),
                "solver_rhs_evaluations": int(f[I_RHS]),
                "solver_jacobian_evaluations": int(f[I_JACOBIANS]),
                "factorizations": int(f[I_FACTORIZATIONS])}

    @property
    def restart_memory(self):
        """What the integrator has learnt, as plain numbers: {"initial_step" (s, the next
        step), "jacobian" (n * n,) or empty, "lu_step" (s, h g of the Newton matrix),
        "newton_rate", "refresh" (1: a new Jacobian at the next step), "extra_iterations"
        (the Newton iterations the Jacobian's age has cost, `esdirk_newton.jacobian_cost`),
        "input_step" (s, the largest first step after the next input change, 0: none; `restart`),
        "newton_age" (accepted steps since the contraction was last measured, `ETA_HOLD`)}."""
        # a sparse Newton matrix's Jacobian lives in the packed model (`newton_matrix`): a
        # restart from this memory evaluates a new one
        valid = self.flags[I_JACOBIAN] == 1 and not self.sparse_newton
        return {"initial_step": float(self.memory[M_H]),
                "jacobian": self.J.copy() if valid else np.zeros(0),
                "lu_step": float(self.memory[M_H_LU]) if self.flags[I_LU] else 0.0,
                "newton_rate": float(self.memory[M_ETA]),
                "refresh": int(self.flags[I_REFRESH]),
                "extra_iterations": int(self.flags[I_EXTRA]),
                "input_step": float(self.memory[M_H_INPUT]),
                "newton_age": int(self.flags[I_ETA_AGE])}

    @restart_memory.setter
    def restart_memory(self, memory):
        self.forget()
        numbers = {key: float(memory.get(key, default)) for key, default in (
            ("initial_step", 0.0), ("lu_step", 0.0), ("newton_rate", 1.0), ("refresh", 0.0),
            ("extra_iterations", 0.0), ("input_step", 0.0), ("newton_age", 0.0))}
        jacobian = np.asarray(memory.get("jacobian", ()), dtype=float).reshape(-1)
        for key, value in numbers.items():
            if not (np.isfinite(value) and value >= 0.0):
                raise SimulationError("the integrator memory holds negative or non-finite "
                                      f"numbers: {key} = {value!r}")
        if not np.all(np.isfinite(jacobian)):
            raise SimulationError("the integrator memory holds negative or non-finite "
                                  "numbers: in its jacobian")
        refresh, extra = numbers["refresh"], numbers["extra_iterations"]
        age = numbers["newton_age"]
        if refresh not in (0.0, 1.0) or extra != int(extra) or age != int(age):
            raise SimulationError(f"the integrator memory's refresh = {refresh!r}, "
                                  f"extra_iterations = {extra!r} and newton_age = {age!r}: "
                                  "expected 0 or 1 and a whole number for each count")
        self.memory[M_H], self.memory[M_ETA] = numbers["initial_step"], numbers["newton_rate"]
        self.memory[M_H_INPUT] = numbers["input_step"]
        self.flags[I_ETA_AGE] = min(int(age), int(self.flags[I_ETA_HOLD]))
        lu_step = numbers["lu_step"]
        if jacobian.size == self.n * self.n and not self.sparse_newton:
            self.J[:] = jacobian
            self.flags[I_JACOBIAN] = 1
            self.flags[I_REFRESH] = int(refresh)
            self.flags[I_EXTRA] = min(int(extra), 2**62)
            if lu_step > 0.0 and factor(self.J, self.LU, self.pivots, lu_step, self.flags):
                self.flags[I_LU] = 1
                self.memory[M_H_LU] = lu_step

    def close(self):
        """Nothing to free (numpy arrays only)."""
