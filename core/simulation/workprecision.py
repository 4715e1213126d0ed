"""Work-precision study: the error against a tight reference, and the wall time, per method
and tolerance.

Every method integrates the same right-hand side, the compiled engine's: SUNDIALS CVODE
(BDF, Adams) and IDA through `simulate`, and scipy's Radau, BDF and DOP853
(`scipy.integrate.solve_ivp` on `Simulator.derivative`, the implicit ones with the same model
Jacobian, `Simulator.jacobian_matrix`) as the peer baseline. The error is the largest
deviation of any declared output (m) from the reference at equally spaced sample times; the
reference is CVODE Adams at a tight tolerance.

A SUNDIALS method may carry a largest order, "cvode-bdf:2" or "ida:2" (max_order 2, the
A-stable BDF2), so that the study compares the order limit with the default.
"""

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import FlexureError, SimulationError
from ..numerics.blas import blas_threads
from ..reporting.tables import format_table, markdown_table
from .methods import METHOD_TABLE, ONE_STEP_METHODS, SUNDIALS_METHODS  # SUNDIALS' take ":ORDER"

SCIPY_METHODS = {"scipy-radau": "Radau", "scipy-bdf": "BDF", "scipy-dop853": "DOP853"}
ALL_METHODS = SUNDIALS_METHODS + ONE_STEP_METHODS + tuple(SCIPY_METHODS)
# every registered method; a stiff multistep one also at order 2 (A-stable BDF)
DEFAULT_METHODS = (*(name for m in METHOD_TABLE if not m.one_step
                     for name in ((m.name, f"{m.name}:2") if m.stiff else (m.name,))),
                   *ONE_STEP_METHODS, *SCIPY_METHODS)
HEADERS = ["method", "rtol", "max output error (m)", "wall time (s)", "rhs evaluations",
           "steps", "status"]


@dataclass
class WorkPrecision:
    """The rows of a work-precision study and how it was made."""

    scene: str
    t_end: float
    reference_rtol: float
    reference_time_s: float
    rows: list = field(default_factory=list)  # dicts with the HEADERS' quantities

    def table_rows(self):
        return [(r["method"], f"{r['rtol']:.0e}",
                 "" if r["error"] is None else f"{r['error']:.2e}", f"{r['wall_time_s']:.3f}",
                 r["rhs_evaluations"], r["steps"], r["status"]) for r in self.rows]

    def text(self):
        return format_table(HEADERS, self.table_rows(),
                            title=f"work-precision: {self.scene}, {self.t_end:g} s "
                                  f"(reference: cvode-adams at rtol {self.reference_rtol:g})")

    def markdown(self):
        return markdown_table(HEADERS, self.table_rows())

    def to_csv(self, path):
        lines = ["method,rtol,max_output_error_m,wall_time_s,rhs_evaluations,steps,status"]
        for r in self.rows:
            error = "" if r["error"] is None else f"{r['error']:.6e}"
            lines.append(f"{r['method']},{r['rtol']:.3e},{error},{r['wall_time_s']:.6f},"
                         f"{r['rhs_evaluations']},{r['steps']},{r['status']}")
        with open(path, "w") as handle:
            handle.write("\n".join(lines) + "\n")

    def plot(self, path):
        """Log-log plot of the error against the wall time, one line per method (PNG)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 5))
        for i, method in enumerate(dict.fromkeys(r["method"] for r in self.rows)):
            points = [(r["wall_time_s"], r["error"]) for r in self.rows
                      if r["method"] == method and r["error"] is not None and r["error"] > 0]
            # a marker and line per family, as the ten colours come round again
            style = ("^--" if method in SCIPY_METHODS else
                     "s-" if method in ONE_STEP_METHODS else "o-")
            if points:
                ax.loglog(*zip(*points, strict=True), style, color=f"C{i % 10}", label=method)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("max output error (m)")
        ax.set_title(f"{self.scene}: {self.t_end:g} s")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)


@blas_threads()
def work_precision(model, t_end, *, inputs=None, methods=DEFAULT_METHODS,
                   rtols=(1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8), reference_rtol=1e-11,
                   samples=101, time_limit=60.0, progress=None):
    """Run every method at every rtol against a tight reference; a `WorkPrecision`.

    inputs: {name: constant N or callable(t)}. methods: names of `ALL_METHODS`, a SUNDIALS
    one optionally with ":ORDER" (its largest order). time_limit (s) stops a single run that
    takes longer (its row says so). progress: optional callable(row) after each run.
    """
    from .simulation import simulate  # the models and SUNDIALS on first use (cheap `--help`)

    times = np.linspace(0.0, t_end, samples)
    for method in methods:
        parse_method(method)
    start = time.perf_counter()
    reference = simulate(model, t_end, inputs=inputs, method="cvode-adams", rtol=reference_rtol,
                         output_times=times).output_array
    study = WorkPrecision(model.name, t_end, reference_rtol, time.perf_counter() - start)
    for method in methods:  # compiled code loaded (or compiled) before any timed run
        name, _ = parse_method(method)
        if name in ONE_STEP_METHODS:
            simulate(model, 1e-3 * t_end, inputs=inputs, method=name, rtol=1e-3)
    for method in methods:
        for rtol in rtols:
            row = _run(model, t_end, inputs, method, rtol, times, reference, time_limit)
            study.rows.append(row)
            if progress:
                progress(row)
    return study


def parse_method(method):
    """(name, max_order or None) of a study method "NAME" or "NAME:ORDER"."""
    name, _, order = method.partition(":")
    if name not in ALL_METHODS or (order and (name not in SUNDIALS_METHODS
                                              or not order.isdigit())):
        raise SimulationError(f"unknown method {method!r}; expected one of "
                              f"{', '.join(ALL_METHODS)}, a SUNDIALS one optionally with "
                              "':ORDER' (e.g. cvode-bdf:2)")
    return name, int(order) if order else None


def _run(model, t_end, inputs, method, rtol, times, reference, time_limit):
    from .simulation import simulate

    row = {"method": method, "rtol": rtol, "error": None, "wall_time_s": 0.0,
           "rhs_evaluations": 0, "steps": 0, "status": "ok"}
    start = time.perf_counter()
    name, max_order = parse_method(method)
    try:
        if name in SCIPY_METHODS:
            outputs, stats = _scipy_run(model, t_end, inputs, SCIPY_METHODS[name], rtol,
                                        times, start + time_limit)
        else:
            # every accepted step, interpolated to the sample times afterwards (as scipy's
            # dense output): stopping at each sample would cap the step size
            result = simulate(model, t_end, inputs=inputs, method=name, rtol=rtol,
                              max_order=max_order, deadline=start + time_limit)
            outputs, stats = _sampled_outputs(model, result, times), result.statistics
        row["error"] = float(np.max(np.abs(outputs - reference)))
        row["rhs_evaluations"], row["steps"] = stats["rhs_evaluations"], stats["steps"]
    except FlexureError as error:
        row["status"] = "time limit" if "time limit" in str(error) else _short(error)
    row["wall_time_s"] = time.perf_counter() - start
    return row


def _short(error):
    """A one-line status for a failed run: the cause and the time, without commas."""
    text = str(error)
    cause = "singular configuration" if "singular" in text else text.split(": ")[-1][:50]
    where = f" at {text.split(': ')[0]}" if text.startswith("t = ") else ""
    return f"failed{where}: {cause}".replace(",", ";")


def _sampled_outputs(model, result, times):
    """Outputs at `times` from the cubic Hermite interpolant of (q, qdot) over the steps."""
    import scipy.interpolate  # 0.05 s to import: only where it is used

    from .simulator import Simulator

    spline = scipy.interpolate.CubicHermiteSpline(result.times, result.q, result.qdot)
    states = np.hstack([spline(times), spline.derivative()(times)])
    return Simulator(model).outputs_along(states)


def _scipy_run(model, t_end, inputs, method, rtol, times, deadline):
    """scipy.integrate.solve_ivp on the same right-hand side (and Jacobian for the implicit)."""
    import scipy.integrate  # 0.05 s to import: only where it is used

    from .simulation import split_inputs
    from .simulator import Simulator

    constants, functions, samples = split_inputs(model, inputs or {})
    if samples:
        raise SimulationError("the scipy baseline takes constant or callable inputs only")
    sim = Simulator(model, rtol=rtol, input_functions=functions)
    u = np.zeros(len(sim.input_names))
    for i, value in constants.items():
        u[i] = value
    sim.set_inputs(u)
    sim.deadline = deadline
    options = {"jac": sim.jacobian_matrix} if method in ("Radau", "BDF") else {}
    rhs_evaluations = 0

    def derivative(t, y):
        # a trial stage that leaves the mechanism's range (kinematics unsolvable) is answered
        # with an infinite derivative, so that scipy rejects the step and shrinks it (SUNDIALS
        # gets the same through a restart in Simulator.advance)
        nonlocal rhs_evaluations
        rhs_evaluations += 1
        try:
            return sim.derivative(t, y)
        except SimulationError as error:
            if "time limit" in str(error):
                raise
            return np.full_like(y, np.inf)

    solution = scipy.integrate.solve_ivp(derivative, (0.0, t_end), sim.state,
                                         method=method, t_eval=times, rtol=rtol,
                                         atol=sim.atol, **options)
    if not solution.success:
        raise SimulationError(f"scipy {method}: {solution.message}")
    outputs = sim.outputs_along(sim.absolute(solution.y.T))
    # solve_ivp does not report its number of steps when t_eval is given
    return outputs, {"rhs_evaluations": rhs_evaluations, "steps": "-"}
