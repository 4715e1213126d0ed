"""Progress of a long run on standard error, for the command line.

On a terminal one line is rewritten in place ("loop: 42 %  (3.1 s, about 4 s to go)"); in a
log (CI, a file) a line is written at every tenth, and at least every `LOG_EVERY` seconds
between them, so a log shows the run advancing without thousands of lines, and a run whose
first tenth takes an hour says so in its first minute. The time to go is the elapsed time
scaled by the fraction left: a projection at the run's rate so far, not a promise.
"""

import sys
import time

LOG_EVERY = 30.0  # s: the longest a log goes without a line while the run advances


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
        self.last_line = -LOG_EVERY  # s since the start, of the last line in a log

    def __call__(self, fraction):
        fraction = min(max(fraction, 0.0), 1.0)
        percent = int(100 * fraction)
        if self.start is None:
            self.start = time.perf_counter()
        elapsed = time.perf_counter() - self.start
        if elapsed < self.after:
            return
        if self.interactive:
            if percent != self.last_percent:
                end = "\n" if percent == 100 else ""
                self.stream.write(f"\r{self.label}: {percent:3d} %  "
                                  f"({self._times(elapsed, fraction)}){end}")
                self.stream.flush()
        elif percent // 10 != self.last_tenth or elapsed - self.last_line >= LOG_EVERY:
            self.last_tenth = percent // 10
            self.last_line = elapsed
            self.stream.write(f"{self.label}: {percent} % ({self._times(elapsed, fraction)})\n")
            self.stream.flush()
        self.last_percent = percent

    @staticmethod
    def _times(elapsed, fraction):
        """'12.0 s' and, before the end, the time to go at the rate so far."""
        if fraction <= 0.0 or fraction >= 1.0:
            return f"{elapsed:.1f} s"
        left = elapsed * (1.0 - fraction) / fraction
        return f"{elapsed:.1f} s, about {duration_words(left)} to go"


def duration_words(seconds):
    """A duration as a person reads it: '40 s', '12 min', '3.5 h', '2.1 days'."""
    if seconds < 100.0:
        return f"{seconds:.0f} s"
    if seconds < 6000.0:
        return f"{seconds / 60.0:.0f} min"
    if seconds < 2.0 * 86400.0:
        return f"{seconds / 3600.0:.1f} h"
    return f"{seconds / 86400.0:.1f} days"
