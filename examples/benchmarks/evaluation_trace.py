"""Where a model's evaluations go inside its sampled loop's integrator: every engine operation
the ESDIRK calls, and every one those call (the kinematics, J's and A's sparse LUs and solves,
the rigid clusters' kernels, the refined accelerations, the Newton matrix's operations), timed
by a tracer put between the compiled callers and the engine.

Compiled code reaches an operation through the table of the operations' addresses whose
address the packed model holds (dims[ENGINE], `engine.connect`), the engine's own nested
calls too (`operations.run`). The tracer is a C function (numba) with the entries'
signature: it counts the call, reads the cycle counter, forwards the call to the real entry,
reads the counter again and logs (operation, s, depth, cycles). A copy of the table with the
tracer's address in every connected operation's place, put in dims[ENGINE] for the traced
samples, traces them; nothing of the engine changes. Its own cost: two counter reads and a
log row a call (about 0.1 us; the replay's CPU with and without it is printed).

The run: `run_loop` on the 6 mm xy path (esdirk2 at 1e-5, 4 kHz; `reduced_methods.loop_run`)
gives the held forces; they are replayed in a new Simulator with the method and rtol asked
(default the order-4 esdirk at 1e-4, one step a sample on manipulator_reduced), untraced to
the first traced sample, traced for `SAMPLES` samples (the fastest motion about the middle of
the move). Cycles are wall time (converted with the counter's rate measured against
perf_counter), so per-call figures are medians; the totals a sample are compared with the
replay's CPU a sample.

A second replay traced over `AGE_SAMPLES` counts the Newton iterations of each stage by the
age of the Newton matrix's Jacobian (the samples since it was made).

Then OP_RHS from Python at the replay's states (as `rosenbrock_replay.rhs_costs_along`): at a
sample's end state after one at the previous sample's end (a state the sample moved), and again
1e-9 from it (near the last call's), traced the same way: what a moved state's OP_RHS does
that a near one's does not; and at states moved by a fraction of a sample (`FRACTIONS`):
from how far the augmented system's kept factors no longer serve.

    python -m examples.benchmarks.evaluation_trace [MODEL [METHOD RTOL]]

What the Jacobian's age costs, measured by forcing it younger: `jacobian_refresh`.
"""

import ctypes
import statistics
import sys
import time

import numpy as np

from flexure.core.engine import operations as ops

SAMPLES = range(100, 140)  # the traced samples of the replay (of the 250 on the 6 mm move)
RHS_SAMPLES = range(100, 140)
AGE_SAMPLES = range(20, 240)  # traced for the iterations by the Jacobian's age
FRACTIONS = (1.0, 0.3, 0.1, 0.03, 0.01)  # of a sample's change: `rhs_by_distance`
LOG_ROWS = 400_000
(L_OP, L_S, L_DEPTH, L_START, L_END, L_TOP, L_PARENT, L_TIME) = range(8)
WIDTH = 8
DEPTHS = 16  # the deepest nesting logged with its caller
PS = 1e12  # the logged time t's unit: ps
NAMES = {getattr(ops, k): k[3:] for k in dir(ops) if k.startswith("OP_")}
SUBJOBS = {  # (op, s) -> label, where s picks a job
    (ops.OP_STAGE_FORCE, ops.FORCE): "STAGE_FORCE",
    (ops.OP_STAGE_FORCE, ops.FACTOR_A): "STAGE_FORCE (FACTOR_A)",
    (ops.OP_STAGE_FORCE, ops.REFINED_ACCELERATIONS): "STAGE_FORCE (REFINED_ACCELERATIONS)",
    (ops.OP_SPARSE_FACTOR, ops.SPARSE_J): "SPARSE_FACTOR (J)",
    (ops.OP_SPARSE_FACTOR, ops.SPARSE_AUGMENTED): "SPARSE_FACTOR (A)",
    (ops.OP_SPARSE_SOLVE, ops.SPARSE_J): "SPARSE_SOLVE (J)",
    (ops.OP_SPARSE_SOLVE, ops.SPARSE_J_TRANSPOSED): "SPARSE_SOLVE (J^T)",
    (ops.OP_SPARSE_SOLVE, ops.SPARSE_AUGMENTED): "SPARSE_SOLVE (A)",
    (ops.OP_RIGID_CONDENSE, ops.WITH_FORCE): "RIGID_CONDENSE (with force)",
}


def label(op, s):
    """The operation's name, with its job where s picks one."""
    return SUBJOBS.get((int(op), float(s)), NAMES.get(int(op), str(op)))


class Tracer:
    """The tracer of one packed model (the module's docstring): `install()` before the traced
    calls, `remove()` after, `rows()` the log (L_* columns), `clear()`."""

    def __init__(self, data):
        import numba

        from flexure.core.engine import data as ed
        from flexure.core.engine import engine
        from flexure.core.numerics.native import as_int_pointer, call_engine

        from .cycle_counter import cycles

        self.data = data
        self.dims = data.int_array("dims")
        address = int(self.dims[ed.ENGINE])  # the process's table of the entries
        self.real = np.ctypeslib.as_array(
            (ctypes.c_int64 * len(engine.ENTRIES)).from_address(address)).copy()
        self.log = np.zeros((LOG_ROWS, WIDTH), dtype=np.int64)
        # depth, rows, top-level calls, overflow, then the callers' (op, s) codes by depth
        self.control = np.zeros(4 + DEPTHS, dtype=np.int64)
        real, log, control = self.real.ctypes.data, self.log.ctypes.data, \
            self.control.ctypes.data
        rows, width, size = LOG_ROWS, WIDTH, 4 + DEPTHS

        @numba.cfunc(ops.ENTRY)
        def tracer(op, user_data, t, a, b, c, s):
            ctl = numba.carray(as_int_pointer(control), (size,))
            entries = numba.carray(as_int_pointer(log), (rows, width))
            depth = ctl[0]
            if depth == 0:
                ctl[2] += 1
            parent = ctl[3 + depth] if 0 < depth <= size - 4 else -1
            if depth < size - 4:
                ctl[4 + depth] = 4 * op + int(s)
            ctl[0] = depth + 1
            start = cycles()
            status = call_engine(real, op, user_data, t, a, b, c, s)
            end = cycles()
            ctl[0] = depth
            k = ctl[1]
            if k < rows:
                entries[k, 0] = op
                entries[k, 1] = int(s)
                entries[k, 2] = depth
                entries[k, 3] = start
                entries[k, 4] = end
                entries[k, 5] = ctl[2]
                entries[k, 6] = parent
                entries[k, 7] = int(t * 1e12)
                ctl[1] = k + 1
            else:
                ctl[3] += 1
            return status

        self._tracer = tracer  # kept alive: its address is in the table
        self.table = self.real.copy()
        missing = engine.missing_entry.address
        self.table[self.real != missing] = tracer.address
        self._saved = address

    def install(self):
        """Route the packed model's engine calls through the tracer."""
        self.dims[_engine_field()] = self.table.ctypes.data

    def remove(self):
        """Route them to the engine directly again."""
        self.dims[_engine_field()] = self._saved

    def call(self, op, a=None, b=None, c=None, s=0.0, t=0.0):
        """Operation `op` from Python through the tracer (connected beforehand: `engine.call`
        would put the real table back); its status."""
        from flexure.core.numerics.native import float_address

        def address(array):
            return None if array is None else float_address(array)
        return self._tracer.ctypes(op, self.data.address, t, address(a), address(b),
                                   address(c), float(s))

    def clear(self):
        """Forget the log."""
        self.control[:] = 0

    def rows(self):
        """The log's rows so far (calls in order of their ends; L_* columns)."""
        if self.control[3]:
            raise RuntimeError(f"the trace's log overflowed by {self.control[3]} rows")
        return self.log[: self.control[1]].copy()


def _engine_field():
    from flexure.core.engine import data as ed

    return ed.ENGINE


def cycle_rate(seconds=0.2):
    """The cycle counter's ticks per second, against perf_counter."""
    from .cycle_counter import read_cycles

    read_cycles()
    c0, t0 = read_cycles(), time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        pass
    return (read_cycles() - c0) / (time.perf_counter() - t0)


def exclusive(rows):
    """(inclusive, exclusive) cycles of each logged call: exclusive less its callees' (the
    log is in order of the calls' ends, a callee's before its caller's)."""
    inclusive = rows[:, L_END] - rows[:, L_START]
    own = inclusive.astype(float)
    children = {}
    for k in range(rows.shape[0]):
        depth = int(rows[k, L_DEPTH])
        own[k] -= children.pop(depth + 1, 0.0)
        children[depth] = children.get(depth, 0.0) + inclusive[k]
    return inclusive, own


def top_level_of(rows):
    """The top-level call's label each logged call ran under."""
    tops = {}
    for k in range(rows.shape[0]):
        if rows[k, L_DEPTH] == 0:
            tops[int(rows[k, L_TOP])] = label(rows[k, L_OP], rows[k, L_S])
    return [tops.get(int(rows[k, L_TOP]), "?") for k in range(rows.shape[0])]


def call_label(row):
    """A logged call's label, with its caller's below the top level."""
    name = label(row[L_OP], row[L_S])
    if row[L_DEPTH] >= 2 and row[L_PARENT] >= 0:
        name += " in " + label(row[L_PARENT] // 4, row[L_PARENT] % 4)
    return name


def summary(rows, rate, per):
    """{(top-level label, call label): (calls, inclusive s, exclusive s, median inclusive s a
    call)} over the log, the counts and times divided by `per` (samples)."""
    inclusive, own = exclusive(rows)
    tops = top_level_of(rows)
    table = {}
    for k in range(rows.shape[0]):
        key = (tops[k], call_label(rows[k]) if rows[k, L_DEPTH] else "(itself)")
        table.setdefault(key, []).append((inclusive[k], own[k]))
    return {key: (len(v) / per, sum(i for i, _ in v) / rate / per, sum(o for _, o in v) / rate
                  / per, statistics.median(i for i, _ in v) / rate)
            for key, v in table.items()}


def stage_iterations(rows, rate):
    """The ESDIRK's Newton iterations in the log: [(the stage's time t in ps, the
    iteration's index in its stage, the stage force's inclusive s, its kinematics' J solves
    (the prediction and the chord steps), J's factorisations in it, the force solve's s)],
    a stage being a run of stage forces at one t."""
    inclusive, _ = exclusive(rows)
    calls = {}
    for k in range(rows.shape[0]):
        top = int(rows[k, L_TOP])
        entry = calls.setdefault(top, {"label": None, "t": 0, "s": 0.0, "solves": 0,
                                       "factors": 0})
        name = call_label(rows[k])
        if rows[k, L_DEPTH] == 0:
            entry.update(label=name, t=int(rows[k, L_TIME]), s=inclusive[k] / rate)
        elif name == "SPARSE_SOLVE (J) in CONFIGURATION":
            entry["solves"] += 1
        elif name.startswith("SPARSE_FACTOR (J)"):
            entry["factors"] += 1
    out, last_t, index, pending = [], None, 0, None
    for top in sorted(calls):
        c = calls[top]
        if c["label"] == "NEWTON_FORCE_SOLVE" and pending is not None:
            out.append((*pending, c["s"]))
            pending = None
            continue
        if c["label"] != "STAGE_FORCE":
            last_t = None
            continue
        index = index + 1 if c["t"] == last_t else 0
        last_t = c["t"]
        pending = (c["t"], index, c["s"], c["solves"], c["factors"])
    return out


def iterations_by_age(rows, iterations):
    """{the Newton matrix's age in samples (inputs' changes since its Jacobian; 8 for 8 to
    15, 16 for more): [iterations of each stage]} over the log; `iterations` as
    `stage_iterations` gives them from the same log."""
    tops = sorted((int(r[L_TOP]), call_label(r)) for r in rows if r[L_DEPTH] == 0)
    age, stages, k = None, [], 0
    for _, name in tops:
        if name == "INPUT_RESPONSE" and age is not None:
            age += 1
        elif name == "NEWTON_JACOBIAN":
            age = 0
        elif name == "STAGE_FORCE":
            if iterations[k][1] == 0:
                stages.append([age, 1])
            else:
                stages[-1][1] += 1
            k += 1
    out = {}
    for age, count in stages:
        if age is not None:
            out.setdefault(age if age < 8 else 8 if age < 16 else 16, []).append(count)
    return out


def print_iterations(iterations, per):
    """The Newton iterations by their index in the stage."""
    print("\n| iteration in its stage | a sample | stage force us (median) | kinematics' J solves "
          "(mean) | J factorisations (mean) | force solve us (median) |")
    print("|---|---|---|---|---|---|")
    for index in sorted({i for _, i, *_ in iterations}):
        these = [it for it in iterations if it[1] == index]
        print(f"| {index + 1} | {len(these) / per:.2f} | "
              f"{1e6 * statistics.median(it[2] for it in these):.1f} | "
              f"{statistics.mean(it[3] for it in these):.2f} | "
              f"{statistics.mean(it[4] for it in these):.2f} | "
              f"{1e6 * statistics.median(it[5] for it in these):.1f} |")
    stages = sum(1 for it in iterations if it[1] == 0)
    print(f"stages a sample {stages / per:.2f}, iterations a stage "
          f"{len(iterations) / max(stages, 1):.2f}")


def print_summary(title, table, cpu_per=None):
    """The summary as a Markdown table, by top-level call then by time."""
    print(f"\n{title}")
    print("| under | call | calls | incl. us | excl. us | median us a call |")
    print("|---|---|---|---|---|---|")
    tops = sorted({k[0] for k in table}, key=lambda t: -table.get((t, "(itself)"), (0, 0))[1])
    for top in tops:
        keys = sorted((k for k in table if k[0] == top), key=lambda k: -table[k][1])
        for key in keys:
            calls, inc, exc, med = table[key]
            print(f"| {top} | {key[1]} | {calls:.2f} | {1e6 * inc:.1f} | {1e6 * exc:.1f} | "
                  f"{1e6 * med:.1f} |")
    total = sum(v[1] for k, v in table.items() if k[1] == "(itself)")
    print(f"| all | top-level calls | | {1e6 * total:.1f} | | |")
    if cpu_per is not None:
        print(f"| all | the replay's CPU (process time) | | {1e6 * cpu_per:.1f} | | |")


def sizes(model, data):
    """{quantity: value}: the model's and its packing's sizes."""
    from flexure.core.engine import data as ed
    from flexure.core.engine import rigid as rg

    dims = data.int_array("dims")
    elements = {}
    for g in model.groups:
        name = g.kind.__name__.rsplit(".", 1)[-1]
        elements[name] = elements.get(name, 0) + len(g.names)
    rigid = data.int_array("rigid_elements").reshape(-1, rg.ELEMENT_WIDTH)
    out = {"DOFs": int(dims[ed.NDOF]), "coordinates NX": int(dims[ed.NX]),
           "free (reduced) coordinates": int(dims[ed.NFREE]),
           "rigid rows of J": int(dims[ed.NRIGID]), "slaves (dependent nodes' coordinates)":
           int(dims[ed.NSLAVES]), "elements": sum(elements.values())}
    out.update({f"  {k}": v for k, v in sorted(elements.items())})
    out["touching elements (De T_e)"] = int(np.sum(rigid[:, rg.E_INTERNAL] == 0))
    out["internal elements (out of J)"] = int(np.sum(rigid[:, rg.E_INTERNAL] == 1))
    for name, key in (("J", "j_sparse"), ("A", "aug_sparse")):
        n, nnz, fill_l, fill_u = lu_counts(data.int_array(key))
        out[f"{name}: order, nonzeros, L's and U's"] = (n, nnz, fill_l, fill_u)
    return out


def lu_counts(ints):
    """(order, nonzeros of the matrix, of L, of U) of a packed sparse LU (`sparse_lu`'s
    header and column pointers: Ap, Ai, Lp, Li (room_l), Up, ...)."""
    from flexure.core.numerics.sparse_lu import H_SIZE, H_VALID

    n, nnz, room_l, _ = (int(v) for v in ints[:H_VALID])
    lp = H_SIZE + n + 1 + nnz
    up = lp + n + 1 + room_l
    return n, nnz, int(ints[lp + n]), int(ints[up + n])


def replay_traced(model, t, force, method, rtol, samples, trace=True):
    """(the traced log, the cycle rate, CPU s a traced sample, CPU s a sample untraced, the
    states at each sample's end (N, 2 NDOF), the simulator) of the held forces replayed."""
    from flexure.core import Simulator
    from flexure.core.engine import engine as e

    sim = Simulator(model, method=method, rtol=rtol)
    states = np.zeros((len(t) - 1, sim.nstate))
    tracer = None
    untraced, traced = [], []
    for k in range(len(t) - 1):
        if k == samples.start and trace:
            e.connect(sim.data, e.OP_RHS)  # for `rhs_traced`'s calls, in the tracer's table
            tracer = Tracer(sim.data)
            tracer.install()
        if k == samples.stop and trace:
            tracer.remove()
        start = time.process_time()
        sim.set_inputs(force[k])
        sim.advance_to(t[k + 1])
        cpu = time.process_time() - start
        (traced if k in samples else untraced).append(cpu)
        states[k] = sim.state
    return (tracer.rows() if trace else None, cycle_rate(), statistics.median(traced),
            statistics.median(untraced[samples.start // 2:]), states, sim, tracer)


def rhs_traced(sim, tracer, force, states, samples):
    """{where: (log, CPU s a call (median))} of OP_RHS from Python at each sample's end state
    after one at the previous sample's end ("moved") and then 1e-9 from it ("near")."""
    from flexure.core.engine import engine as e

    inputs = sim.data.float_array("inputs")
    out = np.zeros(sim.nstate)
    logs = {"moved": [], "near": []}
    cpu = {"moved": [], "near": []}

    def call(y, where):
        tracer.clear()
        tracer.install()
        start = time.process_time()
        status = tracer.call(e.OP_RHS, y, out)
        cpu[where].append(time.process_time() - start)
        tracer.remove()
        if status != 0:
            raise RuntimeError(f"OP_RHS failed: {status}")
        logs[where].append(tracer.rows())
    for k in samples:
        inputs[:] = force[k]
        call(states[k - 1], "near")  # the last call's state: its near neighbour next
        call(states[k], "moved")
        call(states[k] + 1e-9, "near")
    return {w: (logs[w], statistics.median(cpu[w])) for w in logs}


def rhs_by_distance(sim, tracer, force, states, samples, fractions=FRACTIONS):
    """{fraction: (CPU s a call (median), A's factorisations a call, A's solves a call in the
    refinement)} of OP_RHS at the previous sample's end moved by that fraction of the sample's
    change, after calls at that end and 1e-9 from it (A's kept factors then of that end or of
    an earlier state)."""
    from flexure.core.engine import engine as e

    inputs = sim.data.float_array("inputs")
    out = np.zeros(sim.nstate)
    found = {}
    for fraction in fractions:
        cpu, factors, solves = [], [], []
        for k in samples:
            inputs[:] = force[k]
            for y in (states[k - 1], states[k - 1] + 1e-9):
                tracer.call(e.OP_RHS, y, out)
            tracer.clear()
            tracer.install()
            start = time.process_time()
            tracer.call(e.OP_RHS, states[k - 1] + fraction * (states[k] - states[k - 1]), out)
            cpu.append(time.process_time() - start)
            tracer.remove()
            names = [call_label(r) for r in tracer.rows()]
            factors.append(names.count("SPARSE_FACTOR (A) in ACCELERATIONS"))
            solves.append(names.count("SPARSE_SOLVE (A) in STAGE_FORCE (REFINED_ACCELERATIONS)"))
        found[fraction] = (statistics.median(cpu), statistics.mean(factors),
                           statistics.mean(solves))
    return found


def main(argv=None):
    """Trace the replay and the rhs calls; print the tables."""
    from flexure.core import load_scene

    from .manipulator import REDUCED_MOVE
    from .reduced_methods import loop_run

    args = list(argv if argv is not None else sys.argv[1:])
    name = args[0] if args else "manipulator_reduced"
    method, rtol = (args[1], float(args[2])) if len(args) > 2 else ("esdirk", 1e-4)
    model = load_scene(name)
    _, t, force = loop_run(model, *REDUCED_MOVE)
    plain = replay_traced(model, t, force, method, rtol, SAMPLES, trace=False)[2]
    rows, rate, cpu_traced, _, states, sim, tracer = replay_traced(
        model, t, force, method, rtol, SAMPLES)
    per = len(SAMPLES)
    print(f"{name}, {method} at rtol {rtol:g}: samples {SAMPLES.start} to {SAMPLES.stop - 1} "
          f"traced; CPU a sample (medians) traced {1e3 * cpu_traced:.3f} ms, the same samples "
          f"untraced {1e3 * plain:.3f} ms; cycle rate {rate / 1e9:.3f} GHz")
    print("sizes:", sizes(model, sim.data))
    print_summary("a sample of the replay (a call's figures per sample; us)",
                  summary(rows, rate, per), cpu_traced)
    iterations = stage_iterations(rows, rate)
    print_iterations(iterations, per)
    aged_rows = replay_traced(model, t, force, method, rtol, AGE_SAMPLES)[0]
    print("\niterations a stage by the Newton matrix's age (samples since its Jacobian), samples "
          f"{AGE_SAMPLES.start} to {AGE_SAMPLES.stop - 1}:")
    for age, counts in sorted(iterations_by_age(
            aged_rows, stage_iterations(aged_rows, rate)).items()):
        print(f"  {age}{'+' if age >= 8 else ''}: {len(counts)} stages, "
              f"{statistics.mean(counts):.2f} iterations")
    for where, (logs, cpu) in rhs_traced(sim, tracer, force, states, RHS_SAMPLES).items():
        merged = np.concatenate(logs)
        print_summary(f"OP_RHS from Python, {where} (per call; us; CPU a call {1e6 * cpu:.1f})",
                      summary(merged, rate, len(logs)))
    print("\nOP_RHS moved by a fraction of a sample (CPU us a call, A's factorisations and its "
          "refinement's solves a call):")
    for fraction, (cpu, factors, solves) in rhs_by_distance(sim, tracer, force, states,
                                                            RHS_SAMPLES).items():
        print(f"  {fraction:g}: {1e6 * cpu:.1f} us, {factors:.2f} factorisations, "
              f"{solves:.2f} refinement solves")


if __name__ == "__main__":
    main()
