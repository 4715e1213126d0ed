"""Where a cold first use spends its compile time: one row per compiled kernel.

Runs one flexure command in this process with an empty compile cache (a new temporary
FLEXURE_CACHE_DIR unless one is given) and records every numba compilation through numba's
event API ("numba:compile" for the njit kernels; the C entry points (`cfunc`), which numba
does not report, through a wrapper of their compile step). Prints a table, most expensive
first:

    kernel        module.function
    n             compilations (one per argument-type signature)
    self (s)      CPU seconds of the kernel's own compilations, its callees' excluded
    llvm (s)      of which LLVM's optimisation and code generation ("numba:llvm_lock")
    total (s)     CPU seconds including the callees compiled on the way

and the process's CPU seconds (user + sys) at the end. A callee's code is linked into each
caller that calls it directly and optimised again there: that work is in the caller's self
time, which is why an entry point that calls much directly is expensive.

    python -m examples.benchmarks.compile_profile                   # flexure loop --no-plot
    python -m examples.benchmarks.compile_profile --top 20 -- loop stage_planar_3dof --no-plot
    python -m examples.benchmarks.compile_profile --fmu             # fmu build + instantiate
    python -m examples.benchmarks.compile_profile --signatures      # each kernel's signatures
    python -m examples.benchmarks.compile_profile --passes          # numba's passes, self CPU
"""

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from collections import defaultdict


class PassRecorder:
    """numba's compiler passes ("numba:run_pass" events) by name, their self CPU time (s):
    the passes of the compilations nested in one (a callee typed on the way) subtracted."""

    def __init__(self):
        self.stack = []  # [name, start, children's time]
        self.passes = defaultdict(lambda: [0, 0.0])  # name: [runs, self time]

    def install(self):
        from numba.core import event

        recorder = self

        class Passes(event.Listener):
            def on_start(self, ev):
                recorder.stack.append([ev.data["name"].split(" [")[0], time.process_time(),
                                       0.0])

            def on_end(self, ev):
                name, start, children = recorder.stack.pop()
                total = time.process_time() - start
                recorder.passes[name][0] += 1
                recorder.passes[name][1] += total - children
                if recorder.stack:
                    recorder.stack[-1][2] += total

        event.register("numba:run_pass", Passes())

    def lines(self, top):
        rows = sorted(self.passes.items(), key=lambda item: -item[1][1])
        lines = [f"{'numba pass':45s} {'runs':>5s} {'self (s)':>9s}", "-" * 61]
        lines += [f"{name:45s} {n:5d} {t:9.2f}" for name, (n, t) in rows[:top]]
        lines.append(f"{'all passes':45s} {'':5s} {sum(t for _, t in self.passes.values()):9.2f}")
        return lines


class CompileRecorder:
    """Nested compile events with their CPU time (process time, s), the callees' subtracted."""

    def __init__(self):
        self.stack = []  # [name, start, children's time, llvm time]
        self.kernels = defaultdict(lambda: {"n": 0, "self": 0.0, "llvm": 0.0, "total": 0.0,
                                            "signatures": [], "callers": []})
        self._llvm_depth, self._llvm_start = 0, 0.0

    def start(self, name, signature):
        self.stack.append([name, time.process_time(), 0.0, 0.0, signature])

    def end(self, discard=False):
        name, start, children, llvm, signature = self.stack.pop()
        total = time.process_time() - start
        if discard:  # loaded from the cache, not compiled
            return
        row = self.kernels[name]
        row["n"] += 1
        row["self"] += total - children
        row["llvm"] += llvm
        row["total"] += total
        row["signatures"].append(signature)
        row["callers"].append(self.stack[-1][0] if self.stack else "(Python)")
        if self.stack:
            self.stack[-1][2] += total

    def llvm(self, starting):
        if starting:
            self._llvm_depth += 1
            if self._llvm_depth == 1:
                self._llvm_start = time.process_time()
        else:
            self._llvm_depth -= 1
            if self._llvm_depth == 0 and self.stack:
                self.stack[-1][3] += time.process_time() - self._llvm_start


def install(recorder):
    """Listen to numba's compile and LLVM events, and wrap the cfuncs' compile step."""
    from numba.core import ccallback, event

    class Compiles(event.Listener):
        def on_start(self, ev):
            function = ev.data["dispatcher"].py_func
            recorder.start(f"{function.__module__}.{function.__qualname__}",
                           str(tuple(ev.data["args"])))

        def on_end(self, ev):
            recorder.end()

    class Llvm(event.Listener):
        def on_start(self, ev):
            recorder.llvm(True)

        def on_end(self, ev):
            recorder.llvm(False)

    event.register("numba:compile", Compiles())
    event.register("numba:llvm_lock", Llvm())
    original = ccallback.CFunc.compile

    def compile(self):  # a cfunc's code is optimised when it is saved, after its compile step
        function = self._pyfunc
        recorder.start(f"{function.__module__}.{function.__qualname__} (cfunc)", str(self._sig))
        hits = self._cache_hits
        try:
            return original(self)
        finally:
            recorder.end(discard=self._cache_hits != hits)

    ccallback.CFunc.compile = compile


def short(name):
    """module.function without the package prefix."""
    for prefix in ("flexure.core.", "flexure."):
        if name.startswith(prefix):
            return name[len(prefix):]
    return name


def table(recorder, top):
    """The rows, most self time first, and the totals."""
    rows = sorted(recorder.kernels.items(), key=lambda item: -item[1]["self"])
    lines = [f"{'kernel':58s} {'n':>3s} {'self (s)':>9s} {'llvm (s)':>9s} {'total (s)':>9s}",
             "-" * 92]
    for name, row in rows[:top]:
        lines.append(f"{short(name):58s} {row['n']:3d} {row['self']:9.2f} {row['llvm']:9.2f} "
                     f"{row['total']:9.2f}")
    compiled = sum(row["self"] for row in recorder.kernels.values())
    repeated = sum(row["n"] - 1 for row in recorder.kernels.values())
    lines.append("-" * 92)
    count = sum(row["n"] for row in recorder.kernels.values())
    lines.append(f"{len(rows)} kernels, {count} compilations ({repeated} of them a kernel "
                 f"again for other argument types), {compiled:.1f} s of CPU compiling")
    return lines


def run_fmu():
    """`flexure fmu build stage_planar_3dof` and the FMU's first instantiate in this process."""
    from flexure.core.cli import main

    with tempfile.TemporaryDirectory(prefix="flexure_fmu_") as folder:
        path = os.path.join(folder, "stage.fmu")
        main(["fmu", "build", "stage_planar_3dof", "-o", path])
        from fmpy import extract, instantiate_fmu, read_model_description

        unpacked = extract(path)
        description = read_model_description(unpacked)
        slave = instantiate_fmu(unpacked, description, fmi_type="CoSimulation")
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        slave.doStep(0.0, 1e-3)
        slave.terminate()
        slave.freeInstance()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--top", type=int, default=25, help="rows to print")
    parser.add_argument("--fmu", action="store_true",
                        help="profile fmu build + instantiate (needs fmpy) instead")
    parser.add_argument("--signatures", action="store_true",
                        help="list each kernel's signatures and who compiled it (the most "
                        "specialised first)")
    parser.add_argument("--passes", action="store_true",
                        help="also print numba's compiler passes by self CPU time")
    parser.add_argument("--keep-cache", action="store_true",
                        help="use FLEXURE_CACHE_DIR as set (a warm run), not a new empty one")
    parser.add_argument("--json", help="also write every kernel's row to this JSON file")
    parser.add_argument("command", nargs="*", help="the flexure command (default: loop "
                        "--no-plot)")
    args = parser.parse_args(argv)
    if not args.keep_cache:
        os.environ["FLEXURE_CACHE_DIR"] = tempfile.mkdtemp(prefix="flexure_cold_cache_")
    os.environ.setdefault("MPLBACKEND", "Agg")
    recorder = CompileRecorder()
    install(recorder)
    passes = PassRecorder() if args.passes else None
    if passes:
        passes.install()
    start = time.perf_counter()
    if args.fmu:
        run_fmu()
    else:
        from flexure.core.cli import main as flexure

        status = flexure(args.command or ["loop", "--no-plot"])
        if status:
            print(f"the command exited with {status}", file=sys.stderr)
    usage = resource.getrusage(resource.RUSAGE_SELF)
    print()
    print("\n".join(table(recorder, args.top)))
    print(f"process CPU {usage.ru_utime + usage.ru_stime:.1f} s (user {usage.ru_utime:.1f}, "
          f"sys {usage.ru_stime:.1f}), wall {time.perf_counter() - start:.1f} s, cache "
          f"{os.environ['FLEXURE_CACHE_DIR']}")
    if passes:
        print()
        print("\n".join(passes.lines(args.top)))
    if args.json:
        with open(args.json, "w") as out:
            json.dump({short(name): row for name, row in recorder.kernels.items()}, out,
                      indent=1)
    if args.signatures:
        for name, row in sorted(recorder.kernels.items(),
                                key=lambda item: -item[1]["n"]):
            if row["n"] > 1:
                print(f"{short(name)}:")
                for signature, caller in zip(row["signatures"], row["callers"], strict=True):
                    print(f"    {signature}  <- {short(caller)}")


if __name__ == "__main__":
    main()
