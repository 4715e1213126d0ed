"""The notice a person gets while flexure's engine compiles, wherever they are.

The first use of a version of flexure on a machine compiles its engine (numba) for about a
minute of CPU, with nothing else to show for it. When an entry point of the engine is missing
from the cache (`flexure.core.numerics.jit`), `CompileNotice.announce` says so, once per
process:

- by default on stderr, always (a terminal, a piped log, CI, a notebook): one line naming
  what compiles, the estimate and the cache folder;
- on a terminal, a progress line while it runs ("compiled 57 of ~200 functions"), redrawn in
  place with a carriage return and erased when the compilation ends;
- within `CompileNotice.notices_to(write)` the line goes to `write` instead, followed by a
  summary when the compilation is done (an FMU's slave hands it the host's FMI logger);
- when another process compiles the same code into the cache and this one waits for it
  (`compile_lock`), one line saying so (`CompileNotice.waiting`), there or on stderr.

The estimate is measured on this machine: each compilation's CPU and wall seconds and the
number of functions it compiled are kept in `compile-time.json` in the cache folder, and the
next notice quotes them; without a record, DEFAULT_CPU_S (measured on the project's machine)
and SLOW_MACHINE_CPU_S (on a slower one of its kind).
A compiled function is a numba compilation event ("numba:compile", numba.core.event) or an
entry point compiled by `jit`.
"""

import contextlib
import datetime
import json
import os
import sys
import tempfile
import time

# A cold `flexure loop` on the project's 2-core development machine, empty cache (load about 2;
# 2026-11-29, docs/benchmarks.md, "a kernel compiled for linking only"): 27.1 s of CPU (the
# median of three whole processes; the commit before, alternating with them: 32.3 s). The
# machine's speed moves by the hour, by up to a third. A new VM of the same kind took 87.3 s
# (2026-12-02, docs/benchmarks.md, session 42): the notice without a record quotes both, so
# that no one on a slow machine thinks it hung.
DEFAULT_CPU_S = 27.1
SLOW_MACHINE_CPU_S = 87.3
DEFAULT_FUNCTIONS = 129
RECORD_NAME = "compile-time.json"


def _listener(notice):
    """A numba event listener that passes its compilation events on to `notice`."""
    from numba.core import event

    class Listener(event.Listener):
        def on_start(self, ev):
            notice.enter()

        def on_end(self, ev):
            notice.leave(counted=True)

    return Listener()


class CompileNotice:
    """The compilation notice of one process (see the module).

    Parameters
    ----------
    folder : str or None
        The cache folder (where the record is kept; None: no record).
    sources : str
        The hash of the sources being compiled. A record is replaced by a compilation at
        least as large, or, when it was of other sources (an earlier version), by one at
        least half as large: a later partial compilation (a script that packs a model
        compiles a tenth of the engine) does not make the estimate of a full one small.
    """

    def __init__(self, folder, sources=""):
        self.folder, self.sources = folder, sources
        self.stream = None  # where the notice and the progress go, unless `sink` is set
        self.sink = None  # write(text), e.g. an FMU's logger, while `notices_to` is active
        self.announced = False
        self.functions = 0  # compiled since the notice
        self.cpu_s = self.wall_s = 0.0  # spent compiling since the notice, s
        self._depth = 0  # nested compilations running
        self._burst = None  # (process time, wall time) when the outermost one began
        self._progress = 0  # length of the progress line on the terminal (0: none shown)
        self._total = DEFAULT_FUNCTIONS  # the estimate's count of functions
        self._owns_record = False
        self._listener = None
        self.waited = False  # whether the waiting notice was given

    # -- what is said ----------------------------------------------------------------------

    def record(self):
        """The last compilation measured here: {"cpu_s", "wall_s", "functions", "date",
        "sources"}, or None."""
        if self.folder is None:
            return None
        try:
            with open(os.path.join(self.folder, RECORD_NAME)) as handle:
                record = json.load(handle)
            float(record["cpu_s"]), float(record["wall_s"]), int(record["functions"])
            return record
        except (OSError, ValueError, KeyError, TypeError):  # none yet, or not ours
            return None

    def estimate(self):
        """(CPU seconds, functions, words saying where the figure comes from)."""
        record = self.record()
        if record is None:
            return (DEFAULT_CPU_S, DEFAULT_FUNCTIONS,
                    f"measured on flexure's 2-core development machines, up to "
                    f"{SLOW_MACHINE_CPU_S:.0f} s on a slower one; none here yet")
        return (float(record["cpu_s"]), int(record["functions"]),
                f"{float(record['wall_s']):.0f} s of wall time when measured here on "
                f"{record.get('date', '?')}")

    def text(self):
        """The notice: what compiles, for how long, and where it is kept."""
        from numba.core import config

        cpu, _, source = self.estimate()
        target = ("this machine" if config.CPU_NAME is None
                  else f"the CPU target {config.CPU_NAME!r}")
        if self.compiled_here_before():
            # what is missing is the part this use needs beyond what an earlier use compiled
            # (another scene's operations, an FMU's slave): often seconds, so the whole
            # engine's time is a bound, not an estimate
            return (f"flexure: compiling its engine for {target}, the parts this use needs "
                    f"that are not yet kept: at most about {cpu:.0f} s of CPU, the whole "
                    f"engine's ({source}); kept in {self.folder}")
        return (f"flexure: compiling its engine for {target}, once per version of flexure: "
                f"about {cpu:.0f} s of CPU ({source}); kept in {self.folder}")

    def compiled_here_before(self):
        """Whether the record is of these sources: this version of flexure has compiled into
        this cache before, so what compiles now is a part of its engine, not all of it."""
        record = self.record()
        return bool(self.sources) and record is not None and record.get("sources") == self.sources

    def summary(self):
        """What the compilation took, once done."""
        return (f"flexure: compiled {self.functions} functions in {self.cpu_s:.0f} s of CPU "
                f"({self.wall_s:.0f} s of wall time); kept in {self.folder}")

    def announce(self, stream=None):
        """Give the notice, once per process, and follow the compilation from here on.

        Parameters
        ----------
        stream : file, optional
            Where the notice goes (default sys.stderr) unless `notices_to` is active; a
            progress line is drawn there too when it is a terminal.
        """
        if self.announced:
            return
        self.announced = True
        self.stream = stream
        self._total = self.estimate()[1]
        self._say(self.text())
        from numba.core import event

        self._listener = _listener(self)
        event.register("numba:compile", self._listener)

    def waiting(self, holder=None):
        """Say, once per process, that it waits for another process compiling the same code
        into the cache (`compile_lock`): a host waiting in silence looks hung.

        Parameters
        ----------
        holder : int, optional
            That process's id, when known.
        """
        if self.waited:
            return
        self.waited = True
        who = "another process" if holder is None else f"process {holder}"
        self._say(f"flexure: waiting for {who}, which compiles the same code of the engine "
                  f"into {self.folder}; this process loads it from there when it is done")

    def close(self):
        """Stop following numba's compilations (a notice made for a test)."""
        if self._listener is not None:
            from numba.core import event

            event.unregister("numba:compile", self._listener)
            self._listener = None

    @contextlib.contextmanager
    def notices_to(self, write):
        """Within this block the notice goes to `write(text)` (no progress line), and a
        summary follows when something was compiled in it."""
        previous, self.sink = self.sink, write
        before = self.functions
        try:
            yield
        finally:
            self.sink = previous
            if self.functions > before:
                write(self.summary())

    # -- following the compilation ---------------------------------------------------------

    @contextlib.contextmanager
    def unit(self, counted=True):
        """A compilation that numba's events do not report (a C entry point's)."""
        self.enter()
        try:
            yield
        finally:
            self.leave(counted)

    def enter(self):
        """A compilation begins (numba's event, or `unit`)."""
        if self._depth == 0:
            self._burst = (time.process_time(), time.perf_counter())
        self._depth += 1

    def leave(self, counted):
        """A compilation ends: counted (unless `counted` is False: code loaded from the
        cache), and when it was the outermost, its time added and the record written."""
        self._depth = max(self._depth - 1, 0)
        if counted and self.announced:
            self.functions += 1
            self._show_progress()
        if self._depth == 0 and self._burst is not None:
            cpu, wall = self._burst
            self._burst = None
            if self.announced:
                self.cpu_s += time.process_time() - cpu
                self.wall_s += time.perf_counter() - wall
                self._erase_progress()
                self._write_record()

    # -- where it goes ---------------------------------------------------------------------

    def _target(self):
        return self.stream if self.stream is not None else sys.stderr

    def _terminal(self):
        return self.sink is None and getattr(self._target(), "isatty", lambda: False)()

    def _say(self, text):
        if self.sink is not None:
            self.sink(text)
            return
        self._erase_progress()
        stream = self._target()
        stream.write(text + "\n")
        stream.flush()

    def _show_progress(self):
        if not self._terminal():
            return
        line = (f"flexure: compiled {self.functions} of ~{max(self._total, self.functions)} "
                "functions")
        stream = self._target()
        stream.write("\r" + line.ljust(self._progress))
        stream.flush()
        self._progress = len(line)

    def _erase_progress(self):
        if self._progress and self._terminal():
            stream = self._target()
            stream.write("\r" + " " * self._progress + "\r")
            stream.flush()
        self._progress = 0

    def _write_record(self):
        """Keep this compilation's figures for the next notice's estimate (see `__init__`)."""
        if self.folder is None:
            return
        old = self.record()
        recorded = 0 if old is None else int(old["functions"])
        if old is not None and old.get("sources") != self.sources:
            recorded = recorded / 2  # an earlier version's: a compilation of about its size
        if not (self._owns_record or self.functions >= recorded):
            return
        record = {"cpu_s": round(self.cpu_s, 1), "wall_s": round(self.wall_s, 1),
                  "functions": self.functions, "date": datetime.date.today().isoformat(),
                  "sources": self.sources}
        temporary = None
        try:
            descriptor, temporary = tempfile.mkstemp(dir=self.folder, suffix=".tmp")
            with os.fdopen(descriptor, "w") as handle:
                json.dump(record, handle)
            os.replace(temporary, os.path.join(self.folder, RECORD_NAME))
            self._owns_record = True
        except OSError:  # a read-only cache folder: the next notice quotes the default
            if temporary is not None and os.path.exists(temporary):
                os.unlink(temporary)
