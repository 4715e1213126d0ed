"""Progress of long runs: the reporter, and the closed loop reporting through it."""

import io
import time

import numpy as np
import pytest

from flexure.controllers import run_loop
from flexure.core import load_scene, simulate
from flexure.core.reporting.progress import Progress


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_log_gets_one_line_per_tenth():
    stream = io.StringIO()
    report = Progress("run", stream=stream)
    for fraction in np.linspace(0.0, 1.0, 1001):
        report(fraction)
    lines = stream.getvalue().splitlines()
    assert [line.split(" (")[0] for line in lines] == [f"run: {10 * i} %" for i in range(11)]


def test_a_terminal_gets_one_line_rewritten_in_place():
    stream = Terminal()
    report = Progress("run", stream=stream)
    for fraction in (0.0, 0.5, 0.5, 1.0):
        report(fraction)
    text = stream.getvalue()
    assert text.count("\r") == 3 and text.endswith("\n") and text.count("\n") == 1
    assert "run:  50 %" in text


def test_a_short_run_says_nothing_with_after():
    stream = io.StringIO()
    report = Progress("run", stream=stream, after=3600.0)
    for fraction in (0.0, 0.5, 1.0):
        report(fraction)
    assert stream.getvalue() == ""


def test_the_set_up_before_the_first_report_is_not_the_run():
    """A run's clock starts at its first report: a short run after a long set-up (the
    engine compiling, with its own notice) says nothing, nor counts the set-up."""
    stream = io.StringIO()
    report = Progress("run", stream=stream, after=0.2)
    time.sleep(0.3)  # the set-up
    for fraction in (0.0, 0.5, 1.0):
        report(fraction)
    assert stream.getvalue() == ""


def test_simulate_reports_the_fraction_of_t_end_at_every_step():
    fractions = []
    for grid in (None, np.linspace(0.0, 0.02, 5)):
        fractions.clear()
        result = simulate(load_scene("stage_planar_1dof"), 0.02, inputs={"F": 1.0},
                          output_times=grid, progress=fractions.append)
        assert len(fractions) == result.statistics["steps"]
        assert np.all(np.diff(fractions) > 0) and fractions[-1] == 1.0


@pytest.mark.slow
def test_chunked_libcosim_run_with_progress_equals_the_plain_run():
    """Reporting progress advances libcosim in chunks; the loop must not change."""
    options = dict(duration=0.04, settle=0.01, fs=2000.0, plant="libcosim")
    fractions = []
    reported = run_loop("stage_planar_1dof", progress=fractions.append, **options)
    plain = run_loop("stage_planar_1dof", **options)
    np.testing.assert_array_equal(reported.position, plain.position)
    np.testing.assert_array_equal(reported.force, plain.force)
    assert fractions[-1] == 1.0 and len(fractions) >= 50
    assert fractions == sorted(fractions)


def test_inprocess_loop_reports_progress():
    fractions = []
    run_loop("stage_planar_1dof", duration=0.04, settle=0.01, fs=2000.0,
             progress=fractions.append)
    # the compiled loop reports after each chunk of about 1 % of the samples
    assert 0.0 <= fractions[0] <= 0.02 and fractions[-1] == 1.0 and len(fractions) >= 50
    assert fractions == sorted(fractions)


class Clock:
    """A perf_counter that a test sets."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def test_a_slow_first_tenth_says_how_long_the_run_will_take(monkeypatch):
    """1 % done after 61 s: the log gets a line every 30 s, projecting 1.7 h to go."""
    from flexure.core.reporting import progress

    clock = Clock()
    monkeypatch.setattr(progress.time, "perf_counter", clock)
    stream = io.StringIO()
    report = Progress("run", stream=stream)
    for now, fraction in ((0.0, 0.0), (29.0, 0.004), (31.0, 0.005), (45.0, 0.008),
                          (61.0, 0.01)):
        clock.now = now
        report(fraction)
    lines = stream.getvalue().splitlines()
    assert lines == ["run: 0 % (0.0 s)", "run: 0 % (31.0 s, about 1.7 h to go)",
                     "run: 1 % (61.0 s, about 1.7 h to go)"]


@pytest.mark.parametrize(("seconds", "text"), [(42.0, "42 s"), (720.0, "12 min"),
                                               (12600.0, "3.5 h"), (181440.0, "2.1 days")])
def test_durations_read_as_a_person_reads_them(seconds, text):
    from flexure.core.reporting.progress import duration_words

    assert duration_words(seconds) == text
