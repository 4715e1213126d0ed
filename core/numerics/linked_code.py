"""A kernel is compiled for linking only: into the C entries that call it, as LLVM IR.

The machine code that flexure runs is the entries' (`jit.entry`): compiled code calls other
compiled code only through an entry's address, and Python calls only entries (the engine's
operations, the integrators' hooks, the loops). An entry that calls kernels links their
modules into its own, optimises the whole with LLVM's O3 pipelines and generates its machine
code. numba, compiling each kernel as a function Python may call, does much more for every
kernel, all of it discarded: a CPython wrapper (boxing and unboxing every argument, the
engine's 89-slot data tuple among them), the O3 module pipelines run twice over the kernel's
own module, and its machine code, generated at once (numba makes the Python-callable
function from its address). On an empty cache the first `flexure loop` spent about 5 s of
its 33 s of CPU there (docs/benchmarks.md).

So a kernel that compiled code calls is compiled for linking only (`install`): numba's
`no_cpython_wrapper`, the per-function passes (numba's `_optimize_functions`), and nothing
after them:

- no module pipeline: the entry that links the module optimises it, with its callers
  around it (`_optimize_final_module` is skipped for a library finalised inside a kernel's
  compilation, the libraries of numba's own implementations compiled on the way included);
- no machine code: the library never joins numba's execution engine (`_finalize_final_module`
  keeps only its checks), and the function that numba would make from the wrapper's address
  is a Python function that refuses to be called (`refusing_python_calls`);
- cached as its module for linking (LLVM bitcode, kind `LINKING_ONLY`), loaded as such.

Python calls a kernel (the tests check kernels against plain formulas) through a second
dispatcher of the same function, compiled as numba compiles it, with a cache folder of its
own (`jit.Kernel.python_dispatcher`). Code of anyone else's (a host's own numba functions) is
compiled as numba compiles it: only compilations inside a flexure kernel's are changed, and
where numba lacks a method this module replaces, nothing is (`install` returns False).
"""

import functools
import types

# the compilations under way, innermost last: a flexure kernel's Python function (or True),
# False for an entry's (numba compiles a callee while it types its caller, so they nest)
COMPILING = []

LINKING_ONLY = "flexure-linking-only"  # the cache's serialisation kind of such a library
MARK = "_flexure_linking_only"  # the attribute that marks a library compiled so


def compiling(kernel):
    """A context for a compilation of a flexure kernel (its Python function, or True) or of
    a C entry (False): the libraries it finalises are optimised as this module describes."""
    return _Compiling(kernel)


class _Compiling:
    def __init__(self, kernel):
        self.kernel = kernel

    def __enter__(self):
        COMPILING.append(self.kernel)

    def __exit__(self, *exc):
        COMPILING.pop()


def _inside_kernel():
    return bool(COMPILING) and bool(COMPILING[-1])


def _is_the_kernel(fndesc):
    """Whether `fndesc` is the function of the kernel whose compilation is under way (not
    one of numba's own implementations that its typing compiles on the way)."""
    kernel = COMPILING[-1] if COMPILING else None
    return (callable(kernel) and fndesc.qualname == kernel.__qualname__
            and fndesc.modname == kernel.__module__)


def compiled_as_kernel(compile_method, function):
    """A kernel's dispatcher's `compile` (numba's, bound) wrapped so that what it compiles
    is the compilation of the kernel `function` (`compiling(function)`)."""

    @functools.wraps(compile_method)
    def compile(*args, **kwargs):
        with compiling(function):
            return compile_method(*args, **kwargs)

    return compile


def refusing_python_calls(dispatcher):
    """`dispatcher` (a kernel's, compiled for linking only) with its compiled versions kept
    out of numba's table of Python-callable functions: that table takes only functions
    made from machine code, and there is none. A Python call of it raises TypeError
    (`jit.Kernel.__call__` calls the Python-callable dispatcher instead)."""
    dispatcher._insert = lambda *args, **kwargs: None
    return dispatcher


def python_callable(function):
    """A copy of a kernel's Python function (the same code, globals, defaults and closure),
    marked (`is_python_callable`) so that its compiled code, which Python calls, is cached
    in a folder of its own (`jit`), apart from the same function's linking-only code."""
    copy = types.FunctionType(function.__code__, function.__globals__, function.__name__,
                              function.__defaults__, function.__closure__)
    copy.__kwdefaults__, copy.__qualname__ = function.__kwdefaults__, function.__qualname__
    copy.__module__, copy.__doc__ = function.__module__, function.__doc__
    copy._flexure_python_calls = True
    return copy


def is_python_callable(function):
    """Whether `function` is a `python_callable` copy."""
    return getattr(function, "_flexure_python_calls", False)


def _python_calls_refused(qualname):
    def refuse(*args, **kwargs):
        raise TypeError(f"{qualname}: compiled for linking into flexure's C entries only; "
                        f"call the kernel (jit.Kernel) from Python")
    return refuse


def has_function(library, name):
    try:
        library._final_module.get_function(name)
    except NameError:
        return False
    return True


@functools.cache
def install():
    """Make numba compile the libraries of flexure's kernels for linking only (once per
    process). Returns whether it could: False where numba lacks a method this replaces, and
    then numba compiles every kernel as it does."""
    from llvmlite import binding
    from numba.core import codegen, cpu

    library_class, context_class = codegen.CPUCodeLibrary, cpu.CPUContext
    names = ("_optimize_final_module", "_finalize_final_module", "_finalize_dynamic_globals",
             "_verify_declare_only_symbols", "serialize_using_object_code", "_unserialize",
             "_get_module_for_linking")
    if not (all(hasattr(library_class, name) for name in names)
            and hasattr(context_class, "get_executable")
            and hasattr(codegen.JITCPUCodegen, "set_env")):
        return False
    optimize, finalize = library_class._optimize_final_module, library_class._finalize_final_module
    serialize = library_class.serialize_using_object_code
    unserialize = library_class.__dict__["_unserialize"].__func__
    executable, set_env = context_class.get_executable, codegen.JITCPUCodegen.set_env

    def optimize_final_module(self):
        if getattr(self, MARK, False) or _inside_kernel():
            return  # linked into an entry, and optimised there
        optimize(self)

    def finalize_final_module(self):
        if not getattr(self, MARK, False):
            return finalize(self)
        self._finalize_dynamic_globals()  # numba's checks, without the execution engine
        self._verify_declare_only_symbols()
        self._finalized = True

    def get_executable(self, library, fndesc, env):
        linking_only = getattr(library, MARK, False) or (
            _is_the_kernel(fndesc)
            and not has_function(library, fndesc.llvm_cpython_wrapper_name))
        if not linking_only:
            return executable(self, library, fndesc, env)
        setattr(library, MARK, True)
        return _python_calls_refused(fndesc.qualname)

    def serialize_using_object_code(self):
        if not getattr(self, MARK, False):
            return serialize(self)
        return (self.name, LINKING_ONLY, self._get_module_for_linking().as_bitcode())

    def _unserialize(cls, codegen_, state):
        name, kind, data = state
        if kind != LINKING_ONLY:
            return unserialize(cls, codegen_, state)
        library = codegen_.create_library(name)
        setattr(library, MARK, True)
        library._final_module = binding.parse_bitcode(data)
        library._finalize_final_module()
        return library

    def set_environment(self, env_name, env):
        # a linking-only library's environment is in no module of the engine: nothing to set
        if self._engine.get_global_value_address(env_name):
            set_env(self, env_name, env)

    library_class._optimize_final_module = optimize_final_module
    library_class._finalize_final_module = finalize_final_module
    library_class.serialize_using_object_code = serialize_using_object_code
    library_class._unserialize = classmethod(_unserialize)
    context_class.get_executable = get_executable
    codegen.JITCPUCodegen.set_env = set_environment
    return True
