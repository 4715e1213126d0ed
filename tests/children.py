"""The tests' child processes, each with a time limit: a child still running at its limit is
killed with everything it started (its process group, made for it), so that a hung child
fails its test, instead of hanging the run until pytest-timeout, and leaves nothing behind.
subprocess.run's own timeout kills the child only: a grandchild (a command that runs others,
a shell) would go on, holding the pipes it inherited open."""

import os
import signal
import subprocess

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
