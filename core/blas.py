"""One BLAS thread: flexure's matrices are small (tens to a few hundred rows).

Multi-threaded BLAS only costs on such matrices, and on a busy machine it costs a lot: an LU
of a 192 x 192 matrix took 0.5 ms with one OpenBLAS thread and 118 ms with two on this
project's 2-core machine while other processes ran (measured 2026-11-21). The limit is applied
when flexure.core is imported; set FLEXURE_BLAS_THREADS to another number to override it.

`import flexure.core` loads no numpy (its names are imported on first use), so the BLAS
libraries are mostly loaded after the limit is set: numpy's and scipy's OpenBLAS, and
scikit-sundae's, each its own library. OpenBLAS reads OPENBLAS_NUM_THREADS when it is loaded
(as MKL and BLIS read theirs), so the limit sets these variables of the process (child
processes inherit them); the libraries already loaded (numpy imported before flexure, as in
an FMU host) are limited through threadpoolctl.
"""

import os
import sys

THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")

_limit = None


def limit_blas_threads():
    """Limit the BLAS thread pools of this process to FLEXURE_BLAS_THREADS (default 1)."""
    global _limit
    if _limit is None:
        threads = int(os.environ.get("FLEXURE_BLAS_THREADS", "1"))
        for variable in THREAD_VARIABLES:  # for the BLAS libraries loaded from now on
            os.environ[variable] = str(threads)
        _limit = True
        if "numpy" in sys.modules:  # every Python package with a BLAS imports numpy first
            from threadpoolctl import threadpool_limits

            _limit = threadpool_limits(limits=threads, user_api="blas")
    return _limit
