"""The compilation notice (flexure.core.numerics.compile_notice): once per process, on any
stream, with a progress line on a terminal that is erased when the compilation ends, an
estimate from the last compilation recorded in the cache folder, and through a writer (an
FMU's logger) when one is given; and the CLI's notice on a piped stderr, at a real first
compilation. The FMU's notice in its host's log: tests/test_fmu_engine.py."""

import datetime
import io
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import children
import numba
import pytest

from flexure.core.numerics.compile_notice import (
    DEFAULT_CPU_S,
    DEFAULT_FUNCTIONS,
    RECORD_NAME,
    SLOW_MACHINE_CPU_S,
    CompileNotice,
)


class Terminal(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture
def notices():
    """Make CompileNotice objects; each stops following numba's compilations at the end."""
    made = []

    def make(folder, sources="sources"):
        made.append(CompileNotice(str(folder), sources))
        return made[-1]

    yield make
    for notice in made:
        notice.close()


def test_a_terminal_sees_a_progress_line_that_is_erased_at_the_end(tmp_path, notices):
    terminal, log = Terminal(), io.StringIO()
    for stream in (terminal, log):
        notice = notices(tmp_path / stream.__class__.__name__)
        os.makedirs(notice.folder)
        notice.announce(stream)
        with notice.unit():
            with notice.unit():  # a callee compiled while its caller compiles
                pass
        assert notice.functions == 2
    line = f"flexure: compiled 2 of ~{DEFAULT_FUNCTIONS} functions"
    shown = terminal.getvalue()
    assert f"\rflexure: compiled 1 of ~{DEFAULT_FUNCTIONS} functions" in shown
    assert shown.endswith(f"\r{line}\r{' ' * len(line)}\r"), repr(shown[-200:])
    assert "\r" not in log.getvalue() and log.getvalue().count("\n") == 1


def test_numbas_own_compilations_are_counted(tmp_path, notices):
    """The functions numba compiles (its "numba:compile" events) count, nested or not."""
    notice = notices(tmp_path)
    notice.announce(io.StringIO())

    @numba.njit
    def inner(x):
        return x + 1

    @numba.njit
    def outer(x):
        return inner(x) * 2

    assert outer(1) == 4 and outer(1.5) == 5.0
    assert notice.functions == 4  # outer and inner, each for an int and a float
    assert notice.cpu_s > 0.0 and notice.wall_s > 0.0


def test_the_estimate_is_the_largest_recent_compilation_recorded_on_this_machine(tmp_path, notices):
    first = notices(tmp_path, "sources-1")
    assert f"about {DEFAULT_CPU_S:.0f} s of CPU" in first.text()
    assert "none here yet" in first.text()
    assert f"up to {SLOW_MACHINE_CPU_S:.0f} s on a slower one" in first.text()
    first.announce(io.StringIO())
    for _ in range(3):
        with first.unit():
            time.sleep(0.01)
    record = json.loads((tmp_path / RECORD_NAME).read_text())
    assert record["functions"] == 3 and record["sources"] == "sources-1"
    assert record["wall_s"] >= 0.0 and record["date"] == datetime.date.today().isoformat()

    (tmp_path / RECORD_NAME).write_text(json.dumps({**record, "cpu_s": 123.4, "wall_s": 130.2}))
    second = notices(tmp_path, "sources-1")
    # these sources compiled here before: what is missing now is a part, the record a bound
    assert second.text().startswith("flexure: compiling its engine for ")
    assert ("the parts this use needs that are not yet kept: at most about 123 s of CPU, the "
            f"whole engine's (130 s of wall time when measured here on {record['date']})"
            ) in second.text()
    assert "about 123 s of CPU (130 s" in notices(tmp_path, "sources-3").text()  # another version
    second.announce(io.StringIO())
    with second.unit():  # a smaller compilation of the same sources: the record stays
        pass
    assert json.loads((tmp_path / RECORD_NAME).read_text())["cpu_s"] == 123.4
    third = notices(tmp_path, "sources-2")
    third.announce(io.StringIO())
    with third.unit():  # other sources, but a partial compilation: the record stays
        pass
    assert json.loads((tmp_path / RECORD_NAME).read_text())["sources"] == "sources-1"
    with third.unit():  # half the recorded size: the record is theirs now
        pass
    record = json.loads((tmp_path / RECORD_NAME).read_text())
    assert record["sources"] == "sources-2" and record["functions"] == 2

    (tmp_path / RECORD_NAME).write_text("{not json")
    assert notices(tmp_path).record() is None
    assert "none here yet" in notices(tmp_path).text()


def test_a_cache_folder_that_cannot_be_written_keeps_no_record(tmp_path, notices):
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    notice = notices(not_a_folder)
    notice.announce(io.StringIO())
    with notice.unit():
        pass
    assert notice.functions == 1 and notice.record() is None


def test_a_writer_gets_the_notice_and_then_a_summary(tmp_path, notices):
    """Within `notices_to` (an FMU's slave building its model), the notice and the summary
    go to the writer, and a terminal gets no progress line."""
    notice, terminal, written = notices(tmp_path), Terminal(), []
    expected = notice.text()
    with notice.notices_to(written.append):
        notice.announce(terminal)
        with notice.unit():
            pass
    assert terminal.getvalue() == ""
    assert len(written) == 2 and written[0] == expected
    assert written[1].startswith("flexure: compiled 1 functions in ")
    assert written[1].endswith(f"of wall time); kept in {tmp_path}")
    with notice.notices_to(written.append):  # nothing compiled: nothing said
        pass
    assert len(written) == 2


def test_the_cli_announces_its_first_compilation_on_a_piped_stderr(tmp_path):
    """`flexure loop` with an empty cache, its stderr a pipe (not a terminal): the notice is
    its first line there, with the default estimate; the process is stopped once it is seen
    (the compilation itself takes a minute)."""
    cache = tmp_path / "cache"
    command = [str(Path(sys.executable).with_name("flexure")), "loop", "--no-plot"]
    env = {**os.environ, "FLEXURE_CACHE_DIR": str(cache)}
    with subprocess.Popen(command, env=env, cwd=tmp_path, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True) as child:
        try:
            first = children.lines_until(child, child.stderr, lambda line: True, 120)[0]
        finally:
            child.kill()
    assert first.startswith("flexure: compiling its engine for "), first
    assert f"about {DEFAULT_CPU_S:.0f} s of CPU" in first
    assert first.rstrip().endswith(f"kept in {cache}")
