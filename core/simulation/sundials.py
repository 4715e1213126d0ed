"""SUNDIALS CVODE and IDA through their C interface, with compiled callbacks.

The integrators call the model through C function pointers of numba `cfunc`s: the right-hand
side, the residual and their Jacobians run compiled, with no Python call per evaluation (the
callbacks' user data is the address table of `data.EngineData`). The libraries are the
SUNDIALS 7.9 shared libraries that scikit-sundae's wheel ships; they are loaded with ctypes.

Why this route (measured on stage_planar_3dof; docs/decisions.md): scikit-sundae's
Python callbacks cost 8-10 us per evaluation on top of the model, more than the whole compiled
evaluation (about 1 us); sundials4py, SUNDIALS' own binding, needs Python 3.12 or later and
still calls Python per evaluation. The C interface plus a compiled callback costs nothing per
evaluation beyond the model and SUNDIALS' own step (about 0.3 us per step on a 2-state
problem).

Status: a callback returns 0, 1 (recoverable: CVODE and IDA retry with a smaller step; a
kinematics that does not converge at a trial state) or -1 (unrecoverable: a non-finite state,
or a singular configuration, through which the DOFs cannot describe the motion).
The engine's status code of the last failure is kept, so an error names its cause.
"""

import ctypes
import sys

import numpy as np

from ..engine import data as ed
from ..engine import engine
from ..engine.status import status_message
from ..errors import SimulationError, StepBudgetSpent
from .methods import REGISTRY, SUNDIALS_METHODS
from .stepper import Stepper
from .sundials_callbacks import cvode_jacobian, cvode_rhs, ida_jacobian, ida_residual
from .sundials_libraries import function_address, libraries
from .sundials_restart import (
    A_ACTUAL_INIT_STEP,
    A_ANALYTIC,
    A_DATA,
    A_INIT_STEP,
    A_MEMORY,
    A_NUM_JACOBIANS,
    A_NUM_RHS,
    A_NUM_STEPS,
    A_REINIT,
    A_SIZE,
    A_SOLVE,
    A_STOP,
    A_TRET,
    A_Y,
    L_INITIAL_STEP,
    L_JACOBIAN,
    T_JACOBIANS,
    T_RHS,
    T_SCRATCH,
    T_STEPS,
    cvode_restart_now,
)

_VP, _D, _INT, _LONG = ctypes.c_void_p, ctypes.c_double, ctypes.c_int, ctypes.c_long
CV_BDF, CV_ADAMS = 2, 1
NORMAL, ONE_STEP = 1, 2
TOO_MUCH_WORK = -1  # CV_TOO_MUCH_WORK, IDA_TOO_MUCH_WORK: the step limit of one call reached
MAX_STEPS_PER_CALL = 1_000_000  # the step limit of a call without a budget of its own
METHODS = SUNDIALS_METHODS  # the methods this module runs
JACOBIANS = ("analytic", "finite-difference")



_CV_RHS = ctypes.CFUNCTYPE(_INT, _D, _VP, _VP, _VP)
_CV_JAC = ctypes.CFUNCTYPE(_INT, _D, _VP, _VP, _VP, _VP, _VP, _VP, _VP)
_IDA_RES = ctypes.CFUNCTYPE(_INT, _D, _VP, _VP, _VP, _VP)
_IDA_JAC = ctypes.CFUNCTYPE(_INT, _D, _D, _VP, _VP, _VP, _VP, _VP, _VP, _VP, _VP)


# -- the integrators ----------------------------------------------------------------------------
class _Solver(Stepper):
    """What CVODE and IDA share: the context, the vectors, the dense linear solver, the
    options, the stepping and the counts, and the Python callbacks used instead of the
    compiled ones when an input varies within an interval (`input_function(t)` -> inputs (N),
    set before each compiled evaluation).

    SUNDIALS names the functions of both modules alike, `prefix` + what they do
    ("CVodeSetMaxStep", "IDASetMaxStep"); a subclass names its module (`library`), its prefix
    and its count of right-hand-side (or residual) evaluations, and makes and solves its
    problem (`_solve`)."""

    library = prefix = rhs_count = ""  # set by the subclass
    operations = ()  # the engine's operations its callbacks call (`engine.connect`)

    @classmethod
    def make(cls, data, method, *, rtol, atol, max_step=None, jacobian="analytic",
             max_order=None, input_function=None):
        """The solver of registry entry `method` (`Stepper.make`, `make_solver`)."""
        return make_solver(data, method.name, rtol=rtol, atol=atol, max_step=max_step,
                           jacobian=jacobian, max_order=max_order,
                           input_function=input_function)

    def __init__(self, data, *, rtol, atol, input_function=None):
        lib = libraries()
        self.lib, self.data = lib, engine.connect(data, *self.operations)
        dims = data.int_array("dims")
        self.n = 2 * int(dims[ed.NDOF]) + int(dims[ed.NEL])  # [q - q_ref, qdot, coil currents]
        self.context = _VP()
        _check(lib.core.SUNContext_Create(0, ctypes.byref(self.context)), "SUNContext_Create")
        lib.core.SUNContext_ClearErrHandlers(self.context)  # errors come back as our messages
        self.y = lib.nvec.N_VNew_Serial(self.n, self.context)
        self.yp = lib.nvec.N_VNew_Serial(self.n, self.context)
        self.atol = lib.nvec.N_VNew_Serial(self.n, self.context)
        self.y_array = _vector_array(lib, self.y, self.n)
        self.yp_array = _vector_array(lib, self.yp, self.n)
        _vector_array(lib, self.atol, self.n)[:] = atol
        self.matrix = lib.matrix.SUNDenseMatrix(self.n, self.n, self.context)
        self.linear_solver = lib.linsol.SUNLinSol_Dense(self.y, self.matrix, self.context)
        self.rtol = float(rtol)
        self.tret = _D(0.0)
        self.counters = data.int_array("counters")
        self.input_function = input_function
        self.input_error = None
        self.totals = np.zeros(T_SCRATCH + 1, dtype=np.int64)  # [steps, rhs, jacobians, -]

    def _function(self, name):
        """The module's function `prefix + name`."""
        return getattr(getattr(self.lib, self.library), self.prefix + name)

    def _call(self, name, *args):
        """Call `prefix + name` on this solver's memory; a negative flag raises."""
        _check(self._function(name)(self.memory, *args), self.prefix + name)

    def _set_options(self, jacobian_function, *, jacobian, max_step, max_order):
        """After Init: the tolerances, the user data (the packed model), the dense linear
        solver with the analytic Jacobian if asked for, the step limits and the largest
        order."""
        self._call("SVtolerances", self.rtol, self.atol)
        self._call("SetUserData", self.data.address)
        self._call("SetLinearSolver", self.linear_solver, self.matrix)
        if jacobian == "analytic":
            self._call("SetJacFn", jacobian_function)
        self._call("SetMaxNumSteps", MAX_STEPS_PER_CALL)
        if max_step:
            self._call("SetMaxStep", float(max_step))
        if max_order is not None:
            self._call("SetMaxOrd", int(max_order))

    def _with_inputs(self, compiled, prototype):
        """A ctypes callback that sets the inputs at time t, then calls the compiled one."""
        inputs, function = self.data.float_array("inputs"), self.input_function

        def callback(t, *args):
            try:
                inputs[:] = function(t)
            except SimulationError as error:
                self.input_error = error
                return -1
            return compiled(t, *args)

        return prototype(callback)

    def _accumulate(self):
        """Add the counts since the last (re)start to the totals (ReInit zeroes SUNDIALS')."""
        for slot, value in zip((T_STEPS, T_RHS, T_JACOBIANS), self._current().values(),
                               strict=True):
            self.totals[slot] += value

    def statistics(self):
        """{"steps", "solver_rhs_evaluations", "solver_jacobian_evaluations"} since the
        solver was made."""
        return {key: int(self.totals[slot]) + value for (key, value), slot in
                zip(self._current().items(), (T_STEPS, T_RHS, T_JACOBIANS), strict=True)}

    def step_count(self):
        """Steps since the solver was made (for a step budget)."""
        return self.statistics()["steps"]

    def advance(self, t_stop, *, one_step=False, max_steps=None):
        """Integrate to t_stop (s), never past it (one step only with one_step; at most
        max_steps steps, else StepBudgetSpent); returns t and a view of y (valid until the next
        call). Raises SimulationError on failure."""
        self._function("SetStopTime")(self.memory, float(t_stop))
        if max_steps:
            self._function("SetMaxNumSteps")(self.memory, int(max_steps))
        flag = self._solve(float(t_stop), ONE_STEP if one_step else NORMAL)
        if max_steps:
            self._function("SetMaxNumSteps")(self.memory, MAX_STEPS_PER_CALL)
        if flag == TOO_MUCH_WORK and max_steps:
            raise self.budget_spent(max_steps, self.tret.value)
        if flag < 0:
            raise self.failure(flag, self.tret.value)
        t = self.tret.value
        return (t_stop if flag == 1 else t), self.y_array

    def _current(self):
        """The counts since the last (re)start."""
        def count(name):
            return _get_long(self._function(name), self.memory)

        return {"steps": count("GetNumSteps"), "solver_rhs_evaluations": count(self.rhs_count),
                "solver_jacobian_evaluations": count("GetNumJacEvals")}

    def flag_name(self, flag):
        """SUNDIALS' name of a return flag (e.g. "CV_CONV_FAILURE")."""
        return self._function("GetReturnFlagName")(flag).decode()

    def budget_spent(self, max_steps, t):
        """The StepBudgetSpent of a call that took max_steps steps, at the time t (s) it
        reached; its `last_good` is (t, y) there."""
        error = StepBudgetSpent(f"t = {t:.9g} s: the step budget of {max_steps} integrator "
                                "steps is spent")
        error.last_good = (t, self.y_array.copy())
        return error

    def failure(self, flag, t):
        """A SimulationError for a failed call, naming the time and the engine's cause; its
        `last_good` is (t, y) of the last successful step, which SUNDIALS returns."""
        error = self._failure(flag, t)
        error.last_good = (t, self.y_array.copy())
        return error

    def _failure(self, flag, t):
        if self.input_error is not None:
            error, self.input_error = self.input_error, None
            return error
        cause = int(self.counters[ed.FAILED_STATUS])  # the engine's, where it failed
        name = self.flag_name(flag)
        detail = f" ({status_message(cause)})" if cause != ed.OK else ""
        return SimulationError(f"t = {t:.9g} s: {self.label} failed with {name}{detail}")

    def close(self):
        """Free the SUNDIALS objects (idempotent), and drop the input callbacks, whose
        closures refer to this solver: with them it is freed when its last reference goes,
        not when the collector finds the cycle."""
        if getattr(self, "memory", None):
            self._function("Free")(ctypes.byref(_VP(self.memory)))
            self.memory = None
        if getattr(self, "linear_solver", None):
            self._free_common()
        self._callbacks = self.input_function = None

    def __del__(self):
        if not sys.is_finalizing():  # at exit SUNDIALS may be unloaded already; the OS frees
            self.close()

    def _free_common(self):
        lib = self.lib
        if self.linear_solver:
            lib.linsol.SUNLinSolFree(self.linear_solver)
            lib.matrix.SUNMatDestroy(self.matrix)
            for vector in (self.y, self.yp, self.atol):
                lib.nvec.N_VDestroy(vector)
            lib.core.SUNContext_Free(ctypes.byref(self.context))
            self.linear_solver = None


class Cvode(_Solver):
    """CVODE (BDF or Adams) on ydot = f(t, y), y = [q - q_ref, qdot] (and the coil currents of
    voltage-driven actuators), with the engine.

    Parameters
    ----------
    data : EngineData
        The packed model; its inputs array holds the forces (N) or drive signals (V) of the
        current interval.
    method : str
        "BDF" or "Adams".
    rtol : float
        Relative tolerance.
    atol : array (2 NDOF + coil currents,)
        Absolute tolerances (m, rad, m/s, rad/s, A).
    max_step : float or None
        Largest step (s).
    jacobian : str
        "analytic" (the model's tangent) or "finite-difference" (SUNDIALS').
    max_order : int or None
        Largest order (SUNDIALS' default: 5 for BDF, 12 for Adams).
    """

    library, prefix, rhs_count = "cvode", "CVode", "GetNumRhsEvals"
    operations = tuple(getattr(engine, op) for op in REGISTRY["cvode-bdf"].operations)

    def __init__(self, data, *, method="BDF", rtol, atol, max_step=None, jacobian="analytic",
                 max_order=None, input_function=None):
        super().__init__(data, rtol=rtol, atol=atol, input_function=input_function)
        cv = self.lib.cvode
        self.method = REGISTRY["cvode-bdf" if method == "BDF" else "cvode-adams"]
        self.label = f"CVODE {method}"
        rhs, jac = cvode_rhs.address, cvode_jacobian.address
        if input_function is not None:
            self._callbacks = (self._with_inputs(cvode_rhs.ctypes, _CV_RHS),
                               self._with_inputs(cvode_jacobian.ctypes, _CV_JAC))
            rhs, jac = (ctypes.cast(c, _VP).value for c in self._callbacks)
        self.memory = cv.CVodeCreate(CV_BDF if method == "BDF" else CV_ADAMS, self.context)
        self._call("Init", rhs, 0.0, self.y)
        self._set_options(jac, jacobian=jacobian, max_step=max_step, max_order=max_order)
        # up to 10 Newton iterations (SUNDIALS' default is 3): with the lightly damped kHz
        # modes of a stage, 3 iterations on a reused Jacobian often fail and each failure cuts
        # the step (stage_planar_3dof, 0.3 s of a 1 N step at rtol 1e-6: 2731 steps with 3,
        # 159 with 10)
        self._call("SetMaxNonlinIters", 10)
        self.analytic = jacobian == "analytic"
        self.learnt = np.zeros(2)  # [initial step (s), Jacobian kept] (L_ slots)
        self._jacobians_at_forget = 0
        self.address_table = np.zeros(A_SIZE, dtype=np.int64)
        for slot, address in (
                (A_SOLVE, function_address(cv.CVode)),
                (A_REINIT, function_address(cv.CVodeReInit)),
                (A_STOP, function_address(cv.CVodeSetStopTime)), (A_MEMORY, self.memory),
                (A_Y, self.y), (A_TRET, ctypes.addressof(self.tret)),
                (A_INIT_STEP, function_address(cv.CVodeSetInitStep)),
                (A_ACTUAL_INIT_STEP, function_address(cv.CVodeGetActualInitStep)),
                (A_NUM_STEPS, function_address(cv.CVodeGetNumSteps)),
                (A_NUM_RHS, function_address(cv.CVodeGetNumRhsEvals)),
                (A_NUM_JACOBIANS, function_address(cv.CVodeGetNumJacEvals)),
                (A_DATA, self.data.address), (A_ANALYTIC, int(self.analytic))):
            self.address_table[slot] = address

    @property
    def initial_step(self):
        """The initial step (s) of the next restart; 0: SUNDIALS' estimate."""
        return float(self.learnt[L_INITIAL_STEP])

    @initial_step.setter
    def initial_step(self, value):
        self.learnt[L_INITIAL_STEP] = float(value)

    def reset(self, t, y, *, inputs_changed=False):
        """(Re)start at time t (s) from y (2 NDOF + coil currents,) at order 1, whether or not
        only the inputs changed since the last step (`inputs_changed`, which the one-step
        `Esdirk.reset` takes too): a multistep method's history is wrong after either.

        What the integrator learnt before is kept (`restart_memory`): the first restart
        estimates its initial step, later ones start with that step; and the Jacobian of the
        last setup is handed back once instead of a new one (the tangent changes little
        between restarts at the samples of a loop, and CVODE asks for a fresh one when its
        Newton iteration does not converge with it). The restart itself is `cvode_restart`,
        the compiled sampled loop's too."""
        self.y_array[:] = y
        self.learnt[L_JACOBIAN] = float(self.jacobian_cached())
        _check(cvode_restart_now(self.address_table, self.learnt, self.totals, float(t)),
               "CVodeReInit")

    def forget(self):
        """Start the next restart from nothing: SUNDIALS' initial step, a new Jacobian."""
        self.initial_step = 0.0
        self._jacobians_at_forget = int(self.counters[ed.JACOBIAN_COUNT])
        self.data.int_array("dims")[ed.JACOBIAN_REUSE] = 0
        self.data.float_array("jacobian_cache")[:] = 0.0
        self._call("SetInitStep", 0.0)

    def jacobian_cached(self):
        """Whether a Jacobian has been computed since `forget` (analytic Jacobians only)."""
        return (self.analytic
                and int(self.counters[ed.JACOBIAN_COUNT]) > self._jacobians_at_forget)

    @property
    def restart_memory(self):
        """{"initial_step": s, "jacobian": (2n * 2n,) or empty}: what `reset` keeps."""
        jacobian = (self.data.float_array("jacobian_cache").copy() if self.jacobian_cached()
                    else np.zeros(0))
        return {"initial_step": float(self.initial_step), "jacobian": jacobian}

    @restart_memory.setter
    def restart_memory(self, memory):
        self.forget()
        self.initial_step = float(memory.get("initial_step", 0.0))
        jacobian = np.asarray(memory.get("jacobian", ()), dtype=float).reshape(-1)
        if jacobian.size == self.n * self.n and self.analytic:
            self.data.float_array("jacobian_cache")[:] = jacobian
            self._jacobians_at_forget = int(self.counters[ed.JACOBIAN_COUNT]) - 1

    def learn_initial_step(self):
        """After the first interval since `forget`: keep the initial step CVODE chose."""
        if self.initial_step == 0.0:
            value = _D(0.0)
            self.lib.cvode.CVodeGetActualInitStep(self.memory, ctypes.byref(value))
            self.initial_step = float(value.value)

    def _solve(self, t_stop, task):
        return self.lib.cvode.CVode(self.memory, t_stop, self.y, ctypes.byref(self.tret), task)


class Ida(_Solver):
    """IDA on the implicit form res(t, y, yp) = 0 with the engine; arguments as `Cvode`."""

    library, prefix, rhs_count = "ida", "IDA", "GetNumResEvals"
    operations = tuple(getattr(engine, op) for op in REGISTRY["ida"].operations)

    def __init__(self, data, *, rtol, atol, max_step=None, jacobian="analytic", max_order=None,
                 input_function=None):
        super().__init__(data, rtol=rtol, atol=atol, input_function=input_function)
        ida = self.lib.ida
        self.method = REGISTRY["ida"]
        self.label = "IDA"
        residual, jac = ida_residual.address, ida_jacobian.address
        if input_function is not None:
            self._callbacks = (self._with_inputs(ida_residual.ctypes, _IDA_RES),
                               self._with_inputs(ida_jacobian.ctypes, _IDA_JAC))
            residual, jac = (ctypes.cast(c, _VP).value for c in self._callbacks)
        self.memory = ida.IDACreate(self.context)
        self._call("Init", residual, 0.0, self.y, self.yp)
        self._set_options(jac, jacobian=jacobian, max_step=max_step, max_order=max_order)
        self._ydot = np.zeros(self.n)

    def reset(self, t, y, *, inputs_changed=False):
        """(Re)start at t from y with the consistent yp = f(t, y) (both halves differential),
        whether or not only the inputs changed (`inputs_changed`, as `Cvode.reset`)."""
        if self.input_function is not None:
            self.data.float_array("inputs")[:] = self.input_function(t)
        # at t: a model with kinematic inputs evaluates them on their path then
        status = engine.call(self.data, engine.OP_RHS, np.ascontiguousarray(y, float),
                             self._ydot, t=float(t))
        if status != ed.OK:
            raise SimulationError(f"t = {t:.9g} s: IDA could not start: "
                                  f"{status_message(status)}")
        self._accumulate()
        self.y_array[:] = y
        self.yp_array[:] = self._ydot
        self.counters[ed.FAILED_STATUS] = 0
        self._call("ReInit", float(t), self.y, self.yp)

    def _solve(self, t_stop, task):
        return self.lib.ida.IDASolve(self.memory, t_stop, ctypes.byref(self.tret), self.y,
                                     self.yp, task)


def make_solver(data, method, *, rtol, atol, max_step=None, jacobian="analytic",
                max_order=None, input_function=None):
    """The integrator for `method` ("cvode-bdf", "cvode-adams" or "ida") on packed data.

    max_order: the largest order of the multistep formulas (None: SUNDIALS' default, 5 for
    BDF and IDA, 12 for Adams)."""
    if method not in METHODS:
        raise SimulationError(f"unknown method {method!r}; expected one of {', '.join(METHODS)}")
    if max_order is not None:
        top = 12 if method == "cvode-adams" else 5
        if not (isinstance(max_order, (int, np.integer)) and 1 <= max_order <= top):
            raise SimulationError(f"max_order: expected an integer from 1 to {top} for "
                                  f"{method}, got {max_order!r}")
    if jacobian not in JACOBIANS:
        raise SimulationError(f"unknown jacobian {jacobian!r}; expected one of "
                              f"{', '.join(JACOBIANS)}")
    options = dict(rtol=rtol, atol=atol, max_step=max_step, jacobian=jacobian,
                   max_order=max_order, input_function=input_function)
    if method == "ida":
        return Ida(data, **options)
    return Cvode(data, method="BDF" if method == "cvode-bdf" else "Adams", **options)


def _vector_array(lib, vector, n):
    pointer = lib.nvec.N_VGetArrayPointer(vector)
    return np.ctypeslib.as_array(ctypes.cast(pointer, ctypes.POINTER(_D)), (n,))


def _get_long(function, memory):
    value = _LONG(0)
    function(memory, ctypes.byref(value))
    return int(value.value)


def _check(flag, what):
    if flag is not None and flag < 0:
        raise SimulationError(f"SUNDIALS {what} failed (flag {flag})")
