"""Integrator back-ends: SUNDIALS CVODE and IDA through scikit-sundae, and scipy's solvers.

Every back-end offers the same three calls on the first-order state y = [q, qdot]:
`reset(t, y)` (re)initialises at a consistent state (order 1, new initial step),
`step(t_stop)` takes one accepted step that never passes t_stop and returns (t, y), and
`statistics()`. CVODE integrates ydot = f(t, y) (BDF or Adams); IDA the implicit form
res(t, y, yp) = 0. The Jacobian is the model's tangent (`FirstOrderSystem.jacobian`) or, with
jacobian="finite-difference", SUNDIALS' own difference quotients.

Largest order. BDF of order 3 to 5 is not A-stable: on a lightly damped mode (eigenvalues near
the imaginary axis, such as the 2.1 and 3.6 kHz modes of stage_planar_3dof with a damping ratio
of about 1e-3) it is stable only for steps well below the mode's period; CVODE's stability limit
detection, which lowers the order there, is not offered by scikit-sundae (1.2.0 has no option
for it), and measured (below) it would not help. max_order=2 (BDF2, A-stable) removes that step
limit but keeps the order low. Measured on 1 s of a 1 N step on stage_planar_3dof with the
deviation state (README, work-precision table, 2026-11-21): order 5 is stability-limited at
every tolerance (17 000 to 44 000 steps, 4 to 9 s) and its error is 0.07 to 0.3 rtol times the
2.1 mm motion from rtol 1e-5 down; BDF2 takes 23 to 1.6 times fewer steps down to rtol 1e-7, but
its error is 170 to 3700 rtol times the motion (the 10.6 Hz motion's phase error builds up over
thousands of second-order steps): at rtol 1e-8 it spends 12 s for 7.8e-8 m, where order 5
reaches 5.7e-12 m in 9.1 s. So BDF2 is the faster choice only for errors above about 1e-7 m, and
never keeps the rtol contract; on a smooth scene (truss_1dof_x, 5 periods at rtol 1e-6) order 5
takes 8 times fewer steps and is 100 times more accurate. IDA behaves the same way (IDA of order
5 is as fast as or faster than order 2 at loose tolerances too). The default therefore stays
SUNDIALS' (5); `max_order=2` is for a quick look at a loose tolerance. The step count is the
formulas' own, not the model's: on the stage's exact linearisation with a right-hand side of one
matrix product (examples/solver_floor.py) CVODE BDF takes the same 43 500 steps at rtol 1e-6 (2
times real time with a free model), orders 3 and 4 take 126 000 and 65 000, and CVODE's
stability limit detection did not help either in a single observation the repository cannot
reproduce (a throwaway ctypes probe of scikit-sundae's private solver memory, not committed): 53
014, 58 955 and 58 673 steps instead of 42 070, 43 500 and 43 752 at rtol 1e-5, 1e-6 and 1e-7.
(Before the deviation state BDF2 looked better: with atol = rtol x 0.1 m the kHz modes were
under the tolerance, and order 5 spent 14 900 steps on them for a 2 % error.)
"""

import numpy as np
from sksundae.cvode import CVODE
from sksundae.ida import IDA

from .errors import SimulationError

METHODS = ("cvode-bdf", "cvode-adams", "ida")
JACOBIANS = ("analytic", "finite-difference")


class _Sundials:
    """Shared one-step loop of the scikit-sundae solvers."""

    label = ""

    def step(self, t_stop):
        """One accepted step towards t_stop (never past it); returns (t, y)."""
        result = self.solver.step(t_stop, method="onestep", tstop=t_stop)
        if not result.success:
            raise SimulationError(
                f"t = {result.t:.9g} s: {self.label} failed (status {result.status}): "
                f"{result.message}")
        self.steps += 1
        self._njev = int(result.njev)
        t = float(result.t)
        if result.status == 1 or t >= t_stop:
            t = t_stop
        return t, result.y

    def fd_jacobians(self):
        """Jacobian evaluations counted by SUNDIALS over every restart."""
        return self._njev_total + self._njev

    def _count_restart(self):
        self._njev_total = getattr(self, "_njev_total", 0) + getattr(self, "_njev", 0)
        self._njev = 0


class CvodeIntegrator(_Sundials):
    """CVODE on ydot = f(t, y) with BDF (stiff) or Adams (non-stiff) formulas."""

    def __init__(self, system, *, method="BDF", rtol, atol, max_step=None,
                 jacobian="analytic", max_order=None):
        self.system = system
        self.label = f"CVODE {method}"
        # up to 10 Newton iterations (SUNDIALS' default is 3): with the lightly damped kHz
        # modes of a stage, 3 iterations on a reused Jacobian fail to converge often and
        # each failure cuts the step; measured on stage_planar_3dof, 0.3 s of a 1 N step at
        # rtol 1e-6: 2731 steps with 3, 159 with 10
        options = dict(method=method, rtol=rtol, atol=atol, max_num_steps=1_000_000,
                       max_step=max_step or 0.0, linsolver="dense", max_nonlin_iters=10)
        if max_order is not None:
            options["max_order"] = int(max_order)
        if jacobian == "analytic":
            options["jacfn"] = system.jacobian
        self.solver = CVODE(system.rhs, **options)
        self.steps = 0

    def reset(self, t, y):
        self._count_restart()
        result = self.solver.init_step(t, np.asarray(y, dtype=float))
        if not result.success:
            raise SimulationError(f"t = {t:.9g} s: CVODE could not start: {result.message}")


class IdaIntegrator(_Sundials):
    """IDA on the implicit form res(t, y, yp) = 0 (variable-order BDF)."""

    def __init__(self, system, *, rtol, atol, max_step=None, jacobian="analytic",
                 max_order=None):
        self.system = system
        self.label = "IDA"
        options = dict(rtol=rtol, atol=atol, max_num_steps=1_000_000, max_step=max_step or 0.0,
                       linsolver="dense")
        if max_order is not None:
            options["max_order"] = int(max_order)
        if jacobian == "analytic":
            options["jacfn"] = system.residual_jacobian
        self.solver = IDA(system.residual, **options)
        self.steps = 0

    def reset(self, t, y):
        self._count_restart()
        y = np.asarray(y, dtype=float)
        yp = self.system.derivative(t, y)  # consistent: both halves are differential
        result = self.solver.init_step(t, y, yp)
        if not result.success:
            raise SimulationError(f"t = {t:.9g} s: IDA could not start: {result.message}")


def make_integrator(system, method, *, rtol, atol, max_step=None, jacobian="analytic",
                    max_order=None):
    """The back-end for `method` ("cvode-bdf", "cvode-adams" or "ida").

    max_order: the largest order of the multistep formulas (None: SUNDIALS' default, 5 for
    BDF and IDA, 12 for Adams).
    """
    if max_order is not None:
        top = 12 if method == "cvode-adams" else 5
        if not (isinstance(max_order, (int, np.integer)) and 1 <= max_order <= top):
            raise SimulationError(f"max_order: expected an integer from 1 to {top} for "
                                  f"{method}, got {max_order!r}")
    if jacobian not in JACOBIANS:
        raise SimulationError(f"unknown jacobian {jacobian!r}; expected one of "
                              f"{', '.join(JACOBIANS)}")
    if method == "cvode-bdf":
        return CvodeIntegrator(system, method="BDF", rtol=rtol, atol=atol, max_step=max_step,
                               jacobian=jacobian, max_order=max_order)
    if method == "cvode-adams":
        return CvodeIntegrator(system, method="Adams", rtol=rtol, atol=atol, max_step=max_step,
                               jacobian=jacobian, max_order=max_order)
    if method == "ida":
        return IdaIntegrator(system, rtol=rtol, atol=atol, max_step=max_step, jacobian=jacobian,
                             max_order=max_order)
    raise SimulationError(f"unknown method {method!r}; expected one of {', '.join(METHODS)}")
