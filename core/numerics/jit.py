"""`kernel`: numba's njit as flexure's compiled code uses it, with an on-disk cache that every
copy of flexure finds again.

Every kernel is compiled with cache=True and error_model="numpy" (a division by zero gives
inf or nan, which the engine checks, instead of raising inside code that a C callback runs).

Where the cache lives. numba keeps its cache next to the source file and stamps it with the
file's modification time; an FMU unpacks its copy of flexure into a new temporary folder at
every instantiation, so numba's own cache would be missed every time and each instance would
compile for tens of seconds. Flexure's locator instead keys the cache by the package's name
(an FMU bundles flexure under a content-hashed name) and by a hash of the package's sources:
any copy with the same sources finds the same compiled code, wherever it is unpacked, and a
change to any source file (a kernel's callee included, which numba's per-file stamp misses)
starts a fresh cache. The folder is $FLEXURE_CACHE_DIR, else $NUMBA_CACHE_DIR, else the
user's cache folder (~/.cache/flexure), else a folder in the temporary directory when that is
not writable. `portable_cache` exports a copy's cache for another machine and installs it
there (an FMU carries its engine so).

The first compilation. When an entry point is not in the cache, the engine is about to
compile for tens of seconds: `announce_compilation` says so once per process, with an estimate
measured on this machine and a progress line on a terminal (`compile_notice`). Processes
that share the cache compile each function once: the first takes its lock and compiles, the
others wait (saying so) and load what it wrote (`compile_lock`).

numba itself is imported when the first kernel is compiled or called, not when a module
declares one: importing it takes about 0.2 s of CPU, and the analyses (statics, modes) run in
numpy and never call a kernel (`flexure analyze` does not import numba).
"""

import contextlib
import functools
import hashlib
import inspect
import os
import sys
import tempfile

from . import compile_flags, compile_lock, inline_copy, linked_code
from .compile_notice import CompileNotice

_CORE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # core/, above numerics/
_PACKAGE_ROOT = os.path.dirname(_CORE)  # holds core/


@functools.cache
def sources_hash():
    """SHA-256 (hex) of every Python source of this copy's core package."""
    digest = hashlib.sha256()
    for folder, _, files in sorted(os.walk(_CORE)):
        for name in sorted(files):
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                digest.update(os.path.relpath(path, _CORE).encode())
                with open(path, "rb") as source:
                    digest.update(source.read())
    return digest.hexdigest()


def package_name():
    """The name this copy of flexure is imported under ("flexure", or an FMU's own name)."""
    return __name__.rsplit(".", 3)[0]  # <package>.core.numerics.jit


@functools.cache
def cache_root():
    """The folder of flexure's compiled-code cache (created if missing), an absolute path.

    A relative $FLEXURE_CACHE_DIR is taken against this process's working folder and written
    back to the environment absolute: a child process (an FMU host started from here, in its
    own working folder) then finds the same cache instead of compiling into a new one."""
    given = os.environ.get("FLEXURE_CACHE_DIR")
    if given and not os.path.isabs(given):
        given = os.environ["FLEXURE_CACHE_DIR"] = os.path.abspath(given)
    candidates = [given, os.environ.get("NUMBA_CACHE_DIR")]
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    candidates.append(os.path.join(base, "flexure"))
    candidates.append(os.path.join(tempfile.gettempdir(), f"flexure-cache-{os.getuid()}"
                                   if hasattr(os, "getuid") else "flexure-cache"))
    for folder in filter(None, candidates):
        try:
            os.makedirs(folder, exist_ok=True)
            tempfile.TemporaryFile(dir=folder).close()
            return os.path.abspath(folder)
        except OSError:
            continue
    return None


def package_cache_folder():
    """This copy's folder in the cache (<cache root>/<package>/<sources hash>), or None when
    there is no writable cache folder."""
    root = cache_root()
    return None if root is None else os.path.join(root, package_name(), sources_hash()[:20])


@functools.cache
def numba_module():
    """numba, imported on first use with flexure's cache locator in place (`_source_locator`)."""
    import numba
    from numba.core import caching

    # numba 0.61 renamed _CacheImpl to CacheImpl; its subclasses share the list of locators
    implementation = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    locator = _source_locator(caching._CacheLocator)
    if locator not in implementation._locator_classes:
        implementation._locator_classes.insert(0, locator)
        _load_without_refresh(caching.Cache, locator)
    linked_code.install()
    inline_copy.install()
    compile_flags.install()
    return numba


def _load_without_refresh(cache_class, locator):
    """Let flexure's cached code load without numba's registry refresh.

    numba refreshes its target before every load from a cache (`Cache.load_overload`): it
    imports the lowering of every builtin and numpy function (scipy.linalg among them) and
    installs their registries, 0.2 to 0.3 s of CPU, for code that is machine code already.
    What a loaded function needs of the process is numba's runtime (NRT), initialised here;
    a compilation refreshes the target itself (numba's compiler does at its start), so a cache
    miss compiles as before. Only caches of flexure's locator are changed (a host's own numba
    code loads as numba does it), and only where numba has the methods this wraps."""
    original = cache_class.load_overload
    if not (hasattr(cache_class, "_load_overload")
            and hasattr(cache_class, "_guard_against_spurious_io_errors")):
        return

    def load_overload(self, sig, target_context):
        if not isinstance(getattr(self._impl, "locator", None), locator):
            return original(self, sig, target_context)
        from numba.core.runtime import rtsys

        rtsys.initialize(target_context)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    cache_class.load_overload = load_overload


@functools.cache
def _source_locator(base):
    """The numba cache locator class for the files of this copy of flexure's core (see the
    module), derived from numba's `base` class."""

    class SourceHashLocator(base):
        def __init__(self, py_func, py_file):
            self._py_file = py_file  # numba's warning of an uncachable function names it
            self._path, self._lineno = cache_location(py_func, py_file)

        def get_cache_path(self):
            return self._path

        def get_source_stamp(self):
            return sources_hash()

        def get_disambiguator(self):
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func, py_file):
            if cache_location(py_func, py_file) is None:
                return None
            return cls(py_func, py_file)

    return SourceHashLocator


def cache_location(py_func, py_file):
    """(folder, first line) of the cache entry of `py_func`, defined in `py_file`; None
    outside this copy's core or without a cache folder."""
    inside = os.path.abspath(py_file).startswith(_CORE + os.sep)
    if not inside or cache_root() is None:
        return None
    relative = os.path.relpath(os.path.dirname(os.path.abspath(py_file)), _PACKAGE_ROOT)
    if linked_code.is_python_callable(py_func):  # numba's index keys neither by the options
        relative = os.path.join("python-calls", relative)  # nor by the code's kind
    return os.path.join(package_cache_folder(), relative), py_func.__code__.co_firstlineno


def kernel(function=None, **options):
    """numba.njit with flexure's compile options; use as `@kernel` or `@kernel(option=...)`.

    The options: cache=True; error_model="numpy"; no_cfunc_wrapper=True (numba would also
    compile a C-callable wrapper of every kernel, which nothing of flexure calls: the C entry
    points are `entry`'s own; without it the first compilation takes about 8 % less CPU). A
    kernel is compiled once per type of its arguments, a constant argument's type being its
    plain type (`_by_plain_types`). The decorated function is a `Kernel`: numba's dispatcher
    made when first needed, compiled for linking into the C entries only (no CPython
    wrapper, no machine code of its own: `linked_code`), and a second one, compiled as numba
    compiles, for a call from Python."""
    options = {"cache": True, "error_model": "numpy", "no_cfunc_wrapper": True, **options}
    if function is None:
        return lambda function: Kernel(function, options)
    return Kernel(function, options)


class Kernel:
    """A numba kernel whose dispatchers (and numba) are made when first needed: the
    linking-only one when compiled code calls it (numba types a global by its
    `_numba_type_`) or a dispatcher's attribute is asked for (`signatures`, ...), the
    Python-callable one when Python calls it."""

    def __init__(self, function, options):
        self.py_func, self._options = function, options
        self._dispatcher = self._python_dispatcher = None
        functools.update_wrapper(self, function)

    @property
    def dispatcher(self):
        """numba's dispatcher of this kernel as compiled code calls it (numba.njit with the
        kernel's options), compiled for linking only (`linked_code`)."""
        if self._dispatcher is None:
            numba = numba_module()
            if linked_code.install():
                dispatcher = numba.njit(**self._options, no_cpython_wrapper=True)(self.py_func)
                linked_code.refusing_python_calls(dispatcher)
            else:
                dispatcher = numba.njit(**self._options)(self.py_func)
            dispatcher.compile = linked_code.compiled_as_kernel(dispatcher.compile,
                                                                  self.py_func)
            self._dispatcher = _by_plain_types(dispatcher)
        return self._dispatcher

    @property
    def python_dispatcher(self):
        """numba's dispatcher of this kernel as Python calls it: compiled as numba compiles
        it, cached apart from the linking-only code (`linked_code.python_callable`)."""
        if self._python_dispatcher is None:
            numba = numba_module()
            if linked_code.install():
                function = linked_code.python_callable(self.py_func)
                # numba's own locators (a kernel outside flexure's core) would file it with
                # the linking-only code: uncached there
                cached = cache_location(function, inspect.getfile(function)) is not None
                dispatcher = numba.njit(
                    **{**self._options, "cache": self._options.get("cache") and cached})(
                    function)
                if cached:
                    dispatcher.compile = compile_lock.compiled_alone(dispatcher.compile, function)
                self._python_dispatcher = dispatcher
            else:
                self._python_dispatcher = self.dispatcher
        return self._python_dispatcher

    @property
    def is_made(self):
        """Whether this process has made its dispatcher (compiled or loaded code or not)."""
        return self._dispatcher is not None

    @property
    def _numba_type_(self):
        from numba.core import types

        return types.Dispatcher(self.dispatcher)

    def __call__(self, *args, **kwargs):
        return self.python_dispatcher(*args, **kwargs)

    def __getattr__(self, name):
        if name.startswith("__"):  # copy, pickle and inspect probe these: not the dispatcher's
            raise AttributeError(name)
        return getattr(self.dispatcher, name)


class CompiledName:
    """A name of numba's that compiled code calls (an intrinsic, numba.carray), made by
    `make()` when numba first types code that uses it: a module that declares kernels with it
    imports neither numba nor llvmlite's IR builder (numba types a global by its
    `_numba_type_`, as `Kernel`s)."""

    def __init__(self, make, name):
        self._make, self._made, self.__name__ = make, None, name

    @property
    def made(self):
        """The intrinsic (or function) itself (numba imported first)."""
        if self._made is None:
            numba_module()
            self._made = self._make()
        return self._made

    @property
    def _numba_type_(self):
        from numba.core.registry import cpu_target

        made = self.made  # before the refresh: it installs what making it declared
        context = cpu_target.typing_context
        context.refresh()
        return context.resolve_value_type(made)

    def __call__(self, *args, **kwargs):
        return self.made(*args, **kwargs)

    def __repr__(self):
        return f"<compiled name {self.__name__}>"


def _plain(numba_type):
    """An integer or boolean constant's type as its plain type (Literal[int](3) as int64)."""
    from numba.core import types

    if isinstance(numba_type, (types.IntegerLiteral, types.BooleanLiteral)):
        return types.unliteral(numba_type)
    return numba_type


def _by_plain_types(dispatcher):
    """`dispatcher`, compiled by the plain types of its arguments when compiled code calls it.

    numba types a constant argument (a slot index, an order, a flag) as a literal and compiles
    the callee once per value: `int_array(table, DIMS)` and `int_array(table, slot)` were two
    compilations, `deformations` four. The values are run-time numbers here, and a branch on
    them costs nothing beside what it selects; one compilation serves every caller."""
    typed_by_literals = dispatcher.get_call_template

    def get_call_template(args, kws):
        return typed_by_literals(tuple(_plain(a) for a in args),
                                 {k: _plain(v) for k, v in kws.items()})

    dispatcher.get_call_template = get_call_template
    return dispatcher


# -- compiled entry points: C functions that other compiled code calls by address ------------
# numba signatures, as numba parses them (strings: declaring them does not import numba)
_POINTER = "CPointer(float64)"
# an element's deformations: (x, ref, order, e, De, D2e, m, k, width) -> void
DEFORMATIONS_ENTRY = (f"void({_POINTER}, {_POINTER}, int64, {_POINTER}, {_POINTER}, "
                      f"{_POINTER}, int64, int64, int64)")
# an element's inertia points: (x, v, ref, order, p, Dp, acc, m, P, width) -> void
INERTIA_ENTRY = (f"void({_POINTER}, {_POINTER}, {_POINTER}, int64, {_POINTER}, {_POINTER}, "
                 f"{_POINTER}, int64, int64, int64)")


class CompiledEntry:
    """A numba cfunc compiled (or loaded from the cache) when its address is first asked for.

    Compiled code calls these through their addresses, never inlines them: each kernel and
    the engine are compiled once, as separate units, which keeps the first compilation short
    (inlining every kernel into every caller made it minutes) and lets an element module plug
    its kernels into the engine without the engine knowing it.

    `function` is the Python function, or a function of no arguments that makes it (called
    when the entry is compiled; `make=True`): an entry whose code needs numba's names (carray)
    is made so without importing numba when it is declared."""

    def __init__(self, function, signature, *, make=False, name=None):
        self.signature = signature
        self._function = None if make else function
        self._make = function if make else None
        self._compiled = self._address = None
        functools.update_wrapper(self, function)
        if name is not None:
            self.__name__ = self.__qualname__ = name

    @property
    def function(self):
        """The Python function compiled."""
        if self._function is None:
            self._function = self._make()
        return self._function

    @property
    def compiled(self):
        """The numba CFunc (compiled on first use, or loaded from the cache)."""
        if self._compiled is None:
            numba = numba_module()
            cached = is_cached(self.function)
            if not cached:
                announce_compilation()
            with compilation_notice().unit(counted=not cached), linked_code.compiling(False):
                self._compiled = numba.cfunc(self.signature, cache=True,
                                             error_model="numpy")(self.function)
        return self._compiled

    @property
    def is_compiled(self):
        """Whether this process has compiled or loaded it."""
        return self._address is not None

    @property
    def address(self):
        """The C function's address (int): its object code loaded from the cache without numba
        (`object_code`) where that can be, else numba's compiled or cached code (whose object
        code is then kept for the next process)."""
        if self._address is None:
            from . import object_code

            address = object_code.load(self.function)
            if address is None:
                # a compilation ahead (one process at a time), unless numba's cache has it
                alone = (contextlib.nullcontext() if is_cached(self.function)
                         else compile_lock.compiling_alone(self.function))
                with alone:  # the process waited for may have written it meanwhile
                    address = object_code.load(self.function)
                    if address is None:
                        address = self.compiled.address
                        object_code.save(self.function, self._compiled)
            self._address = address
        return self._address

    @functools.cached_property
    def ctypes(self):
        """The C function as a ctypes function (pointers as void*: addresses or None)."""
        return ctypes_function(self.signature)(self.address)


_CTYPES = {"void": None, "int32": "c_int32", "intc": "c_int", "int64": "c_int64",
           "float64": "c_double", "double": "c_double", "voidptr": "c_void_p"}


def ctypes_function(signature):
    """The ctypes function type of an entry's numba signature string ("int32(int64, voidptr,
    CPointer(float64))"): pointers of any kind as c_void_p."""
    import ctypes

    def of(name):
        name = name.strip()
        if name.startswith("CPointer("):
            return ctypes.c_void_p
        if name not in _CTYPES:
            raise ValueError(f"entry signature {signature!r}: type {name!r} has no ctypes twin")
        return _CTYPES[name] and getattr(ctypes, _CTYPES[name])

    result, _, arguments = signature.partition("(")
    names, depth, current = [], 0, ""
    for character in arguments[:-1]:
        depth += (character == "(") - (character == ")")
        if character == "," and depth == 0:
            names.append(current)
            current = ""
        else:
            current += character
    if current.strip():
        names.append(current)
    return ctypes.CFUNCTYPE(of(result), *(of(name) for name in names))


def cache_index_path(function):
    """The path of numba's cache index of `function` (a kernel's or entry's Python function
    of flexure's core) for this Python, whether it exists or not (numba's file name:
    module.qualname-line.pyXY.nbi, '<' and '>' left out), or None outside the cache."""
    path = inspect.getfile(function)
    location = cache_location(function, path)
    if location is None:
        return None
    folder, first_line = location
    module = os.path.splitext(os.path.basename(path))[0]
    qualname = function.__qualname__.replace("<", "").replace(">", "")
    name = (f"{module}.{qualname}-{first_line}.py{sys.version_info[0]}"
            f"{sys.version_info[1]}{getattr(sys, 'abiflags', '')}.nbi")
    return os.path.join(folder, name)


def is_cached(function):
    """Whether the on-disk cache holds compiled code of `function` (a kernel's or entry's
    Python function of flexure's core) that this process loads: numba's index of it
    (`cache_index_path`) is of this numba and these sources, and has an entry for this
    process's code-generation target (numba files code by CPU: a cache shared with another
    machine may hold only that machine's)."""
    import pickle

    numba = numba_module()
    from numba.core.registry import cpu_target

    index = cache_index_path(function)
    try:
        with open(index, "rb") as handle:
            if pickle.load(handle) != numba.__version__:
                return False
            stamp, overloads = pickle.loads(handle.read())
    except (OSError, TypeError, ValueError, EOFError, pickle.UnpicklingError):
        return False  # none (index None or no file), or not numba's
    target = cpu_target.target_context.codegen().magic_tuple()
    return stamp == sources_hash() and any(key[1] == target for key in overloads)


@functools.cache
def compilation_notice():
    """This process's `CompileNotice` (its record kept in the cache folder)."""
    return CompileNotice(cache_root(), sources_hash())


def announce_compilation(stream=None):
    """Say once per process that the engine compiles, with an estimate measured on this
    machine: on `stream` (default stderr), terminal or not, with a progress line on a
    terminal; or to the writer of an active `compile_notices` (see `compilation_notice`)."""
    compilation_notice().announce(stream)


def compile_notices(write):
    """A context in which the compilation notice goes to `write(text)`, followed by a summary
    when something compiled (an FMU's slave logs both through its host's FMI logger)."""
    return compilation_notice().notices_to(write)


def entry(signature):
    """Decorator: a lazily compiled C entry point (`CompiledEntry`) with the numba signature."""
    return functools.partial(CompiledEntry, signature=signature)
