"""One BLAS thread: flexure's matrices are small (tens to a few hundred rows).

Multi-threaded BLAS only costs on such matrices, and on a busy machine it costs a lot: an LU
of a 192 x 192 matrix took 0.5 ms with one OpenBLAS thread and 118 ms with two on this
project's 2-core machine while other processes ran (measured 2026-11-21). The limit is applied
when flexure.core is imported, also when numpy was imported before (as in an FMU host);
set FLEXURE_BLAS_THREADS to another number to override it.
"""

import os

from threadpoolctl import threadpool_limits

_limit = None


def limit_blas_threads():
    """Limit the BLAS thread pools of this process to FLEXURE_BLAS_THREADS (default 1)."""
    global _limit
    if _limit is None:
        threads = int(os.environ.get("FLEXURE_BLAS_THREADS", "1"))
        _limit = threadpool_limits(limits=threads, user_api="blas")
    return _limit
