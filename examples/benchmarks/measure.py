"""How the benchmark measures: the progress log, timed runs alternating between the cases
(`alternate`, `Timing`), a whole process's CPU and wall time, a compiled loop's CPU per call
(`cpu_per_call`, the profiles'), and the peer side when it is installed."""

import resource
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass

_START = time.perf_counter()


def log(message):
    """Progress on stderr, with the seconds since the start."""
    print(f"[{time.perf_counter() - _START:7.1f} s] {message}", file=sys.stderr, flush=True)


@dataclass
class Timing:
    """Wall times (s) of repeated runs and what the last run returned."""

    walls: list
    info: object = None

    @property
    def median(self):
        return statistics.median(self.walls)

    @property
    def best(self):
        return min(self.walls)

    def text(self, unit="s"):
        if unit == "ms":
            return f"{1e3 * self.median:.1f} ms (min {1e3 * self.best:.1f})"
        return f"{self.median:.3f} s (min {self.best:.3f})"


def cpu_per_call(function, args, count, batches=5):
    """CPU s per call of function(*args, count), a compiled loop that makes `count` calls: the
    median of `batches` batches, after one call that compiles or loads it."""
    function(*args, 1)
    results = []
    for _ in range(batches):
        start = time.process_time()
        function(*args, count)
        results.append((time.process_time() - start) / count)
    return statistics.median(results)


def alternate(cases, repeat, label="", *, budget=120.0):
    """Run the callables of `cases` ({name: f() -> (wall, info)}) in turn, `repeat` rounds.

    Returns {name: Timing}; the runs of different cases interleave so that they share the
    machine's load. No further round starts once the runs took `budget` seconds (a run of
    a minute is timed once)."""
    timings = {name: Timing([]) for name in cases}
    spent = 0.0
    for i in range(repeat):
        if spent > budget:
            log(f"{label}: {i} round(s) of {repeat}, the budget of {budget:g} s is spent")
            break
        for name, run in cases.items():
            if run is None:
                continue
            log(f"{label} {name}: run {i + 1}/{repeat}")
            start = time.perf_counter()
            wall, info = run()
            spent += time.perf_counter() - start
            timings[name].walls.append(wall)
            timings[name].info = info
    return {name: t for name, t in timings.items() if t.walls}


def peer():
    """The Exudyn side (peer_exudyn), or None when exudyn is not installed."""
    try:
        from . import peer_exudyn
    except ImportError as error:
        log(f"exudyn not available ({error}): the peer columns stay empty")
        return None
    return peer_exudyn


def command_cpu(command, env=None):
    """(CPU s, wall s) of running `command` (a list) in a new process: its user + system
    time, which the other processes on a shared machine inflate far less than its wall;
    raises on its failure."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False, env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed: {done.stderr[-2000:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall
