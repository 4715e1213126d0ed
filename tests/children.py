"""The tests' child processes, each with a time limit: a child still running at its limit is
killed with everything it started (its process group, made for it), so that a hung child
fails its test, instead of hanging the run until pytest-timeout, and leaves nothing behind.
subprocess.run's own timeout kills the child only: a grandchild (a command that runs others,
a shell) would go on, holding the pipes it inherited open. A test that waits for a child to say
something (`lines_until`) waits with a limit too: a bare readline() on a child that never
writes would wait for ever."""

import os
import signal
import subprocess
import threading

DEFAULT_TIMEOUT = 300.0  # s: a child that compiles the engine takes about 30 s of CPU


def run(args, *, timeout=DEFAULT_TIMEOUT, check=False, capture_output=False, input=None,
        **options):
    """subprocess.run(args, ...) (the same keywords, `check` and `capture_output` too), in a
    process group of its own; after `timeout` s (or any exception while waiting) the group
    is killed and the exception (subprocess.TimeoutExpired) raised."""
    if capture_output:
        options["stdout"] = options["stderr"] = subprocess.PIPE
    with subprocess.Popen(args, start_new_session=True,
                          stdin=subprocess.PIPE if input is not None else None,
                          **options) as child:
        try:
            out, err = child.communicate(input, timeout=timeout)
        except BaseException:
            kill_group(child)
            raise
    if check and child.returncode:
        raise subprocess.CalledProcessError(child.returncode, args, out, err)
    return subprocess.CompletedProcess(args, child.returncode, out, err)


def finish(child, timeout=DEFAULT_TIMEOUT):
    """(stdout, stderr) of a started child (a subprocess.Popen) once it ends; after `timeout`
    s (or any exception while waiting) it is killed, with its process group if it leads
    one, and the exception (subprocess.TimeoutExpired) raised."""
    try:
        return child.communicate(timeout=timeout)
    except BaseException:
        kill_group(child)
        child.communicate()
        raise


def kill_group(child):
    """Kill the child, and its process group if it leads one (start_new_session=True), if it
    is still there."""
    try:
        if os.getpgid(child.pid) == child.pid:
            os.killpg(child.pid, signal.SIGKILL)
        else:
            child.kill()
    except ProcessLookupError:
        pass


def lines_until(child, stream, found, timeout=DEFAULT_TIMEOUT):
    """The lines that `child` writes to `stream` (its stdout or stderr, a text pipe), up to
    and with the first for which found(line) is true; the child goes on running.

    The lines are read in a thread of their own, so that a child that never writes such a
    line (it hangs, or ends; a line on which `found` raises is not that line) fails the
    test after at most `timeout` s: the child is then killed, with its process group if it
    leads one, and an AssertionError quotes the last 3000 characters it wrote there."""
    lines, done = [], threading.Event()

    def read():
        try:
            for line in stream:
                lines.append(line)
                if _holds(found, line):
                    return
        finally:
            done.set()

    threading.Thread(target=read, daemon=True).start()
    done.wait(timeout)
    if lines and _holds(found, lines[-1]):
        return lines
    kill_group(child)
    child.wait()
    said = "".join(lines)[-3000:]
    raise AssertionError(f"the child (pid {child.pid}) did not write the line waited for "
                         f"within {timeout:g} s; it wrote:\n{said}")


def _holds(found, line):
    try:
        return bool(found(line))
    except Exception:  # noqa: BLE001 - a line `found` cannot read is not the one
        return False
