"""The spatial row group (issue 35, item 4): spatial models as cheap per DOF as planar ones.

- One right-hand side of `manipulator_control` (75 DOFs, 952 coordinates, 259 elements,
  rigid clusters) per DOF against the refined planar stage's (`refined_stage(16)`, 93 DOFs),
  both by `refined.rhs_cost` (the engine's RHS operation called in a loop at a state 10 ms
  into a run with every input at 1, the call from Python subtracted). Target: at most 3.
- One Jacobian of `manipulator_control` (the engine's first-order Jacobian, row-major as the
  ESDIRK takes it: an evaluation, the tangent, M_bar^-1 [K C]) in right-hand sides: at most
  20. Beside it one mass matrix (DF, M_bar and its LU after an evaluation), for information.
- A spatial cantilever (`spatial_cantilever`: n BEAMs along x, every deformation a DOF, 6 n
  DOFs, clamped, a 1 N tip load from rest; steel strip 10 x 1 mm, 0.2 m): one implicit step
  (esdirk at rtol 1e-6 for 5 ms: the wall of `Simulator.advance_to`, Jacobians and Newton
  factorisations included, over its steps; CPU time) at 96 and 384 DOFs, both on the sparse
  Newton matrix (`core/engine/newton.py`; docs/simulation.md). Targets: the
  growth from 96 to 384 DOFs at most n^1.2; at 384 DOFs at most Exudyn's step, measured in
  the same run where exudyn is installed (`exudyn_cantilever`: the same strip of
  geometrically exact beams, generalized-alpha at h = 1e-4 s, sparse LU; undamped, as that
  element leaves section damping out, and 2 % off in time where flexure's run is within
  5e-7), alternating with flexure's runs; without exudyn the issue's figure (3.4 ms).
  Beside them, for information only: the same runs' step with esdirk2 (TR-BDF2, order 2,
  as Exudyn's generalized-alpha is; the target row measures the order-4 esdirk).
- The same cantilever at equal error (`cantilever_precision`): the CPU per simulated ms of
  flexure's esdirk and of Exudyn at a tip error of 1e-3 of the deflection over the 5 ms,
  each against its own converged run, interpolated in log-log between the tolerances and
  step sizes around it; the ratio flexure/Exudyn for information (the step row above stays
  the issue's target). `compare.py --plot FILE` also writes error against CPU, both codes.
- The nonlinear 6 mm move on `manipulator_control` against real time is a row of the
  manipulator group.

Run alone: python examples/benchmarks/compare.py --only spatial
"""

import math
import statistics
import time

import numpy as np

from .measure import alternate, log
from .refined import rhs_cost
from .stage_models import refined_stage
from .table import Row

EXUDYN_STEP_384 = 3.4e-3  # s: the measurement of Exudyn's step at 384 DOFs (sparse)
SIZES = (16, 64)  # BEAMs of the cantilevers: 96 and 384 DOFs
ORDER_TWO = "esdirk2"  # the information row's method: one of order 2, as generalized-alpha
CANTILEVER_END = 5e-3  # s simulated per cantilever run


def spatial_cantilever(n, *, length=0.2, output=False):
    """A clamped steel strip along x of n BEAMs (10 mm wide along y, 1 mm thick along z),
    every deformation e1 ... e6 a DOF (6 n DOFs), 1 N down (-z) at the tip; with `output`
    the tip's z (m) its one output, "tip"."""
    from flexure.core import build_model

    spec = cantilever_spec(n, length=length, name=f"spatial_cantilever_{n}")
    spec["nodes"][str(n)]["force"] = [0.0, 0.0, -1.0]
    spec["outputs"] = {"tip": {"node": str(n), "coordinate": "z"}} if output else {}
    return build_model(spec)


def cantilever_spec(n, *, length=0.2, name="cantilever"):
    """The scene (a dict for `build_model`) of `spatial_cantilever`'s strip, unloaded: n
    BEAMs over `length` m, nodes "0" ... str(n) and their rotations "0r" ... f"{n}r"."""
    nodes = {"0": {"position": [0.0, 0.0, 0.0], "fixed": ["x", "y", "z"]},
             "0r": {"rotation": [0.0, 0.0, 0.0], "fixed": True}}
    elements = {}
    for j in range(1, n + 1):
        nodes[str(j)] = {"position": [length * j / n, 0.0, 0.0]}
        nodes[f"{j}r"] = {"rotation": [0.0, 0.0, 0.0]}
        elements[f"b{j}"] = {"type": "BEAM", "section": "strip", "y_axis": [0.0, 1.0, 0.0],
                             "dof": ["e1", "e2", "e3", "e4", "e5", "e6"],
                             "nodes": [str(j - 1), f"{j - 1}r", str(j), f"{j}r"]}
    return {"scene": {"name": name, "dimension": 3},
            "sections": {"strip": {"E": 2.1e11, "nu": 0.3, "rho": 7850.0, "beta": 5e-5,
                                   "width": 0.01, "height": 0.001}},
            "nodes": nodes, "elements": elements}


def jacobian_cost(model, *, repeat=5):
    """(s per Jacobian, s per mass matrix) of the engine at a state 10 ms into a run with every
    input at 1: the medians of `repeat` calls each."""
    from flexure.core import Simulator
    from flexure.core.engine import engine

    sim = Simulator(model, rtol=1e-6)
    sim.set_inputs(np.ones(len(model.inputs)))
    sim.advance_to(0.01)
    y = np.ascontiguousarray(sim.state, dtype=float)
    ydot, J = np.empty_like(y), np.empty(y.size * y.size)
    data = sim.data
    jacobians, masses = [], []
    for _ in range(repeat):
        start = time.perf_counter()
        engine.call(data, engine.OP_JACOBIAN, y, J)
        jacobians.append(time.perf_counter() - start)
        engine.call(data, engine.OP_RHS, y, ydot)
        start = time.perf_counter()
        engine.call(data, engine.OP_MASS)
        masses.append(time.perf_counter() - start)
    return statistics.median(jacobians), statistics.median(masses)


def cantilever_step(model, method="esdirk"):
    """One run of the cantilever with `method` at rtol 1e-6: (CPU s, (steps, rhs, Jacobians,
    Newton factorisations))."""
    from flexure.core import Simulator

    sim = Simulator(model, method=method, rtol=1e-6)
    start = time.process_time()
    sim.advance_to(CANTILEVER_END)
    wall = time.process_time() - start
    stats = sim.statistics
    return wall, (stats["steps"], stats["rhs_evaluations"], stats["jacobian_evaluations"],
                  sim.integrator.statistics()["factorizations"])


def spatial(*, repeat=5, quick=False, plot=None):
    """The rows of the spatial group (the module's docstring); with `plot` (a path) the
    cantilever's work-precision plot written there (`cantilever_precision.plot`)."""
    from flexure.core import load_scene

    rows = []
    manipulator, planar = load_scene("manipulator_control"), refined_stage(16)
    seconds = 0.05 if quick else 0.2
    log("spatial: rhs costs, manipulator_control and the refined planar stage")
    costs = {"manipulator": [], "planar": []}
    for _ in range(1 if quick else 3):  # alternating, the median of each
        costs["manipulator"].append(rhs_cost(manipulator, seconds=seconds)[0])
        costs["planar"].append(rhs_cost(planar, seconds=seconds)[0])
    rhs = {name: statistics.median(values) for name, values in costs.items()}
    per_dof = {"manipulator": rhs["manipulator"] / manipulator.ndof,
               "planar": rhs["planar"] / planar.ndof}
    ratio = per_dof["manipulator"] / per_dof["planar"]
    rows.append(Row(
        f"one rhs of manipulator_control ({manipulator.ndof} DOFs) per DOF <= 3 x the refined "
        f"planar stage's ({planar.ndof} DOFs)",
        f"{1e6 * rhs['manipulator']:.1f} us/eval, {1e6 * per_dof['manipulator']:.2f} us/DOF: "
        f"{ratio:.1f} x the planar stage's",
        f"planar {1e6 * rhs['planar']:.1f} us/eval, {1e6 * per_dof['planar']:.2f} us/DOF; "
        "limit 3 x", ratio / 3.0, ratio <= 3.0))
    log("spatial: the Jacobian of manipulator_control")
    jacobian, mass = jacobian_cost(manipulator, repeat=3 if quick else 7)
    in_rhs = jacobian / rhs["manipulator"]
    rows.append(Row(
        "one Jacobian of manipulator_control <= 20 rhs",
        f"{1e3 * jacobian:.2f} ms = {in_rhs:.1f} rhs (one mass matrix {1e3 * mass:.2f} ms)",
        "<= 20 rhs", in_rhs / 20.0, in_rhs <= 20.0))
    rows += cantilever_rows(1 if quick else min(repeat, 3))
    from .cantilever_precision import precision_rows

    rows += precision_rows(1 if quick else min(repeat, 3), plot_path=plot, quick=quick)[0]
    return rows


def cantilever_rows(repeat):
    """The cantilever's rows: flexure's step at 96 and 384 DOFs beside Exudyn's (measured,
    alternating, where exudyn is installed) and the growth of each."""
    models = {n: spatial_cantilever(n) for n in SIZES}
    for model in models.values():  # the first runs compile or load: not timed
        cantilever_step(model)
        cantilever_step(model, ORDER_TWO)
    cases = {n: (lambda model=model: cantilever_step(model)) for n, model in models.items()}
    cases.update({f"{ORDER_TWO} {n}": (lambda model=model: cantilever_step(model, ORDER_TWO))
                  for n, model in models.items()})
    try:
        from . import exudyn_cantilever
    except ImportError as error:
        log(f"exudyn not available ({error}): the issue's figure stands for its step")
    else:
        for n in SIZES:
            # its timing is already per step: no count to divide by
            cases[f"Exudyn {n}"] = lambda n=n: (exudyn_cantilever.run(n)[0], None)
    t = alternate(cases, repeat, "spatial cantilever")
    per_step = {n: t[n].median / t[n].info[0] for n in SIZES}
    peer = {n: t[f"Exudyn {n}"].median for n in SIZES if f"Exudyn {n}" in t}
    limit = peer.get(64, EXUDYN_STEP_384)
    rows = []
    for n in SIZES:
        steps, evaluations, jacobians, factorisations = t[n].info
        if n in peer:
            beside = f"Exudyn {1e3 * peer[n]:.2f} ms/step (measured)"
        else:
            beside = f"Exudyn {1e3 * EXUDYN_STEP_384:.1f} ms (the issue's)" if n == 64 else ""
        rows.append(Row(
            f"spatial cantilever, {n} BEAMs ({6 * n} DOFs): one implicit step (esdirk, rtol "
            f"1e-6, {1e3 * CANTILEVER_END:g} ms after a 1 N tip load; CPU)",
            f"{1e3 * per_step[n]:.2f} ms/step ({t[n].text()} for {steps} steps, "
            f"{evaluations} rhs, {jacobians} Jacobians, {factorisations} factorisations)",
            beside or "(information)",
            per_step[n] / limit if n == 64 else None,
            per_step[n] <= limit if n == 64 else None))
    # information: the same runs with an order-2 method, as Exudyn's generalized-alpha is
    order_two = {n: t[f"{ORDER_TWO} {n}"] for n in SIZES}
    rows.append(Row(
        f"spatial cantilever: one step with {ORDER_TWO} (TR-BDF2, order 2; the same runs, "
        "information)",
        ", ".join(f"{6 * n} DOFs {1e3 * order_two[n].median / order_two[n].info[0]:.2f} ms/step "
                  f"({order_two[n].info[0]} steps, {order_two[n].info[1]} rhs)" for n in SIZES),
        ("Exudyn " + ", ".join(f"{6 * n} DOFs {1e3 * peer[n]:.2f} ms/step" for n in SIZES)
         if len(peer) == len(SIZES) else "(information)")))
    growth = math.log(per_step[64] / per_step[16]) / math.log(4.0)
    peer_growth = (f"; Exudyn's n^{math.log(peer[64] / peer[16]) / math.log(4.0):.2f}"
                   if len(peer) == 2 else "")
    rows.append(Row("spatial cantilever: the step grows at most as n^1.2 from 96 to 384 DOFs",
                    f"n^{growth:.2f}", f"n^1.2{peer_growth}", growth / 1.2, growth <= 1.2))
    return rows
