"""The tests' child processes (children.py): a hung child is killed at its time limit with
what it started, and the test fails then instead of hanging."""

import json
import subprocess
import sys
import time
from pathlib import Path

import children
import pytest


def running(pid):
    """Neither gone nor dead and not yet reaped (a zombie)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def gone_soon(pid, within=10.0):
    """SIGKILL was sent: the process ends when it is next scheduled (s: the longest wait)."""
    deadline = time.monotonic() + within
    while running(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    return not running(pid)


def test_a_hung_child_and_its_own_child_are_killed_at_the_limit(tmp_path):
    pids = tmp_path / "pids"
    start = time.monotonic()
    with pytest.raises(subprocess.TimeoutExpired):
        children.run(["sh", "-c", f"sleep 300 & echo $$ $! > {pids}; wait"],
                     capture_output=True, timeout=1.0)
    assert time.monotonic() - start < 30
    assert all(gone_soon(int(pid)) for pid in pids.read_text().split())


def test_a_started_child_that_hangs_is_killed_at_the_limit():
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(300)"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    with pytest.raises(subprocess.TimeoutExpired):
        children.finish(child, 1.0)
    assert child.returncode is not None and not running(child.pid)


def test_a_child_runs_as_subprocess_run_would():
    done = children.run([sys.executable, "-c", "import sys; print(sys.stdin.read()[::-1]); "
                         "sys.exit(3)"], input="abc", capture_output=True, text=True)
    assert (done.returncode, done.stdout, done.stderr) == (3, "cba\n", "")
    with pytest.raises(subprocess.CalledProcessError):
        children.run([sys.executable, "-c", "raise SystemExit(1)"], check=True)


def test_what_a_child_says_is_read_up_to_the_line_waited_for():
    child = subprocess.Popen([sys.executable, "-uc", "print('a'); print('b'); print('c'); "
                              "import time; time.sleep(300)"],
                             stdout=subprocess.PIPE, text=True, start_new_session=True)
    try:
        assert children.lines_until(child, child.stdout, lambda line: "b" in line, 60) == \
            ["a\n", "b\n"]
        assert child.poll() is None  # it goes on
    finally:
        children.kill_group(child)
        child.wait()


@pytest.mark.parametrize("script, limit", [
    ("print('starting', flush=True); import time; time.sleep(300)", 1.0),  # hangs
    ("print('starting'); print('not json')", 60.0),  # ends without it, or unreadable
])
def test_a_child_that_never_says_it_fails_the_test_at_the_limit_and_is_killed(script, limit):
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True,
                             start_new_session=True)
    start = time.monotonic()
    with pytest.raises(AssertionError, match=r"did not write the line waited for within "
                                             r"[0-9.]+ s; it wrote:\nstarting\n"):
        children.lines_until(child, child.stdout,
                             lambda line: json.loads(line)["ready"], limit)
    assert time.monotonic() - start < 30
    assert child.returncode is not None and not running(child.pid)
