"""Numerical building blocks every layer uses: numba kernels and their cache, BLAS threads,
rotations (Euler parameters), dense and banded LU, C calls."""
