"""Progress of a long run on standard error, for the command line.

On a terminal one line is rewritten in place ("loop: 42 %"); in a log (CI, a file) a line is
written at every tenth, so a log shows the run advancing without thousands of lines.
"""

import sys
import time


class Progress:
    """A callable that takes the fraction done (0 to 1) and reports it to `stream`.

    With `after` (s) a run that ends sooner reports nothing (a short `flexure simulate`). The
    run's clock starts at its first report: the set-up before it (loading a model, compiling
    the engine, which has a notice of its own) is not the run's."""

    def __init__(self, label, *, stream=None, after=0.0):
        self.label = label
        self.after = after  # s: say nothing before the run has taken this long
        self.stream = stream if stream is not None else sys.stderr
        self.interactive = getattr(self.stream, "isatty", lambda: False)()
        self.start = None  # perf_counter at the first report
        self.last_percent = -1
        self.last_tenth = -1

    def __call__(self, fraction):
        percent = int(100 * min(max(fraction, 0.0), 1.0))
        if self.start is None:
            self.start = time.perf_counter()
        elapsed = time.perf_counter() - self.start
        if elapsed < self.after:
            return
        if self.interactive:
            if percent != self.last_percent:
                end = "\n" if percent == 100 else ""
                self.stream.write(f"\r{self.label}: {percent:3d} %  ({elapsed:.1f} s){end}")
                self.stream.flush()
        elif percent // 10 != self.last_tenth:
            self.last_tenth = percent // 10
            self.stream.write(f"{self.label}: {percent} % ({elapsed:.1f} s)\n")
            self.stream.flush()
        self.last_percent = percent
