"""BLAS threads limited around flexure's own numerical calls, not for the whole process.

    with blas_threads():            # FLEXURE_BLAS_THREADS threads, default 1
        np.linalg.solve(K, Q)

    @blas_threads()                 # the same around every call of a function
    def static_equilibrium(model, ...): ...

Why one thread: flexure's matrices are small (tens to a few hundred rows). Multi-threaded
BLAS only costs on such matrices, and on a busy machine it costs a lot: an LU of a 192 x 192
matrix took 0.5 ms with one OpenBLAS thread and 118 ms with two on a 2-core machine while
other processes ran. Set FLEXURE_BLAS_THREADS to another number to change the limit.

Why a context and not a process-wide limit: flexure runs inside other programs (an FMU host, a
notebook, a controller design script), whose own linear algebra may want every core. So
importing flexure changes nothing (no environment variable, no thread pool); the public analyses
(statics, linearisation, modes and buckling, state space, stresses along states, the
exact-constraint check, `default_atol`, the mechanical energy, the work-precision study) enter
the context while they run and leave the host's limits as they were. The compiled engine
(`flexure.core.engine.engine`) and the SUNDIALS and ESDIRK integrators use no BLAS: building a
Simulator with the default atol enters the context once (`default_atol`), stepping it (an FMU's
doStep) not at all; an FMU with its von Mises output enters it once per doStep, through
`stresses_along`.

How: threadpoolctl sets the thread count of every BLAS library loaded in the process (numpy
and scipy each bring their own OpenBLAS) on entry and restores it on exit. Only the outermost
context does so (a depth counter): a nested one costs a lock and a counter, about 1 us.
Finding the libraries costs about 0.2 ms, so they are looked up again only when a module was
imported since the last look (a BLAS library is loaded by an extension module); an outermost
entry and exit then costs about 10 us, against 30 us for the cheapest wrapped call (the modes
of a given linear model) and 0.2 to 0.3 ms for `stresses_along` of one state through the
engine (0.7 to 2 ms through the numpy reference, up to 12 ms there with the host's two
threads on the loaded 2-core machine). BLAS thread counts belong to
the process: while a flexure call runs, another thread's BLAS calls get its limit too. A
library loaded during a call (its first import) is limited from the next call on.
"""

import os
import sys
import threading
from contextlib import ContextDecorator

VARIABLE = "FLEXURE_BLAS_THREADS"

_lock = threading.Lock()
_depth = 0  # how many contexts are open, in all threads
_limiter = None  # the outermost context's threadpoolctl limiter
_controller = None  # threadpoolctl's view of the loaded libraries
_modules_seen = -1  # len(sys.modules) when _controller looked them up


def default_threads():
    """The BLAS thread count of flexure's calls: FLEXURE_BLAS_THREADS, default 1."""
    text = os.environ.get(VARIABLE, "1")
    try:
        threads = int(text)
    except ValueError:
        threads = 0
    if threads < 1:
        raise ValueError(f"{VARIABLE}: expected a positive integer, got {text!r}")
    return threads


class _BlasThreads(ContextDecorator):
    def __init__(self, threads):
        self.threads = threads

    def __enter__(self):
        global _depth, _limiter
        with _lock:
            if _depth == 0:
                threads = default_threads() if self.threads is None else self.threads
                _limiter = blas_libraries().limit(limits=threads, user_api="blas")
            _depth += 1
        return self

    def __exit__(self, *exc):
        global _depth, _limiter
        with _lock:
            _depth -= 1
            if _depth == 0:
                limiter, _limiter = _limiter, None
                limiter.restore_original_limits()
        return False


def blas_threads(threads: int | None = None) -> ContextDecorator:
    """A context (and decorator) that limits the BLAS thread pools while it is open and
    restores the previous limits when it closes.

    Nested contexts are cheap and change nothing: the outermost one sets the limit.

    Parameters
    ----------
    threads : int, optional
        The BLAS thread count, >= 1 (default `default_threads()`: FLEXURE_BLAS_THREADS, or 1).

    Returns
    -------
    contextlib.ContextDecorator
        Use it in a `with` statement or as a function decorator.

    Raises
    ------
    ValueError
        `threads` is not a positive integer; on entry, FLEXURE_BLAS_THREADS is not one.
    """
    if threads is not None and (not isinstance(threads, int) or threads < 1):
        raise ValueError(f"threads: expected a positive integer or None, got {threads!r}")
    return _BlasThreads(threads)


def blas_libraries():
    """threadpoolctl's controller of the loaded libraries, looked up again after imports."""
    global _controller, _modules_seen
    if _controller is None or len(sys.modules) != _modules_seen:
        from threadpoolctl import ThreadpoolController

        replaced, _controller = _controller, ThreadpoolController()
        _modules_seen = len(sys.modules)
        # each library's controller points back at its parent: without the cycle, reference
        # counting frees the replaced one (an FMU host may run with the cyclic collector off)
        for library in getattr(replaced, "lib_controllers", ()):
            library.parent = None
    return _controller
