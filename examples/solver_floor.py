"""The integrators' own floor: how fast could the 1 N step run if the model cost nothing?

The speed target of the simulation (stage_planar_3dof, 1 s of a 1 N step at rtol 1e-6, ten times
faster than real time) is measured on the nonlinear model. This script separates the model's
cost from the solver's: it replaces the nonlinear model by its linearisation at rest
(`flexure.core.state_space`: ydot = A y + B u on y = [q - q0, qdot]), whose right-hand side is
one 6 x 6 product (a few microseconds), and runs it through the SUNDIALS formulas the simulator
uses (CVODE BDF, BDF limited to order 2, Adams, IDA; and scipy's Radau) with the simulator's
tolerances (`default_atol`) and solver options (dense linear solver, up to 10 Newton iterations
in CVODE). The simulator calls SUNDIALS through compiled callbacks on its packed model
(`flexure.core.simulation.sundials`), which take no Python right-hand side; the surrogate's runs
go through scikit-sundae's Python interface to the same SUNDIALS instead. So the step counts
compare one to one, while the surrogate's wall time includes some 10 us of Python per
evaluation: its real-time factor is the floor of a Python model, not of a compiled one. The
linear step response is known exactly (eigen-decomposition of A, checked against the matrix
exponential), so each run's error is exact: the largest output error at the accepted steps (m).

It prints two tables:

- the modes the step excites: frequency, damping ratio, amplitude of the free vibration in the
  DOF positions and velocities, and how long each stays above the absolute tolerance (the time
  an accurate integrator has to follow it);
- per rtol and method: steps, rhs evaluations, wall time, real-time factor (simulated over wall
  time; the target is 10) and the error, together with the nonlinear model under CVODE BDF
  measured in the same run.

    python examples/solver_floor.py [--scene stage_planar_3dof] [--t-end 1]
                                    [--rtols 1e-4,1e-6,1e-8] [--methods ...] [--nonlinear]
"""

import argparse
import time

import numpy as np
import scipy.integrate
import scipy.linalg
from sksundae.cvode import CVODE
from sksundae.ida import IDA

from flexure.core import FlexureError, default_atol, load_scene, simulate, state_space
from flexure.core.reporting.tables import format_table

METHODS = ("cvode-bdf", "cvode-bdf:2", "cvode-adams", "ida", "scipy-radau")


class LinearSurrogate:
    """ydot = A y + b (b = B u for a held input) with the calls the back-ends make."""

    def __init__(self, A, b):
        self.A, self.b, self.n = A, b, A.shape[0] // 2
        self.rhs_count = self.jacobian_count = 0

    def rhs(self, t, y, yp):
        """CVODE right-hand side: fills yp (m/s, m/s^2) at the state y (m, m/s)."""
        self.rhs_count += 1
        yp[:] = self.A @ y + self.b

    def derivative(self, t, y):
        """ydot as a new array (scipy's call)."""
        yp = np.empty_like(y)
        self.rhs(t, y, yp)
        return yp

    def jacobian(self, t, y, yp, JJ):
        """CVODE Jacobian: d ydot / d y = A."""
        self.jacobian_count += 1
        JJ[:, :] = self.A

    def residual(self, t, y, yp, res):
        """IDA residual res = yp - (A y + b)."""
        self.rhs_count += 1
        res[:] = yp - self.A @ y - self.b

    def residual_jacobian(self, t, y, yp, res, cj, JJ):
        """IDA Jacobian d res / d y + cj d res / d yp = cj I - A."""
        self.jacobian_count += 1
        JJ[:, :] = cj * np.eye(self.A.shape[0]) - self.A


class ExactStep:
    """The exact response y(t) of ydot = A y + b from y(0) = 0, by the eigenvectors of A."""

    def __init__(self, A, b):
        self.eigenvalues, self.vectors = scipy.linalg.eig(A)
        magnitudes = np.abs(self.eigenvalues)
        if magnitudes.min() <= 1e-9 * magnitudes.max():
            raise ValueError("the linearisation has a mode without stiffness (a zero "
                             "eigenvalue): the surrogate needs a scene held by its springs")
        if np.linalg.cond(self.vectors) > 1e10:
            raise ValueError("the linearisation's eigenvectors are nearly dependent (repeated "
                             "eigenvalues): its exact step response is not computed here")
        self.coefficients = scipy.linalg.solve(self.vectors, b.astype(complex))
        self.A, self.b = A, b

    def __call__(self, times):
        """y (n_times, n) at the times (s)."""
        lam = self.eigenvalues[None, :]
        growth = np.expm1(lam * np.asarray(times)[:, None]) / lam  # int_0^t exp(lam s) ds
        return np.real((growth * self.coefficients[None, :]) @ self.vectors.T)

    def check(self, t):
        """Relative difference to the matrix exponential at t (round-off: ~1e-10 or less)."""
        n = self.A.shape[0]
        augmented = np.zeros((n + 1, n + 1))
        augmented[:n, :n], augmented[:n, n] = self.A * t, self.b * t
        exact = scipy.linalg.expm(augmented)[:n, n]
        return float(np.max(np.abs(self(np.array([t]))[0] - exact)) / np.max(np.abs(exact)))

    def free_vibration(self):
        """Per complex-conjugate mode pair: (frequency Hz, damping ratio, decay rate 1/s,
        |y| amplitude (2 NDOF,)) of the free vibration y - y_static that the step starts, in
        the state's units (m or rad, m/s or rad/s), amplitude at t = 0."""
        modes = []
        for k, lam in enumerate(self.eigenvalues):
            if lam.imag <= 0:
                continue
            # the pair k, conj(k): y_k(t) = 2 Re(c_k v_k exp(lam t) / lam)
            amplitude = 2.0 * np.abs(self.coefficients[k] * self.vectors[:, k] / lam)
            omega = abs(lam)
            modes.append((omega / (2 * np.pi), -lam.real / omega, -lam.real, amplitude))
        return sorted(modes, key=lambda m: m[0])


def surrogate(scene, force=1.0):
    """(A, b, C, model): the scene's linearisation at rest with `force` N on its first input."""
    model = load_scene(scene)
    ss = state_space(model)
    A, B, C = np.asarray(ss.A), np.asarray(ss.B), np.asarray(ss.C)
    return A, force * B[:, 0], C, model


def run_method(method, A, b, *, rtol, atol, t_end):
    """(steps, rhs, Jacobians, wall s, times, states) of one run of the surrogate."""
    system = LinearSurrogate(A, b)
    y0 = np.zeros(A.shape[0])
    if method == "scipy-radau":
        start = time.perf_counter()
        result = scipy.integrate.solve_ivp(system.derivative, (0.0, t_end), y0, method="Radau",
                                           rtol=rtol, atol=atol, jac=A)
        wall = time.perf_counter() - start
        return (result.t.size - 1, result.nfev, result.njev, wall, result.t, result.y.T)
    name, _, order = method.partition(":")
    options = dict(rtol=rtol, atol=atol, max_num_steps=1_000_000, linsolver="dense")
    if order:
        options["max_order"] = int(order)
    times, states = [0.0], [y0]
    start = time.perf_counter()
    if name == "ida":
        solver = IDA(system.residual, jacfn=system.residual_jacobian, **options)
        solver.init_step(0.0, y0, system.derivative(0.0, y0))
    else:  # the simulator's CVODE options (flexure.core.simulation.sundials.Cvode)
        solver = CVODE(system.rhs, method="BDF" if name == "cvode-bdf" else "Adams",
                       jacfn=system.jacobian, max_nonlin_iters=10, **options)
        solver.init_step(0.0, y0)
    t = 0.0
    while t < t_end:
        result = solver.step(t_end, method="onestep", tstop=t_end)
        if not result.success:
            raise FlexureError(f"t = {result.t:.9g} s: {method} failed: {result.message}")
        t = t_end if result.status == 1 or result.t >= t_end else float(result.t)
        times.append(t)
        states.append(np.array(result.y))
    wall = time.perf_counter() - start
    return (len(times) - 1, system.rhs_count, system.jacobian_count, wall, np.array(times),
            np.array(states))


def mode_table(exact, atol, t_end, dof_names):
    """Rows: the free vibrations the step starts, per DOF, against the absolute tolerance.

    Per mode, the DOFs whose amplitude exceeds their atol (position or velocity), or else the
    one closest to it. Units: m and m/s on a translation, rad and rad/s on a rotation."""
    n = len(dof_names)
    rows = []
    for frequency, zeta, decay, amplitude in exact.free_vibration():
        ratios = amplitude / atol
        ratio_q, ratio_v = ratios[:n], ratios[n:]
        shown = np.flatnonzero(np.maximum(ratio_q, ratio_v) > 1.0)
        if shown.size == 0:
            shown = [int(np.argmax(np.maximum(ratio_q, ratio_v)))]
        for i in shown:
            above = [min(t_end, np.log(r) / decay) if r > 1 else 0.0
                     for r in (ratio_q[i], ratio_v[i])]
            unit = "rad" if dof_names[i].endswith(".phi") else "m"
            rows.append((f"{frequency:.1f}", f"{zeta:.2e}", dof_names[i], unit,
                         f"{amplitude[i]:.2e}", f"{amplitude[n + i]:.2e}",
                         f"{ratio_q[i]:.3g}", f"{ratio_v[i]:.3g}", f"{above[0]:.3f}",
                         f"{above[1]:.3f}"))
    return format_table(["mode Hz", "damping ratio", "DOF", "unit", "amplitude",
                         "velocity amplitude (/s)", "/ atol", "/ atol velocity",
                         "s above atol", "s above atol velocity"], rows)


def measure(scene="stage_planar_3dof", *, t_end=1.0, rtols=(1e-6,), methods=METHODS,
            nonlinear=True):
    """The rows of the method table (dicts), and the mode table of the smallest rtol (text)."""
    A, b, C, model = surrogate(scene)
    exact = ExactStep(A, b)
    if exact.check(t_end) > 1e-8:
        raise ValueError("the eigen-decomposition of the linearisation is too ill-conditioned "
                         "for an exact step response")
    rows = []
    for rtol in rtols:
        atol = default_atol(model, rtol)
        for method in methods:
            steps, rhs, jacobians, wall, times, states = run_method(method, A, b, rtol=rtol,
                                                                    atol=atol, t_end=t_end)
            error = np.max(np.abs((states - exact(times)) @ C.T))
            rows.append({"model": "linear", "method": method, "rtol": rtol, "steps": steps,
                         "rhs": rhs, "jacobians": jacobians, "wall": wall,
                         "us_per_rhs": 1e6 * wall / rhs, "realtime": t_end / wall,
                         "error": error})
        if nonlinear:
            start = time.perf_counter()
            result = simulate(model, t_end, inputs={model.inputs[0].name: 1.0}, rtol=rtol)
            wall = time.perf_counter() - start
            stats = result.statistics
            rows.append({"model": "nonlinear", "method": "cvode-bdf", "rtol": rtol,
                         "steps": stats["steps"], "rhs": stats["rhs_evaluations"],
                         "jacobians": stats["jacobian_evaluations"], "wall": wall,
                         "us_per_rhs": 1e6 * wall / stats["rhs_evaluations"],
                         "realtime": t_end / wall, "error": None})
    stroke = np.max(np.abs(exact(np.linspace(0.0, t_end, 2001)) @ C.T))
    modes = mode_table(exact, default_atol(model, min(rtols)), t_end, model.dof_names)
    return rows, modes, stroke


def table(rows, stroke):
    """The method table as text; the error also relative to the stroke (m)."""
    return format_table(
        ["model", "method", "rtol", "steps", "rhs evals", "Jacobians", "wall s", "us / rhs",
         "x real time", "error (m)", "error / stroke"],
        [(r["model"], r["method"], f"{r['rtol']:.0e}", r["steps"], r["rhs"], r["jacobians"],
          f"{r['wall']:.3f}", f"{r['us_per_rhs']:.1f}", f"{r['realtime']:.2f}",
          "" if r["error"] is None else f"{r['error']:.2e}",
          "" if r["error"] is None else f"{r['error'] / stroke:.1e}") for r in rows])


def main(argv=None):
    """Print both tables; return the rows of the method table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="stage_planar_3dof")
    parser.add_argument("--t-end", type=float, default=1.0)
    parser.add_argument("--rtols", default="1e-6")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--nonlinear", action=argparse.BooleanOptionalAction, default=True,
                        help="also run the nonlinear model (CVODE BDF) at each rtol")
    args = parser.parse_args(argv)
    rtols = [float(r) for r in args.rtols.split(",")]
    try:
        rows, modes, stroke = measure(args.scene, t_end=args.t_end, rtols=rtols,
                                      methods=args.methods.split(","), nonlinear=args.nonlinear)
    except (ValueError, FlexureError) as error:
        parser.exit(2, f"solver_floor.py: {args.scene}: {error}\n")
    print(f"{args.scene}: the free vibrations a 1 N step starts, against the default atol at "
          f"rtol {min(rtols):g}")
    print(modes)
    print()
    print(f"{args.t_end:g} s of the 1 N step (stroke {stroke:.3e} m); linear = the "
          "linearisation at rest with a right-hand side of one matrix product")
    print(table(rows, stroke))
    return rows


if __name__ == "__main__":
    main()
