"""The engine's first compilation shared by pytest-xdist's workers.

On an empty compiled cache (CI's first run, a new user's first `pytest -n auto`) every
worker's first simulation needs the same entries of the engine. One process at a time
compiles an entry (`flexure.core.numerics.compile_lock`): the other worker waits for it with
nothing to do. Measured on the project's 2-core machine, the default tier on an empty cache
at a load of 6: the two workers waited 52 s between them for each other's compilations, the
longest waits in their first tests, where the other worker compiled what both needed.

Here each worker compiles its share of those entries before its first test, both at once,
so that neither waits for the other at the start (a run with the shares at that load: 6 s
of waits); a worker that later needs the other's share finds it compiled or being compiled.
The first 13 test files on an empty cache, quiet machine (load 1 to 1.8), 3 pairs
alternating: 0.62 to 0.76 of the wall time without it. On a warm cache each entry is only
loaded (a few ms). A run without workers (`-n 0`) or with one does nothing here.
"""

import os

# The entries that the first simulation of most tests needs (a planar dense model, ESDIRK,
# CVODE and IDA), with the CPU seconds each took to compile, in this order, in one process
# on an empty cache (load 4 to 5; the first includes loading numba and LLVM). Operations by
# their `engine.OP_*` name; ADVANCE is the ESDIRK's step.
ENTRIES = (("ACCELERATIONS", 13.7), ("ADVANCE", 5.7), ("TANGENT", 4.1), ("CONFIGURATION", 2.9),
           ("MASS_OF", 1.2), ("POSITIONS", 1.1), ("JACOBIAN", 1.1), ("RHS", 0.7),
           ("STRESS_RESULTANTS", 0.6), ("DF", 0.5), ("DEFORMATIONS", 0.5),
           ("INPUT_RESPONSE", 0.5), ("MASS", 0.4), ("RESIDUAL_JACOBIAN", 0.3),
           ("RESIDUAL", 0.3))


def shares(count):
    """ENTRIES' names in `count` shares of about equal compile CPU: each entry, the costliest
    first, goes to the share with the least so far (the first such share on a tie)."""
    totals, names = [0.0] * count, [[] for _ in range(count)]
    for name, seconds in ENTRIES:
        least = totals.index(min(totals))
        totals[least] += seconds
        names[least].append(name)
    return names


def entry(name):
    """The compiled entry of ENTRIES' `name` (`jit.CompiledEntry`)."""
    from flexure.core.engine import engine
    from flexure.core.simulation.esdirk_entry import advance_entry

    return advance_entry if name == "ADVANCE" else engine.ENTRIES[getattr(engine, f"OP_{name}")]


def compile_this_workers_share():
    """In pytest-xdist's worker k of n >= 2 (its environment says which), compile (or load)
    the entries of share k."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    count = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if not worker.startswith("gw") or count < 2:
        return
    for name in shares(count)[int(worker[2:]) % count]:
        assert entry(name).address  # compiled, or loaded from the cache
