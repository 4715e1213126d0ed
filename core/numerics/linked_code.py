"""A kernel's code is optimised once, in the C entry that links it, not also on its own.

numba compiles every kernel into a code library of its own and optimises that library's
module with LLVM's whole O3 pipeline, twice (a "cheap" O3 run to inline the reference-count
operations together, then the full one: `CPUCodeLibrary._optimize_final_module`). A C entry
(`jit.entry`) that calls kernels links their modules into its own and runs the same two
pipelines over the whole again, so every kernel's code is optimised once more there, with
its callers around it. The machine code that flexure runs is the entries': compiled code
calls other compiled code only through an entry's address, and Python calls only entries
(the engine's operations, the integrators' hooks, the loops). A kernel's own optimised
module is therefore only an input to the entries' optimisation, and optimising it first
bought nothing that the entry's pipeline does not do again.

`install` skips the module pipelines of the libraries compiled for flexure's kernels (and of
numba's own implementations that a kernel's compilation compiles on the way); their
per-function pass (numba's `_optimize_functions`) and their code generation stay. The first
`flexure loop` on an empty cache took 25.7 s of CPU against 29.9 s (three runs each,
alternating, medians; docs/benchmarks.md), and the entries' speed is unchanged
(`examples/benchmarks/engine_speed.py`). A kernel that Python calls directly (the tests
check kernels against plain formulas) runs code without LLVM's inlining across its callees:
the same numbers, somewhat slower. Code of anyone else's (a host's own numba functions) is
compiled as numba compiles it: only compilations inside a flexure kernel's are changed.
"""

import functools

# the compilations under way, innermost last: True for a flexure kernel's, False for an
# entry's (numba compiles a callee while it types its caller, so they nest)
_COMPILING = []


def compiling(is_kernel):
    """A context for a compilation of a flexure kernel (True) or C entry (False): the
    libraries it finalises are optimised as this module describes."""
    return _Compiling(is_kernel)


class _Compiling:
    def __init__(self, is_kernel):
        self.is_kernel = is_kernel

    def __enter__(self):
        _COMPILING.append(self.is_kernel)

    def __exit__(self, *exc):
        _COMPILING.pop()


def compiled_as_kernel(compile_method):
    """A dispatcher's `compile` (numba's, bound) wrapped so that what it compiles is a
    kernel's compilation (`compiling(True)`)."""

    @functools.wraps(compile_method)
    def compile(*args, **kwargs):
        with compiling(True):
            return compile_method(*args, **kwargs)

    return compile


@functools.cache
def install():
    """Make numba's code libraries skip their module pipelines inside a kernel's compilation
    (once per process; where numba has no `_optimize_final_module`, nothing changes)."""
    from numba.core import codegen

    library_class = codegen.CPUCodeLibrary
    original = getattr(library_class, "_optimize_final_module", None)
    if original is None:
        return

    def optimize_final_module(self):
        if _COMPILING and _COMPILING[-1]:
            return  # linked into an entry, and optimised there
        original(self)

    library_class._optimize_final_module = optimize_final_module
