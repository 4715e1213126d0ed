"""The refined row group: the undamped 4-PLBEAM stage's 1 s step, and the cost of one
right-hand-side evaluation against the number of PLBEAMs per spring."""

import statistics
import time

import numpy as np

from .measure import alternate, log
from .stage_models import refined_stage, step_stroke
from .step_scan import capped_step, flexure_step, step_stats_text
from .table import Row

REFINED_METHOD = "esdirk3"  # of the refined undamped stage at rtol 1e-6 (esdirk: 3 x the time)


def rhs_cost(model, *, seconds=0.2):
    """Seconds per engine RHS evaluation at a deformed state, and a short run's integrator
    seconds per rhs evaluation.

    The engine's RHS operation is called from Python in a loop (every input at 1, in its
    unit, after 10 ms of simulation); the same ctypes call of the engine's entry that only
    answers "not connected" is timed alike and subtracted: the cost of the call from Python
    (a few us), which the integrators' compiled callbacks do not pay. Returns (net s, call s,
    run s)."""
    from flexure.core import Simulator
    from flexure.core.engine import data as engine_data
    from flexure.core.engine import engine

    sim = Simulator(model, rtol=1e-6)
    sim.set_inputs(np.ones(len(model.inputs)))
    sim.advance_to(0.01)
    run_cost = sim.statistics["wall_time_s"] / sim.statistics["rhs_evaluations"]
    y = np.ascontiguousarray(sim.state, dtype=float)
    sim.derivative(0.0, y)  # prepares the engine's inputs and reference state
    ydot = np.empty_like(y)
    data = sim.data
    assert engine.call(data, engine.OP_RHS, y, ydot) == engine_data.OK
    rhs, null = engine.ENTRIES[engine.OP_RHS].ctypes, engine.missing_entry.ctypes
    arguments = (data.address, 0.0, y.ctypes.data, ydot.ctypes.data, None, 0.0)
    assert null(engine.OP_RHS, *arguments) == engine_data.NOT_CONNECTED

    def evaluate(count, call=rhs):
        for _ in range(count):
            call(engine.OP_RHS, *arguments)
    start = time.perf_counter()
    evaluate(100)
    count = max(100, int(seconds / max((time.perf_counter() - start) / 100, 1e-9)))
    batches, nulls = [], []
    for _ in range(5):  # alternating the two, the median of each
        start = time.perf_counter()
        evaluate(count)
        batches.append((time.perf_counter() - start) / count)
        start = time.perf_counter()
        evaluate(count, null)
        nulls.append((time.perf_counter() - start) / count)
    total = statistics.median(batches)
    return total - statistics.median(nulls), total, run_cost


def refined(*, repeat=5, quick=False):
    """The undamped 4-PLBEAM stage's 1 s step, and the cost of an evaluation against n."""
    rows = []
    model = refined_stage(4, damped=False)
    cap = 10.0 if quick else None
    t = alternate({"flexure": lambda: capped_step(model, REFINED_METHOD, 1e-6, cap)}, repeat,
                  "refined undamped step", budget=20.0 if quick else 30.0)["flexure"]
    accuracy = ""
    if not quick and "extrapolated" not in t.info:
        log("refined: its error against esdirk at rtol 1e-9")
        _, x, _ = flexure_step(model, REFINED_METHOD, 1e-6)
        _, reference, _ = flexure_step(model, "esdirk", 1e-9)
        error = np.max(np.abs(x - reference)) / step_stroke()
        accuracy = f"; max |x - x_ref| / stroke {error:.1e} (reference: esdirk at rtol 1e-9)"
    rows.append(Row(f"refined stage, 4 PLBEAMs per spring ({model.declared_dof_count} DOFs), "
                    f"undamped 1 s step at rtol 1e-6 ({REFINED_METHOD}): wall <= 2 s",
                    step_stats_text(t) + accuracy, "<= 2 s", t.median / 2.0, t.median <= 2.0))
    per_element = {}
    for n in (1, 2, 4, 8, 16):
        model = refined_stage(n)
        log(f"refined: rhs cost, n = {n} ({model.declared_dof_count} DOFs)")
        cost, call_cost, run_cost = rhs_cost(model, seconds=0.05 if quick else 0.2)
        elements = 2 * n + 1
        per_element[n] = cost / elements
        dofs = model.declared_dof_count
        text = (f"{1e6 * cost:.2f} us/eval, {1e6 * cost / elements:.2f} us/element "
                f"(the call from Python {1e6 * call_cost:.1f} us; in a run "
                f"{1e6 * run_cost:.1f} us per rhs incl. Jacobians, solves)")
        if dofs == 93:
            rows.append(Row(f"one rhs evaluation, n = {n} per spring ({dofs} DOFs, {elements} "
                            "elements): <= 100 us", text, "<= 100 us", 1e6 * cost / 100,
                            cost <= 100e-6))
        else:
            rows.append(Row(f"one rhs evaluation, n = {n} per spring ({dofs} DOFs, {elements} "
                            "elements)", text, ""))
    growth = per_element[16] / per_element[4]
    rows.append(Row("rhs cost grows linearly with the element count: us/element at n = 16 "
                    "<= 1.5 x that at n = 4", f"{1e6 * per_element[16]:.2f} vs "
                    f"{1e6 * per_element[4]:.2f} us/element", "<= 1.5", growth / 1.5,
                    growth <= 1.5))
    return rows
