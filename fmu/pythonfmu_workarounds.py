"""What pythonfmu 0.7.0's binary needs from the Python side of an FMU to stay safe: the
script namespace it releases without owning it and the classes it leaks while looking for the
slave class (`keep_script_namespace`, appended to every slave script by the builder), the
interpreter guard it releases twice at exit (`guard_exit`), the copies of the resources folder
it adds to sys.path (`tidy_sys_path`), and getters and setters that would keep a freed
instance alive in a reference cycle (`weakly_bound`). `SafeSlave` (`slave.py`) uses them; the
measurements behind each are in docs/fmu.md."""

import sys
import types
import weakref

# pythonfmu 0.7.0's binary finds the slave class by importing the script module, executing the
# script once more in the module's namespace with a fresh dict of locals, and then releasing
# one reference to that namespace it never owned (findClass in PySlaveInstance.cpp:
# Py_DECREF on the borrowed PyModule_GetDict). The first instance frees the module's __dict__;
# the next instantiation of the same FMU in the process then fails ("module has no attribute
# ...") or reads garbage. So every execution of the script takes one reference to the
# namespace that is never released (`hold_namespace`).
#
# findClass also leaks, per instantiation and for every class among those locals, the list it
# makes of the class's __mro__, the repr of every entry of that list and the UTF-8 bytes of
# each repr, then the bytes of the name it picks; and the constructor leaks the string of the
# resources path it inserts into sys.path. A class created anew by every execution of the
# script would be kept alive by that list (~2.5 kB each): `keep_script_namespace` leaves
# findClass only `SlaveMarker`, whose __mro__ and reprs are stored objects chosen to leak the
# least: two entries (no `object`, whose repr is a new string at every call), an empty repr
# first (its bytes are Python's shared empty bytes) and then the shortest repr findClass's
# pattern "<class '*.Fmi2Slave'>" accepts. What is left per instantiation is pythonfmu's: the
# list (72 bytes), the repr's bytes (56), the name's bytes (48 for "truss_1dof_x") and the
# path string (49 bytes + the path's length): about 0.3 kB where a three-entry MRO cost 0.5.
SCRIPT_NAMESPACES = []  # the namespaces held while Py_IncRef cannot be called (see hold_namespace)
INCREF = []  # Py_IncRef, called through ctypes (looked up once)


def hold_namespace(namespace):
    """Take one reference to `namespace` that is never released: Py_IncRef through ctypes
    (nothing grows), or, in a host where that call cannot be made, a place in a list."""
    try:
        if not INCREF:
            import ctypes

            INCREF.append(ctypes.PYFUNCTYPE(None, ctypes.py_object)(
                ("Py_IncRef", ctypes.pythonapi)))
        INCREF[0](namespace)
    except Exception:  # noqa: BLE001 -- no ctypes, or no Py_IncRef: hold it in the list
        SCRIPT_NAMESPACES.append(namespace)


class CachedRepr(type):
    """A metaclass whose repr is one stored string (no new object per repr call)."""

    def __repr__(cls):
        return cls.__dict__["_repr"]


class Fmi2SlaveLookalike(metaclass=CachedRepr):
    _repr = "<class '_.Fmi2Slave'>"  # the shortest repr findClass takes for Fmi2Slave


class StoredMro(CachedRepr):
    """A metaclass whose classes answer `__mro__` with a stored tuple (what findClass reads;
    the interpreter's own method resolution is unchanged)."""

    @property
    def __mro__(cls):
        return cls.__dict__["_mro"]


class SlaveMarker(Fmi2SlaveLookalike, metaclass=StoredMro):
    """What findClass finds in the locals of a re-executed script, bound to the slave class's
    name: an `__mro__` of two entries whose second's repr it matches against
    "<class '*.Fmi2Slave'>" to pick the name it then looks up in the module (the real
    class). Stored reprs and MRO, the first repr empty: findClass leaks the least it can."""

    _repr = ""


SlaveMarker._mro = (SlaveMarker, Fmi2SlaveLookalike)


def keep_script_namespace(namespace, local_namespace=None):
    """Called at the end of a slave script as `(globals(), locals())`, by code the builder
    appends (`build_slave_fmu`).

    The script runs once on import (then both are the module's namespace) and once more per
    instantiation, in fresh locals; every release of the namespace by pythonfmu's binary is
    matched by one reference taken here (`hold_namespace`, never released). In a re-execution the
    locals are emptied down to the slave class's name bound to `SlaveMarker`. A scene script
    creates no class when it is re-executed (it looks its class up in the module, see
    `flexure.fmu.builder.scene_script`); a class that another script does create again dies
    with the locals (at a collection of the garbage collector's youngest generation: a class
    is a reference cycle) instead of being kept by findClass's leaked lists.
    """
    hold_namespace(namespace)
    if local_namespace is None or local_namespace is namespace:
        return
    name, depth = None, 0
    for key, value in list(local_namespace.items()):
        if isinstance(value, type):
            chain = [c.__name__ for c in value.__mro__]
            if "Fmi2Slave" in chain[1:] and chain.index("Fmi2Slave") > depth:
                name, depth = key, chain.index("Fmi2Slave")
    local_namespace.clear()
    if name is not None:
        local_namespace[name] = SlaveMarker


# pythonfmu 0.7.0's binary holds its interpreter guard in a static std::shared_ptr and also
# resets it from an __attribute__((destructor)) function (finalizePythonInterpreter). At exit
# the static's destructor runs first (exit handlers), then the library destructor assigns to
# the destroyed shared_ptr and releases its freed control block a second time: "corrupted
# double-linked list" / SIGSEGV after the host's last line, in any process that instantiated
# the FMU (intermittent: it depends on what reused the freed block). dlclose cannot avoid it:
# the binary has STB_GNU_UNIQUE symbols, so glibc never unloads it. In a Python host the
# remedy is to release the guard ourselves before the interpreter finalizes (an atexit
# handler), through the exported finalizePythonInterpreter: both later resets then see an
# empty pointer. Not in a host whose interpreter the binary created (JVM, C): there the
# guard's release *is* the interpreter's finalization.
_GUARDED_BINARIES = {}


def guard_exit(resources, model_identifier):
    """Register the release of this FMU binary's interpreter guard at interpreter exit."""
    if sys.platform != "linux" or not resources:
        return
    import os
    import threading

    if threading.main_thread().native_id != os.getpid():
        return  # the interpreter runs on the binary's own thread: not a Python host
    path = os.path.join(os.path.dirname(os.path.normpath(resources)), "binaries", "linux64",
                        f"{model_identifier}.so")
    if path in _GUARDED_BINARIES or not os.path.isfile(path):
        return
    import ctypes

    library = ctypes.CDLL(path, mode=os.RTLD_NOLOAD | os.RTLD_LAZY)  # the loaded copy
    release = getattr(library, "finalizePythonInterpreter", None)
    if release is None:
        return
    release.restype, release.argtypes = None, []
    if not _GUARDED_BINARIES:
        import atexit

        atexit.register(_release_guards)
    _GUARDED_BINARIES[path] = release


def guarded_binaries():
    """The paths of the FMU binaries whose interpreter guard is released at interpreter exit."""
    return list(_GUARDED_BINARIES)


def _release_guards():
    for release in _GUARDED_BINARIES.values():
        release()
    _GUARDED_BINARIES.clear()


def tidy_sys_path(resources):
    """Drop the copies of the resources folder pythonfmu's binary adds to sys.path.

    It inserts the folder at the front of sys.path on every instantiation (PySlaveInstance's
    constructor) and never removes it: sys.path would grow by one entry per instance.
    """
    if resources and sys.path.count(resources) > 1:
        first = sys.path.index(resources)
        sys.path[:] = [p for i, p in enumerate(sys.path) if p != resources or i == first]


def weakly_bound(function, owner):
    """`function` (a getter or setter of one of `owner`'s variables) holding `owner` weakly.

    A getter that is a closure over the instance (`lambda: self.x`, the defaults of `add_real`,
    SceneSlave's lambdas) or a bound method of it makes instance -> vars -> getter -> instance
    a reference cycle. pythonfmu's binary releases the instance at fmi2FreeInstance, but a
    cycle is freed only by the cyclic garbage collector, whose full collections a host that
    instantiates and frees an FMU in a loop reaches every few hundred instances: the freed
    instances, their models and arrays pile up in between (0.6 MB of the 1.7 MB the RSS of
    tests/test_fmu_memory.py's leak case grew over 1000 cycles). So the closure is copied
    with cells that hold a weak proxy of the instance instead of the instance (the original
    function is left as it is: its cells may be shared), and a bound method is bound to the
    proxy; anything else is returned unchanged.
    """
    if isinstance(function, types.MethodType) and function.__self__ is owner:
        return types.MethodType(function.__func__, weakref.proxy(owner))
    if not isinstance(function, types.FunctionType) or not function.__closure__:
        return function
    cells = [(cell, _cell_holds(cell, owner)) for cell in function.__closure__]
    if not any(holds for _, holds in cells):
        return function
    proxy = weakref.proxy(owner)
    copy = types.FunctionType(function.__code__, function.__globals__, function.__name__,
                              function.__defaults__,
                              tuple(types.CellType(proxy) if holds else cell
                                    for cell, holds in cells))
    copy.__kwdefaults__ = function.__kwdefaults__
    copy.__qualname__ = function.__qualname__
    copy.__dict__.update(function.__dict__)
    return copy


def _cell_holds(cell, owner):
    try:
        return cell.cell_contents is owner
    except ValueError:  # an empty cell (a variable not yet assigned)
        return False


# pythonfmu 0.7.0's binary passes every message to the host's logger only when the host
# instantiated with loggingOn = fmi2True (PyLogger::log drops everything otherwise, errors
# included, where the FMI 2.0 practice, e.g. the Reference FMUs, logs errors regardless), and
# an exception in the slave's constructor reaches the host only as that dropped message: the
# host sees "Failed to instantiate model" and nothing else. `log_to_host` calls the host's own
# logger callback instead. The binary hands the constructor the address of its logger object
# (kwargs["logger"]), an Fmi2Logger (PySlaveInstance.cpp, fmi2.cpp):
#
#     offset  0  vtable pointer             offset 16  std::string instanceName_ (data, size)
#     offset  8  bool debugLogging_         offset 48  std::vector<std::string> categories_
#     offset 72  const fmi2CallbackFunctions* f_  -> {logger, allocateMemory, freeMemory,
#                                                     stepFinished, componentEnvironment}
#
# That layout is the one of the linux64 binary of pythonfmu 0.7.0, and of flexure's corrected
# build of it (fmu/native: its patch leaves Fmi2Logger and PyLogger as they are), identified by
# their SHA-256; any other binary (another version or platform) is not read, and the message
# goes to stderr. tests/test_fmu_native.py checks that the committed build is listed here.
_LAYOUT_0_7_0 = {"name": 16, "callbacks": 72, "component_environment": 32}
PYTHONFMU_LOGGER_LAYOUTS = {
    # pythonfmu 0.7.0, binaries/linux64/libpythonfmu-export.so
    "4be156a552c16f30eb4395805c59855d8d4086056d0f165442565f6c5fbac0c9": _LAYOUT_0_7_0,
    # flexure's corrected build of it, fmu/native/linux64/libpythonfmu-export.so (patch 1)
    "0690858abe8b5dc7267a54529dad9327fd27e53606c76d4915baa0f7db5ff24f": _LAYOUT_0_7_0,
}
FMI2_WARNING, FMI2_ERROR = 1, 3  # fmi2Status
# the log categories pythonfmu declares, by status (logAll for the others)
_CATEGORIES = {FMI2_WARNING: b"logStatusWarning", FMI2_ERROR: b"logStatusError"}


def log_to_host(kwargs, message, status=FMI2_ERROR) -> bool:
    """Log `message` through the host's FMI logger callback from a slave's constructor, even
    when the host switched debug logging off; False if this binary's layout is not known.

    `kwargs` are the constructor's keyword arguments (instance_name, resources, logger). The
    instance name stored in the logger object must equal kwargs["instance_name"], or nothing
    is called.
    """
    try:
        import ctypes
        import hashlib
        import os

        address, name = kwargs.get("logger"), kwargs.get("instance_name")
        resources = kwargs.get("resources")
        if not (isinstance(address, int) and address and isinstance(name, str) and resources
                and sys.platform == "linux"):
            return False
        folder = os.path.join(os.path.dirname(os.path.normpath(resources)), "binaries",
                              "linux64")
        binaries = [os.path.join(folder, f) for f in os.listdir(folder) if f.endswith(".so")]
        if len(binaries) != 1:
            return False
        with open(binaries[0], "rb") as handle:
            layout = PYTHONFMU_LOGGER_LAYOUTS.get(hashlib.sha256(handle.read()).hexdigest())
        if layout is None:
            return False

        def word(at):
            return ctypes.c_void_p.from_address(at).value or 0

        encoded = name.encode()
        data, size = word(address + layout["name"]), word(address + layout["name"] + 8)
        if not data or size != len(encoded) or ctypes.string_at(data, size) != encoded:
            return False
        callbacks = word(address + layout["callbacks"])
        logger = word(callbacks) if callbacks else 0
        if not logger:
            return False
        prototype = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int,
                                     ctypes.c_char_p, ctypes.c_char_p)
        category = _CATEGORIES.get(status, b"logAll")
        # the host formats the message as printf does: '%' doubled
        prototype(logger)(word(callbacks + layout["component_environment"]), encoded, status,
                          category, str(message).replace("%", "%%").encode())
        return True
    except Exception:  # noqa: BLE001 -- a constructor that reports must not fail otherwise
        return False


# Which pythonfmu binary the FMU carries (flexure.fmu.pythonfmu_binary writes the record):
# the corrected build answers what the stock one crashes on, docs/fmu.md's datasheet.
BINARY_RECORD = "pythonfmu-binary.json"


def binary_note(resources) -> str | None:
    """The log line saying which pythonfmu binary this FMU carries for this platform, or None
    where the FMU has no record of it (built before flexure recorded it, or not by flexure).
    """
    import json
    import os
    import platform

    platform_name = {"linux": "linux64", "win32": "win64", "darwin": "darwin64"}.get(
        sys.platform, sys.platform) if platform.architecture()[0] == "64bit" else None
    try:
        with open(os.path.join(resources, BINARY_RECORD), encoding="utf-8") as handle:
            entry = json.load(handle).get(platform_name)
    except (OSError, ValueError, TypeError, AttributeError):
        return None
    if not isinstance(entry, dict):
        return None
    digest = str(entry.get("sha256"))[:12]
    if entry.get("binary") == "corrected":
        return (f"pythonfmu binary ({platform_name}): flexure's corrected build of pythonfmu "
                f"{entry.get('pythonfmu')} (patch {entry.get('patch')}, SHA-256 {digest}): "
                "NULL state handles and freed instances answer fmi2Error")
    return (f"pythonfmu binary ({platform_name}): pythonfmu's stock build (SHA-256 {digest}), "
            f"not flexure's corrected one: {entry.get('why')}; a NULL state handle or a freed "
            "instance crashes the host (docs/fmu.md)")
