"""One process compiles a function of the cache at a time; the others wait and load it.

Several processes that start together on an empty cache (pytest-xdist's workers, a Dask
sweep's, the FMU instances of one co-simulation, two terminals) would each compile the same
entry point for tens of seconds of CPU, since nothing tells the second that the first is at
it. `compiling_alone(function)` holds an inter-process lock on a file beside the function's
cache index (`lock_path`, `held`): the process that gets it compiles and writes the cache, the
others wait for it and then look in the cache again, where they find the code and load it.
`jit` compiles an entry point, and a kernel that Python calls, so.

- A lock per function, not one for the whole cache folder: two processes compiling different
  entries compile side by side (a 2-core machine's workers need both cores).
- No deadlock: a thread holds at most one of these locks. A compilation inside one that holds
  a lock (numba compiles a kernel's callees while it types it) takes none, so no process ever
  waits for a lock while holding another.
- A holder that dies releases its lock (the kernel releases an `flock` with the process's
  last descriptor of the file): the waiter then gets it, finds nothing in the cache and
  compiles itself.
- A holder that hangs is waited for at most `WAIT_LIMIT_S`; the waiter then compiles without
  the lock (numba writes its cache files whole, so two writers do not corrupt it).
- Where no lock can be had (a read-only cache folder, a file system without locks, a
  platform with neither `fcntl` nor `msvcrt`) the compilation goes ahead without one, as
  before: the lock saves CPU, it is never needed for a correct result.

The holder's process id is written into the lock file, so that the waiter's notice
(`on_wait`, from `jit`: `compile_notice`) can name whom it waits for.
"""

import contextlib
import functools
import os
import threading
import time

try:
    import fcntl
except ImportError:  # Windows
    fcntl = None
try:
    import msvcrt
except ImportError:  # POSIX
    msvcrt = None

WAIT_LIMIT_S = 900.0  # a whole engine compiles in 30 to 60 s of CPU; a loaded machine: minutes
POLL_S = 0.05  # how often a waiter tries the lock again, s

_held = threading.local()  # .path: the lock this thread holds (None: none)


def lock_path(function):
    """The lock file of the compilation of `function` (a kernel's or entry's Python function
    of flexure's core): beside its cache index; None outside the cache."""
    from . import jit

    index = jit.cache_index_path(function)
    return None if index is None else f"{index[:-len('.nbi')]}.lock"


def compiling_alone(function):
    """A context in which this process alone, of all that share the cache, compiles
    `function`: another process compiling it is waited for, with a notice
    (`CompileNotice.waiting`), and the caller then finds its code in the cache."""
    from . import jit

    return held(lock_path(function), on_wait=jit.compilation_notice().waiting)


def compiled_alone(compile_method, function):
    """A numba dispatcher's `compile` (bound; it loads from the cache before it compiles)
    run inside `compiling_alone(function)`."""

    @functools.wraps(compile_method)
    def compile(*args, **kwargs):
        with compiling_alone(function):
            return compile_method(*args, **kwargs)

    return compile


@contextlib.contextmanager
def held(path, on_wait=None, limit_s=None):
    """A context holding the inter-process lock on the file `path` (created if missing).

    Parameters
    ----------
    path : str or None
        The lock file. None, or a file that cannot be opened or locked: no lock.
    on_wait : callable, optional
        on_wait(holder) is called once when the lock is busy, before waiting: `holder` is the
        process id (int) written in the file by the process holding it, or None if unknown.
    limit_s : float, optional
        The longest wait, s (default `WAIT_LIMIT_S`); past it the context is entered without
        the lock.

    Yields
    ------
    str
        "held" (this thread took the lock), "nested" (this thread holds a lock already: none
        is taken), "unlocked" (no lock could be had, or the wait ran out).
    """
    if getattr(_held, "path", None) is not None:
        yield "nested"
        return
    handle = _open(path)
    if handle is None:
        yield "unlocked"
        return
    try:
        if not _acquire(handle, on_wait, WAIT_LIMIT_S if limit_s is None else limit_s):
            yield "unlocked"
            return
        _write_holder(handle)
        _held.path = path
        try:
            yield "held"
        finally:
            _held.path = None
            _release(handle)
    finally:
        os.close(handle)


def _open(path):
    """A descriptor of the lock file (its folder created), or None when it cannot be opened
    or this platform has no file locks."""
    if path is None or (fcntl is None and msvcrt is None):
        return None
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        return os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError:  # a read-only folder: no lock
        return None


def _try_lock(handle):
    """Take the lock without waiting: True (taken), False (busy), None (locks unavailable
    on this file: a network file system without them, for one)."""
    try:
        if fcntl is not None:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        else:
            os.lseek(handle, 0, os.SEEK_SET)
            msvcrt.locking(handle, msvcrt.LK_NBLCK, 1)
        return True
    except BlockingIOError:
        return False
    except PermissionError:  # msvcrt's busy; fcntl raises BlockingIOError
        return False if fcntl is None else None
    except OSError:
        return None


def _acquire(handle, on_wait, limit_s):
    """Take the lock, waiting for its holder at most `limit_s` seconds. Returns whether it
    was taken."""
    taken = _try_lock(handle)
    if taken is None:
        return False
    if taken:
        return True
    if on_wait is not None:
        on_wait(_read_holder(handle))
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        time.sleep(POLL_S)
        taken = _try_lock(handle)
        if taken is None:
            return False
        if taken:
            return True
    return False


def _release(handle):
    try:
        if fcntl is not None:
            fcntl.flock(handle, fcntl.LOCK_UN)
        else:
            os.lseek(handle, 0, os.SEEK_SET)
            msvcrt.locking(handle, msvcrt.LK_UNLCK, 1)
    except OSError:  # closing the descriptor releases it anyway
        pass


def _write_holder(handle):
    """Write this process's id into the lock file (for a waiter's notice)."""
    try:
        os.ftruncate(handle, 0)
        os.pwrite(handle, str(os.getpid()).encode(), 0)
    except (OSError, AttributeError):  # not needed for the lock itself
        pass


def _read_holder(handle):
    """The process id written into the lock file by its holder, or None."""
    try:
        return int(os.pread(handle, 32, 0).decode().strip())
    except (OSError, ValueError, AttributeError):
        return None
