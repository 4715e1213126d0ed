"""The compilation lock (flexure.core.numerics.compile_lock): processes that share a cache
compile each function once, the others wait, say so, and load it; a holder that dies or hangs
does not stop a waiter; no lock (and no error) where none can be had.

The processes are real: an entry point (the engine's `missing_entry`, the smallest) and a
kernel called from Python (`rotation_kernels.rates_row`) compiled by two processes on one
empty cache folder. A child stops inside its compilation, holding the lock, until the test
lets it go (`GATE`), so that the other is certain to arrive while it compiles."""

import json
import os
import signal
import subprocess
import sys
import threading
import time

import children
import pytest

from flexure.core.numerics import compile_lock

# A child process: compiles (or loads) the entry or kernel named by argv[1] and prints, as its
# last line, JSON with what it did. With argv[2] a path, it prints "compiling" at the start
# of its compilation (the lock held) and waits there until that path exists. With argv[3] a
# path, it starts on the entry or kernel only once that path exists (numba imported: the
# children start together, and the test says which goes first).
CHILD = r"""
import json, os, sys, time
from numba.core import event
from flexure.core.numerics import jit

what, gate, start = sys.argv[1], sys.argv[2], sys.argv[3]
compilations = []
while start and not os.path.exists(start):
    time.sleep(0.02)


def stop_at_the_gate():
    print("compiling", flush=True)
    while not os.path.exists(gate):
        time.sleep(0.02)


class Counted(event.Listener):
    def on_start(self, ev):
        compilations.append(ev.data["dispatcher"].py_func.__qualname__)
        if gate and len(compilations) == 1 and what == "kernel":
            stop_at_the_gate()

    def on_end(self, ev):
        pass


event.register("numba:compile", Counted())
if what == "entry":
    from flexure.core.engine import engine

    if gate:
        announce = jit.announce_compilation

        def announce_at_the_gate(stream=None):
            stop_at_the_gate()
            announce(stream)

        jit.announce_compilation = announce_at_the_gate
    entry = engine.missing_entry
    result = entry.ctypes(0, None, 0.0, None, None, None, 0.0)
    expected = int(engine.ed.NOT_CONNECTED)
    compiled = entry._compiled  # None: loaded as object code, without numba
    compiled_here = compiled is not None and compiled._cache_hits == 0
else:
    from flexure.core.numerics.rotation_kernels import rates_row

    result = rates_row.py_func(0.5, 0.5, -0.5, 0.5, 1)
    expected = list(result)
    result = list(rates_row(0.5, 0.5, -0.5, 0.5, 1))
    compiled_here = bool(compilations)
print(json.dumps({"compiled_here": compiled_here, "compilations": len(compilations),
                  "result": result, "expected": expected}), flush=True)
"""


def _child(what, cache, gate="", start=""):
    env = {**os.environ, "FLEXURE_CACHE_DIR": str(cache), "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen([sys.executable, "-c", CHILD, what, str(gate), str(start)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _line_with(child, stream, text, timeout_s=300):
    """The first line of `child`'s `stream` that contains `text` (`children.lines_until`: a
    child that never says it fails the test after `timeout_s`)."""
    return children.lines_until(child, stream, lambda line: text in line, timeout_s)[-1]


def _report(process, timeout_s=300):
    out, err = children.finish(process, timeout_s)
    assert process.returncode == 0, err[-3000:]
    return json.loads(out.strip().splitlines()[-1]), err


@pytest.mark.parametrize("what", ["entry", pytest.param("kernel", marks=pytest.mark.slow)])
def test_a_second_process_waits_for_the_first_and_loads_what_it_compiled(tmp_path, what):
    cache, gate, start = tmp_path / "cache", tmp_path / "go", tmp_path / "start"
    first, second = _child(what, cache, gate), _child(what, cache, start=start)
    _line_with(first, first.stdout, "compiling")  # the first holds the lock, inside numba
    start.touch()
    waiting = _line_with(second, second.stderr, "flexure: waiting for")
    assert f"waiting for process {first.pid}, which compiles" in waiting
    gate.touch()
    first_did, first_said = _report(first)
    second_did, _ = _report(second)
    assert "waiting" not in first_said  # alone at the lock: it did not wait
    assert first_did["compiled_here"] and not second_did["compiled_here"]
    assert second_did["compilations"] == 0
    assert first_did["result"] == first_did["expected"]
    assert second_did["result"] == first_did["result"]  # the same machine code, loaded
    if what == "entry":  # in numba's cache and no object code: loaded by numba, no lock
        for path in [*cache.rglob("*.fxo"), *cache.rglob("*.lock")]:
            path.unlink()
        third_did, _ = _report(_child(what, cache))
        assert not third_did["compiled_here"] and third_did["result"] == first_did["result"]
        assert not list(cache.rglob("*.lock"))


@pytest.mark.slow  # 4 s, two processes; the lock's release by a killed holder stays below
def test_a_holder_killed_mid_compilation_leaves_the_waiter_to_compile(tmp_path):
    cache, never, start = tmp_path / "cache", tmp_path / "never", tmp_path / "start"
    holder, waiter = _child("entry", cache, never), _child("entry", cache, start=start)
    _line_with(holder, holder.stdout, "compiling")
    start.touch()
    _line_with(waiter, waiter.stderr, "flexure: waiting for")
    holder.send_signal(signal.SIGKILL)
    holder.wait(timeout=60)
    did, err = _report(waiter)
    assert did["compiled_here"] and did["result"] == did["expected"]
    assert "flexure: compiling its engine" in err


# -- the lock itself -----------------------------------------------------------------------

# holds the lock on argv[1] (prints "held" with its pid) until argv[2] exists
HOLDER = r"""
import os, sys, time
from flexure.core.numerics import compile_lock
with compile_lock.held(sys.argv[1]) as state:
    print(state, os.getpid(), flush=True)
    while not os.path.exists(sys.argv[2]):
        time.sleep(0.02)
"""


def _holder(path, release):
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(path), str(release)],
                              stdout=subprocess.PIPE, text=True)
    assert _line_with(holder, holder.stdout, "held", 60).split() == ["held", str(holder.pid)]
    return holder


def test_the_lock_is_taken_and_the_holder_named_in_its_file(tmp_path):
    path = tmp_path / "folder" / "f.lock"
    with compile_lock.held(str(path)) as state:
        assert state == "held"
        assert path.read_text() == str(os.getpid())
        with compile_lock.held(str(tmp_path / "other.lock")) as inner:
            assert inner == "nested"  # one lock per thread at most: no deadlock
    with compile_lock.held(str(path)) as again:
        assert again == "held"  # released at the end of the block


def test_a_waiter_gets_the_lock_when_its_holder_lets_go(tmp_path):
    path, release = tmp_path / "f.lock", tmp_path / "release"
    holder = _holder(path, release)
    told = []

    def on_wait(pid):
        told.append(pid)
        threading.Timer(0.3, release.touch).start()

    start = time.monotonic()
    with compile_lock.held(str(path), on_wait=on_wait) as state:
        assert state == "held"
        assert time.monotonic() - start >= 0.3
    assert told == [holder.pid]
    assert holder.wait(timeout=60) == 0


def test_a_holder_killed_releases_the_lock(tmp_path):
    path = tmp_path / "f.lock"
    holder = _holder(path, tmp_path / "never")
    with compile_lock.held(str(path), on_wait=lambda pid: os.kill(pid, signal.SIGKILL)) as state:
        assert state == "held"
    assert holder.wait(timeout=60) == -signal.SIGKILL


def test_a_hung_holder_is_waited_for_at_most_the_limit(tmp_path):
    path, release = tmp_path / "f.lock", tmp_path / "release"
    holder = _holder(path, release)
    start = time.monotonic()
    try:
        with compile_lock.held(str(path), limit_s=0.4) as state:
            assert state == "unlocked"
        assert 0.4 <= time.monotonic() - start < 30
    finally:
        release.touch()
        holder.wait(timeout=60)


def test_no_lock_and_no_error_where_none_can_be_had(tmp_path, monkeypatch):
    a_file = tmp_path / "a-file"
    a_file.write_text("")
    with compile_lock.held(str(a_file / "f.lock")) as state:  # its folder cannot be made
        assert state == "unlocked"
    with compile_lock.held(None) as state:  # no cache folder
        assert state == "unlocked"

    def no_locks_here(*args):
        raise OSError(37, "No locks available")  # ENOLCK: a network file system

    monkeypatch.setattr(compile_lock.fcntl, "flock", no_locks_here)
    with compile_lock.held(str(tmp_path / "f.lock")) as state:
        assert state == "unlocked"
    monkeypatch.setattr(compile_lock, "fcntl", None)
    monkeypatch.setattr(compile_lock, "msvcrt", None)
    with compile_lock.held(str(tmp_path / "g.lock")) as state:  # a platform without locks
        assert state == "unlocked"


def test_the_holder_is_unknown_when_its_file_says_nothing_readable(tmp_path):
    path, release = tmp_path / "f.lock", tmp_path / "release"
    holder = _holder(path, release)
    path.write_text("not a pid")
    told = []

    def on_wait(pid):
        told.append(pid)
        release.touch()

    with compile_lock.held(str(path), on_wait=on_wait) as state:
        assert state == "held"
    assert told == [None]
    holder.wait(timeout=60)


def test_the_waiting_notice_is_said_once_and_names_the_holder(tmp_path):
    from flexure.core.numerics.compile_notice import CompileNotice

    notice, written = CompileNotice(str(tmp_path)), []
    with notice.notices_to(written.append):
        notice.waiting(1234)
        notice.waiting(1234)
    notice.waiting(None)
    assert written == [f"flexure: waiting for process 1234, which compiles the same code of "
                       f"the engine into {tmp_path}; this process loads it from there when it "
                       f"is done"]
