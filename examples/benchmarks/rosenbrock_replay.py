"""Linearly implicit W-methods on manipulator_reduced's sampled loop, measured: a prototype in
numpy on the engine's operations, replaying the loop's held forces as `reduced_methods` does.

A Rosenbrock-W method takes no Newton iteration: each stage is one evaluation of f and one
solve with the W matrix I - gamma h J, whose J may be old (a W-method keeps its order for any
J). In the transformed form of Hairer & Wanner (Solving ODEs II, IV.7, (7.4)), for the
autonomous y' = f(y) of a sample's held inputs, y = [q - q_ref, qdot]:

    (I - gamma h J) U_i = gamma h f(y + sum_{j<i} a_ij U_j) + gamma sum_{j<i} c_ij U_j
    y_new = y + sum_i m_i U_i,   err = sum_i (m_i - m_hat_i) U_i

The W system is solved by the engine's sparse Newton matrix (`newton_matrix`: the Schur
complement M + gamma h C + (gamma h)^2 K in coordinate space; OP_NEWTON_JACOBIAN at a state,
OP_NEWTON_FACTOR at gamma h, OP_NEWTON_SOLVE), the ESDIRK's own. The methods:

- ROS2 (Verwer, Spee, Blom & Hundsdorfer 1999): 2 stages, order 2 for any J, L-stable,
  gamma = 1 + 1/sqrt(2); embedded y + h k_1 (order 1).
- ROS34PW2 (Rang & Angermann 2005, BIT 45): 4 stages, W-order 3, L-stable, stiffly accurate;
  embedded order 2.

Error control as the ESDIRK's (weights 1 / (rtol max(|y|, |y_new|) + atol), the Simulator's
atol at that rtol), h_next = h min(5, max(0.2, 0.9 err^(-1 / (p_hat + 1)))), landing on each
sample's end (stretched or halved as `esdirk_kernels.advance`); or, with no rtol, a fixed
number of equal steps a sample. The Jacobian (the engine's sparse one, at the state) is made
at every sample's start ("sample"), at every step ("step"), or at the start and then only
after a rejected step whose J was not fresh ("stale"; "sample" renews it there too); W is
factored again whenever gamma h changes.

    python -m examples.benchmarks.rosenbrock_replay [--loops] [MOVE SETTLE]

Prints, per choice: steps, rhs, solves, LUs, Jacobians, the q and v errors against esdirk at
1e-9 on the same forces (`reduced_methods.errors`), the replay's CPU and each operation's
CPU a sample (the engine's calls from Python: what a compiled method would pay for them);
then the order-4 ESDIRK's and the one-step-a-sample W-methods' replays alternated. With
--loops, the closed loop through the prototype against the reference loop (the positions'
largest difference over the stroke, `reduced_methods.closed_loops`' measure).
"""

import statistics
import time

import numpy as np

from flexure.core.engine import operations as ops

from .reduced_methods import REFERENCE_RTOL, arguments, errors, loop_run, replay


def transformed(alpha, Gamma, b, b_hat):
    """(gamma, a, c, m, m_hat) of the transformed form from a Rosenbrock method's (alpha,
    Gamma, b, b_hat) (Hairer & Wanner IV.7: a = alpha Gamma^-1, c = diag(1/gamma) -
    Gamma^-1, m = b Gamma^-1)."""
    G = np.array(Gamma, float)
    Gi = np.linalg.inv(G)
    return (G[0, 0], np.array(alpha, float) @ Gi, np.diag(1.0 / np.diag(G)) - Gi,
            np.array(b, float) @ Gi, np.array(b_hat, float) @ Gi)


_G2 = 1.0 + 1.0 / np.sqrt(2.0)
# ROS2 in Verwer's form: (I - g h J) K1 = h f(y), (I - g h J) K2 = h f(y + K1) - 2 K1,
# y_new = y + 3/2 K1 + 1/2 K2; with U_i = g K_i: a21 = 1/g, c21 = -2/g
ROS2 = (_G2, np.array([[0.0, 0.0], [1.0 / _G2, 0.0]]), np.array([[0.0, 0.0], [-2.0 / _G2, 0.0]]),
        np.array([1.5, 0.5]) / _G2, np.array([1.0, 0.0]) / _G2)
_G4 = 4.3586652150845900e-01
ROS34PW2 = transformed(
    alpha=[[0, 0, 0, 0], [8.7173304301691801e-01, 0, 0, 0],
           [8.4457060015369423e-01, -1.1299064236484185e-01, 0, 0], [0, 0, 1.0, 0]],
    Gamma=[[_G4, 0, 0, 0], [-8.7173304301691801e-01, _G4, 0, 0],
           [-9.0338057013044082e-01, 5.4180672388095326e-02, _G4, 0],
           [2.4212380706095346e-01, -1.2232505839045147e+00, 5.4526025533510214e-01, _G4]],
    b=[2.4212380706095346e-01, -1.2232505839045147e+00, 1.5452602553351020e+00, _G4],
    b_hat=[3.7810903145819369e-01, -9.6042292212423178e-02, 0.5, 2.1793326075422950e-01])
METHODS = {"ros2": (ROS2, 1), "ros34pw2": (ROS34PW2, 2)}  # (tableau, embedded order)
# (method, rtol or None: `substeps` equal steps a sample and no error test, J policy,
# substeps); the first two are one step a sample
CHOICES = (("ros2", None, "sample", 1), ("ros34pw2", None, "sample", 1),
           ("ros2", None, "step", 4), ("ros34pw2", None, "step", 2),
           ("ros34pw2", None, "step", 4), ("ros34pw2", None, "step", 8),
           ("ros2", 1e-4, "sample", 1), ("ros2", 1e-3, "sample", 1),
           ("ros34pw2", 1e-5, "sample", 1), ("ros34pw2", 1e-4, "sample", 1),
           ("ros34pw2", 1e-3, "sample", 1), ("ros34pw2", 1e-4, "stale", 1))
ESDIRK_CHOICES = (("esdirk", 1e-4), ("esdirk2", 1e-5))  # the order-4 row and the base
# the closed loop's (method, rtol, J policy); an ESDIRK row runs the Simulator's plant
LOOP_CHOICES = (("esdirk", 1e-4, ""), ("ros2", None, "sample"), ("ros34pw2", None, "sample"),
                ("ros2", 1e-4, "sample"), ("ros34pw2", 1e-4, "sample"),
                ("ros34pw2", 1e-5, "sample"))
PAIRS = 4  # alternating replays of the order-4 ESDIRK and the one-step-a-sample W-methods


def _ok(status, what):
    """Raise where the engine's operation failed (status != 0)."""
    if status != 0:
        raise RuntimeError(f"{what}: the engine's status {status}")


def w_step(tableau, y, h, f, solve):
    """(y_new, err) of one step of size h (s) of the W-method `tableau` = (gamma, a, c, m,
    m_hat) from y, for f(y) and solve(v, hg) = (I - hg J)^-1 v (J any matrix: a W-method's)."""
    gamma, a, c, m, m_hat = tableau
    hg = h * gamma
    U = []
    for i in range(len(m)):
        Y = y.copy()
        for j in range(i):
            Y += a[i, j] * U[j]
        r = hg * f(Y)
        for j in range(i):
            r += gamma * c[i, j] * U[j]
        U.append(solve(r, hg))
    y_new, err = y.copy(), np.zeros(y.size)
    for i, u in enumerate(U):
        y_new += m[i] * u
        err += (m[i] - m_hat[i]) * u
    return y_new, err


class WMethod:
    """A Rosenbrock-W method ("ros2", "ros34pw2") on the engine's packed model `data` (a
    Simulator's, its inputs held there), from y = [q - q_ref, qdot] (m, rad, m/s, rad/s),
    kept in `y`; atol (2 NDOF,) in those units; rtol, or None for `substeps` equal steps a
    sample with no error test; jacobian the J policy ("sample", "step", "stale": the module's
    docstring). Counts in `counts`, each operation's CPU (s) in `cpu`."""

    def __init__(self, data, y, atol, method, rtol, jacobian="stale", substeps=1):
        from flexure.core.engine import engine

        self.engine, self.data = engine, data
        self.tableau, self.p_hat = METHODS[method]
        self.rtol, self.atol, self.policy, self.substeps = rtol, atol, jacobian, substeps
        self.y = y.copy()
        self.h = 0.0
        self.hg_lu = 0.0
        self.fresh = False
        self.counts = dict.fromkeys(("steps", "rejected", "rhs", "solves", "LUs", "Js"), 0)
        self.cpu = dict.fromkeys(("rhs", "solve", "LU", "J"), 0.0)  # s, each operation's

    def _jacobian(self):
        e = self.engine
        out = np.zeros(self.y.size)
        start = time.process_time()
        _ok(e.call(self.data, ops.OP_NEWTON_JACOBIAN, self.y, out), "the Jacobian")
        self.cpu["J"] += time.process_time() - start
        self.counts["Js"] += 1
        self.fresh, self.hg_lu = True, 0.0

    def _factor(self, hg):
        if hg != self.hg_lu:
            start = time.process_time()
            _ok(self.engine.call(self.data, ops.OP_NEWTON_FACTOR, s=hg), "the factors")
            self.cpu["LU"] += time.process_time() - start
            self.counts["LUs"] += 1
            self.hg_lu = hg

    def _rhs(self, y):
        out = np.zeros(y.size)
        start = time.process_time()
        _ok(self.engine.call(self.data, self.engine.OP_RHS, y, out), "the rhs")
        self.cpu["rhs"] += time.process_time() - start
        self.counts["rhs"] += 1
        return out

    def _solve(self, v, hg):
        self._factor(hg)
        start = time.process_time()
        self.engine.call(self.data, ops.OP_NEWTON_SOLVE, v, s=hg)
        self.cpu["solve"] += time.process_time() - start
        self.counts["solves"] += 1
        return v

    def step(self, h):
        """(y_new, err) of one step of size h (s) from self.y."""
        return w_step(self.tableau, self.y, h, self._rhs, self._solve)

    def advance(self, t, t_stop):
        """Integrate from t to t_stop (s) with the inputs held, landing on t_stop."""
        if self.policy in ("sample", "step") or self.counts["Js"] == 0:
            self._jacobian()
        if self.rtol is None:  # `substeps` equal steps a sample, no error test
            for k in range(self.substeps):
                if k > 0 and self.policy == "step":
                    self._jacobian()
                self.y = self.step((t_stop - t) / self.substeps)[0]
                self.counts["steps"] += 1
            return
        if self.h <= 0.0:
            self.h = t_stop - t
        while t < t_stop:
            h, remaining = self.h, t_stop - t
            if h >= remaining * (1.0 - 1e-10):
                h = remaining
            elif 2.0 * h > remaining:
                h = 0.5 * remaining
            y_new, err = self.step(h)
            weight = 1.0 / (self.rtol * np.maximum(np.abs(self.y), np.abs(y_new)) + self.atol)
            error = float(np.sqrt(np.mean((err * weight) ** 2)))
            factor = 0.9 * error ** (-1.0 / (self.p_hat + 1)) if error > 0 else 5.0
            if not error <= 1.0:
                self.counts["rejected"] += 1
                if not self.fresh:
                    self._jacobian()
                self.h = h * max(0.2, min(1.0, factor))
                continue
            self.y = y_new
            self.fresh = False
            self.counts["steps"] += 1
            t = t_stop if h == remaining else t + h
            self.h = h * min(5.0, max(0.2, factor))


def w_replay(model, t, force, method, rtol, jacobian, substeps=1):
    """(states (N, 2 n), counts, CPU s) of the held forces replayed with a W-method."""
    from flexure.core import Simulator

    sim = Simulator(model, method="esdirk", rtol=rtol or 1e-4)  # its packed model and atol
    inputs = sim.data.float_array("inputs")
    w = WMethod(sim.data, sim.state, sim.integrator.atol, method, rtol, jacobian, substeps)
    states = np.zeros((len(t) - 1, sim.nstate))
    start = time.process_time()
    for k in range(len(t) - 1):
        inputs[:] = force[k]
        w.advance(t[k], t[k + 1])
        states[k] = w.y
    return states, dict(w.counts, cpu=w.cpu), time.process_time() - start


class WPlant:
    """A plant of the closed-loop runner (`controllers.plants`' interface) integrated by a
    W-method: a Simulator's packed model holds the inputs the method evaluates at, a second
    Simulator measures the outputs at the method's state (`set_state`)."""

    def __init__(self, model, method, rtol, jacobian):
        from flexure.core import Simulator

        self.sim = Simulator(model, method="esdirk", rtol=rtol or 1e-4)
        self.meter = Simulator(model, method="esdirk", rtol=rtol or 1e-4)
        self.input_names = list(self.sim.input_names)
        self.inputs = self.sim.data.float_array("inputs")
        self.start = self.meter.get_state()
        self.w = WMethod(self.sim.data, self.sim.state, self.sim.integrator.atol, method, rtol,
                         jacobian)
        self.t = 0.0

    def reset(self):
        return self.output()

    def set_input(self, u):
        self.inputs[:] = u

    def advance(self, t_end):
        self.w.advance(self.t, t_end)
        self.t = t_end

    def output(self):
        self.meter.set_state(dict(self.start, t=self.t, y=self.w.y.copy()))
        return np.asarray(self.meter.outputs(), float)


def closed_loop(model, move, settle, choices):
    """Print the closed loop (the runner's Python loop, `simulate_loop`, around a `WPlant`)
    with each (method, rtol, jacobian) of `choices`: its counts, the positions' largest
    difference from the reference loop's (`run_loop` with esdirk at `REFERENCE_RTOL`) over the
    stroke, and the tracking error over the stroke."""
    from flexure.controllers.loop_design import build_loop
    from flexure.controllers.move_path import move_path
    from flexure.controllers.plants import InProcessPlant
    from flexure.controllers.runner import run_loop
    from flexure.controllers.sample_loop import simulate_loop

    from ..manipulator_loop import MOVES, targets

    path = move_path(model, targets(*MOVES["6 mm xy"]), kind="nonlinear")
    ref = run_loop(model, path=path, plant="inprocess", duration=move, settle=settle,
                   method="esdirk", rtol=REFERENCE_RTOL)
    stroke = np.max(np.abs(ref.reference - ref.reference[0]))
    print("reference loop: max |position - reference| / stroke "
          f"{np.max(np.abs(ref.position - ref.reference)) / stroke:.6e}")
    print("| method | rtol | J | steps | rhs | solves | LUs | Js | positions' error / stroke | "
          "max |position - reference| / stroke |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for method, rtol, jacobian in choices:
        loop, design = build_loop(model, duration=move, settle=settle, path=path)
        plant = WPlant(model, method, rtol, jacobian) if method in METHODS else \
            InProcessPlant(model, method=method, rtol=rtol)  # the harness's check
        _, r, position, _ = simulate_loop(plant, loop, design)
        error = np.max(np.abs(position - ref.position)) / stroke
        tracking = np.max(np.abs(position - r)) / stroke
        c = plant.w.counts if method in METHODS else {
            "steps": plant.statistics["steps"], "rhs": plant.statistics["rhs_evaluations"],
            "solves": "", "LUs": "", "Js": ""}
        print(f"| {method} | {rtol if rtol else 'none'} | {jacobian} | {c['steps']} | "
              f"{c['rhs']} | {c['solves']} | {c['LUs']} | {c['Js']} | {error:.3e} | "
              f"{tracking:.6e} |", flush=True)


def operation_costs(model, reps=200):
    """{operation: CPU s} of one rhs, Newton Jacobian, factor and solve from Python, at a
    small made-up state about the start."""
    from flexure.core import Simulator
    from flexure.core.engine import engine as e

    sim = Simulator(model, method="esdirk", rtol=1e-4)
    y = 1e-6 * np.random.default_rng(0).standard_normal(sim.nstate)
    out, v = np.zeros(sim.nstate), np.ones(sim.nstate)
    calls = {"rhs": lambda: e.call(sim.data, e.OP_RHS, y, out),
             "J": lambda: e.call(sim.data, ops.OP_NEWTON_JACOBIAN, y, out),
             "LU": lambda: e.call(sim.data, ops.OP_NEWTON_FACTOR, s=1e-4),
             "solve": lambda: e.call(sim.data, ops.OP_NEWTON_SOLVE, v, s=1e-4)}
    costs = {}
    for name, call in calls.items():
        call()
        start = time.process_time()
        for _ in range(reps if name != "J" else reps // 10):
            call()
        costs[name] = (time.process_time() - start) / (reps if name != "J" else reps // 10)
    return costs


def rhs_costs_along(model, force, reference, samples=range(100, 200)):
    """{where: median CPU s} of one rhs from Python along the reference's states: at the next
    sample's state and halfway to it after one at the last sample's (the state moved), and
    at or 1e-9 from the last call's state."""
    from flexure.core import Simulator
    from flexure.core.engine import engine as e

    sim = Simulator(model, method="esdirk", rtol=1e-4)
    inputs = sim.data.float_array("inputs")
    out = np.zeros(sim.nstate)

    def cost(y):
        start = time.process_time()
        _ok(e.call(sim.data, e.OP_RHS, y, out), "the rhs")
        return time.process_time() - start
    found = {"same state": [], "1e-9 from it": [], "halfway to the next": [],
             "the next sample's": []}
    for k in samples:
        inputs[:] = force[k]
        found["same state"].append(cost(reference[k]))  # the last call's (from k - 1)
        found["1e-9 from it"].append(cost(reference[k] + 1e-9))
        found["halfway to the next"].append(cost(0.5 * (reference[k] + reference[k + 1])))
        found["the next sample's"].append(cost(reference[k + 1]))
    return {where: statistics.median(v) for where, v in found.items()}


def main(argv=None):
    """Replay the loop's forces with each choice and print the tables; with --loops the
    closed loops instead."""
    from flexure.core import load_scene

    loops, move, settle = arguments(argv)
    model = load_scene("manipulator_reduced")
    if loops:
        closed_loop(model, move, settle, LOOP_CHOICES)
        return
    n = model.declared_dof_count
    _, t, force = loop_run(model, move, settle)
    samples = len(t) - 1
    reference = replay(model, t, force, "esdirk", REFERENCE_RTOL)[0]
    costs = operation_costs(model)
    print("operations at a state about the start:",
          {k: f"{1e6 * v:.0f} us" for k, v in costs.items()}, flush=True)
    print("one rhs along the reference:",
          {k: f"{1e6 * v:.0f} us" for k, v in rhs_costs_along(model, force, reference).items()},
          flush=True)
    for method, rtol in ESDIRK_CHOICES:
        states, c, cpu = replay(model, t, force, method, rtol)
        print(f"{method} {rtol:g}: {c}, errors {errors(states, reference, n)}, {cpu:.2f} s")
    print("| method | rtol | J | steps | rejected | rhs | solves | LUs | Js | q error | "
          "v error | replay CPU (s) | ms a sample: rhs, solves, LUs, Js |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for method, rtol, jacobian, substeps in CHOICES:
        states, c, cpu = w_replay(model, t, force, method, rtol, jacobian, substeps)
        eq, ev = errors(states, reference, n)
        parts = ", ".join(f"{1e3 * c['cpu'][k] / samples:.2f}" for k in ("rhs", "solve", "LU",
                                                                       "J"))
        label = f"{rtol:g}" if rtol else f"none, {substeps} a sample"
        print(f"| {method} | {label} | {jacobian} | {c['steps']} | {c['rejected']} | "
              f"{c['rhs']} | {c['solves']} | {c['LUs']} | {c['Js']} | {eq:.3e} | {ev:.3e} | "
              f"{cpu:.2f} | {parts} |", flush=True)
    cpu = {"esdirk": [], "ros2": [], "ros34pw2": []}
    for _ in range(PAIRS):
        cpu["esdirk"].append(replay(model, t, force, "esdirk", 1e-4)[2])
        for method in ("ros2", "ros34pw2"):
            cpu[method].append(w_replay(model, t, force, method, None, "sample")[2])
    print("replay CPU, alternating (s):", cpu)
    for method in ("ros2", "ros34pw2"):
        ratios = [w / e for w, e in zip(cpu[method], cpu["esdirk"], strict=True)]
        print(f"{method} a step a sample over esdirk at 1e-4: {ratios}, median "
              f"{statistics.median(ratios):.3f}")


if __name__ == "__main__":
    main()
