"""Compiled entry points loaded as machine code, without numba.

numba keeps each compiled C entry point (`jit.CompiledEntry`) in its cache as object code
(an ELF object, already optimised for this CPU) beside the LLVM bitcode it was made from. To
load it, numba imports itself (about 0.15 s of CPU), parses the bitcode again and hands the
object to its JIT: 0.17 s for the 18 entries of a short simulation, against 0.01 s for the
simulation itself. This module keeps a copy of each entry's object code in a file of its own
(`<module>.<name>-<line>.<key>.fxo` beside numba's index) and loads it straight into an LLVM
execution engine of its own (llvmlite's MCJIT, as numba's is), after checking that:

- the file is this format, its object's SHA-256 is the one recorded, and it was written for
  this code-generation target (`target_key`: the target triple, CPU name and features as
  numba derives them, and the numba, llvmlite and Python versions; the sources are checked by
  the folder, which `jit` keys by their hash);
- every symbol the object leaves undefined is known: the runtime functions of numba's C
  extensions (NRT and the helper library, loaded as extensions without importing numba), the
  Python C API and the C library (`_runtime_symbols`). LLVM's loader does not report an
  unresolved symbol; it would leave a null call in the code, so a file with one is not loaded.

Anything else (no file, another target, a corrupt file, a platform other than ELF x86-64 or
AArch64, a numba setting from the environment that changes the code this module cannot
vouch for) returns None and the entry goes through numba as before, which then writes the file
for the next process (`save`). The loaded code is numba's own, byte for byte: results are
the same as through numba (a test compares two runs bit for bit). NUMBA_CPU_NAME and
NUMBA_CPU_FEATURES are honoured as numba honours them; FLEXURE_OBJECT_CODE=0 turns the loading
off (numba loads every entry then).
"""

import builtins
import functools
import hashlib
import importlib.machinery
import importlib.util
import json
import os
import struct
import sys

from . import jit

FORMAT = 1
SUFFIX = ".fxo"
# numba settings read from the environment that change the code numba makes; with any of these
# set (other than the CPU name and features, which `target_key` follows) numba loads it
_CODE_SETTINGS = ("NUMBA_OPT", "NUMBA_ENABLE_AVX", "NUMBA_DISABLE_JIT", "NUMBA_BOUNDSCHECK",
                  "NUMBA_FASTMATH", "NUMBA_LOOP_VECTORIZE", "NUMBA_SLP_VECTORIZE",
                  "NUMBA_DISABLE_INTEL_SVML", "NUMBA_USE_LLVMLITE_MEMORY_MANAGER")
_DISABLED_AVX_CPUS = {"corei7-avx", "core-avx-i", "sandybridge", "ivybridge", "nocona"}


def enabled():
    """Whether entries may be loaded from object-code files in this process (see the module)."""
    if os.environ.get("FLEXURE_OBJECT_CODE", "1") == "0":
        return False
    if any(name in os.environ for name in _CODE_SETTINGS):
        return False
    if os.path.exists(".numba_config.yaml"):  # numba reads settings from the working folder
        return False
    return sys.platform.startswith("linux") and llvm_binding() is not None


@functools.cache
def llvm_binding():
    """llvmlite's binding, its native target initialised (None without llvmlite)."""
    try:
        import llvmlite.binding as ll
    except ImportError:
        return None
    ll.initialize_native_target()
    ll.initialize_native_asmprinter()
    return ll


@functools.cache
def code_target():
    """(triple, CPU name, CPU features) of numba's code generation in this process, derived as
    numba derives them (numba.core.config and codegen): NUMBA_CPU_NAME, else the host's CPU;
    NUMBA_CPU_FEATURES, else none for the generic CPU, else the host's features with AVX off
    on the CPUs numba turns it off for."""
    ll = llvm_binding()
    cpu = os.environ.get("NUMBA_CPU_NAME") or None
    features = os.environ.get("NUMBA_CPU_FEATURES") or None
    if features is None and str(cpu).lower() == "generic":
        features = ""
    if features is None:
        host = ll.get_host_cpu_features()
        if (cpu or ll.get_host_cpu_name()) in _DISABLED_AVX_CPUS or not _os_supports_avx():
            for name in host:
                if name.startswith("avx"):
                    host[name] = False
        features = host.flatten()
    return ll.get_process_triple(), cpu or ll.get_host_cpu_name(), features


def _os_supports_avx():
    """Whether the kernel lets programs use AVX (numba's test: 'avx' among /proc/cpuinfo's
    flags on x86; true elsewhere)."""
    import platform

    if platform.machine() not in ("i386", "i586", "i686", "x86_64"):
        return True
    try:
        with open("/proc/cpuinfo") as info:
            return any(line.partition(":")[0].strip() == "flags"
                       and "avx" in line.partition(":")[2].split() for line in info)
    except OSError:
        return True


@functools.cache
def target_key():
    """A short hash of what the object code depends on besides the sources: `code_target()`,
    the numba, llvmlite and Python versions."""
    from importlib import metadata

    described = [list(code_target()), metadata.version("numba"), metadata.version("llvmlite"),
                 sys.version, sys.implementation.cache_tag]
    return hashlib.sha256(json.dumps(described).encode()).hexdigest()[:16]


def file_of(function):
    """The object-code file of an entry's Python function (beside numba's index), or None
    outside the cache."""
    index = jit.cache_index_path(function)
    if index is None:
        return None
    return f"{index[:-len('.nbi')]}.{target_key()}{SUFFIX}"


def load(function):
    """The address (int) of the entry compiled from `function`, loaded from its object-code
    file, or None when it cannot be (see the module)."""
    if not enabled():
        return None
    path = file_of(function)
    try:
        with open(path, "rb") as handle:
            header = json.loads(handle.readline())
            code = handle.read()
    except (OSError, TypeError, ValueError):
        return None
    if not (isinstance(header, dict) and header.get("format") == FORMAT
            and header.get("target") == target_key() and isinstance(header.get("symbol"), str)
            and hashlib.sha256(code).hexdigest() == header.get("sha256")):
        return None
    try:
        engine = _engine()
    except (ImportError, OSError, RuntimeError):
        return None  # numba's runtime extensions not loadable as files: numba loads the entry
    return engine.add(code, header["symbol"])


def save(function, cfunc):
    """Write the object-code file of `function` from numba's cache entry of its compiled
    `cfunc` (a numba CFunc compiled or loaded in this process, after `load` found no file it
    could load). Nothing is written when numba kept no object code for it, or its code needs
    numba at load time (an initialiser to run)."""
    if not enabled():
        return
    path = file_of(function)
    if path is None:
        return
    try:
        from numba.core.registry import cpu_target

        codegen = cpu_target.target_context.codegen()
        if tuple(codegen.magic_tuple()) != code_target():
            return  # numba was configured otherwise (a setting this module does not follow)
        cache = cfunc._cache
        payload = cache._cache_file.load(cache._index_key(cfunc._sig, codegen))
        (_, kind, data), reload_init = payload[0], payload[7]
        # the symbol as the cached code names it: numba numbers each compilation within its
        # process, and the cache may hold another process's compilation of the same entry
        symbol = payload[1].llvm_cfunc_wrapper_name
    except (AttributeError, IndexError, TypeError, ValueError, OSError):
        return  # another numba's cache layout: numba keeps loading it
    if kind == "object" and not reload_init:
        write(path, data[0], symbol)


def write(path, code, symbol):
    """Write an object-code file: a header line (JSON: format, target, symbol, sha256 of the
    code) and the object `code` (bytes) whose function `symbol` is the entry. Replaces the
    file whole (a file a process could not load is written anew); an error of the file system
    is ignored."""
    header = {"format": FORMAT, "target": target_key(), "symbol": symbol,
              "sha256": hashlib.sha256(code).hexdigest()}
    temporary = f"{path}.{os.getpid()}.tmp"
    try:
        with open(temporary, "wb") as handle:
            handle.write(json.dumps(header).encode() + b"\n" + code)
        os.replace(temporary, path)  # whole or not at all, also with processes in parallel
    except OSError:
        try:
            os.remove(temporary)
        except OSError:
            pass


def undefined_symbols(code):
    """The names of the symbols an ELF64 little-endian relocatable object uses but does not
    define (its symbol table's entries in no section).

    Raises
    ------
    ValueError
        `code` is not such an object.
    """
    if code[:4] != b"\x7fELF" or code[4:6] != b"\x02\x01":
        raise ValueError("not a little-endian 64-bit ELF object")
    section_offset, = struct.unpack_from("<Q", code, 0x28)
    entry_size, count = struct.unpack_from("<HH", code, 0x3A)
    # (name, type, flags, address, offset, size, link, info, alignment, entry size)
    sections = [struct.unpack_from("<IIQQQQIIQQ", code, section_offset + i * entry_size)
                for i in range(count)]
    names = set()
    for _, kind, _, _, offset, size, link, _, _, symbol_size in sections:
        if kind != 2:  # SHT_SYMTAB
            continue
        strings = sections[link][4]
        for at in range(offset, offset + size, symbol_size):
            name, _, _, section = struct.unpack_from("<IBBH", code, at)
            if section == 0 and name:  # SHN_UNDEF
                start = strings + name
                names.add(code[start:code.index(b"\0", start)].decode())
    return names


@functools.cache
def _engine():
    """This process's execution engine for loaded object code (made on first use)."""
    return _ObjectEngine()


class _ObjectEngine:
    """An LLVM MCJIT execution engine for the target of `code_target`, with numba's runtime
    symbols registered, into which object files are added."""

    def __init__(self):
        ll = llvm_binding()
        _runtime_symbols(ll)
        triple, cpu, features = code_target()
        machine = ll.Target.from_triple(triple).create_target_machine(
            cpu=cpu, features=features, reloc="static", codemodel="jitdefault")
        module = ll.parse_assembly("")
        module.triple = triple
        self._ll = ll
        self._engine = ll.create_mcjit_compiler(module, machine)

    def add(self, code, symbol):
        """Add an object file and return the address of `symbol` in it, or None when the
        object is not ELF or leaves a symbol unresolved."""
        try:
            needed = undefined_symbols(code)
        except (ValueError, struct.error):
            return None
        if not all(self._ll.address_of_symbol(name) for name in needed):
            return None
        self._engine.add_object_file(self._ll.ObjectFileRef.from_data(code))
        self._engine.finalize_object()
        return self._engine.get_function_address(symbol) or None


def _runtime_symbols(ll):
    """Register what numba registers before its compiled code runs: the functions of its
    helper library (numba_*; the C maths it binds to CPython's), of its runtime (NRT_*), the
    built-in exceptions (PyExc_*) and None. The C extensions are numba's own, loaded by file
    and entered in sys.modules under their names, so that a numba imported later uses the same
    ones (its runtime then keeps one memory system)."""
    helper = _extension("numba._helperlib", "_helperlib")
    runtime = _extension("numba.core.runtime._nrt_python", "core/runtime/_nrt_python")
    ll.add_symbol("_Py_NoneStruct", id(None))
    for name, address in helper.c_helpers.items():
        ll.add_symbol("numba_" + name, address)
        if name in _C_MATHS:
            ll.add_symbol(name, address)
    for name, address in runtime.c_helpers.items():
        ll.add_symbol(name if name.startswith("_") else "NRT_" + name, address)
    for value in vars(builtins).values():
        if isinstance(value, type) and issubclass(value, BaseException):
            ll.add_symbol(f"PyExc_{value.__name__}", id(value))


# numba binds these C maths functions to the helper library's (numba.core.intrinsics.INTR_MATH)
_C_MATHS = frozenset(
    f"{name}{suffix}" for suffix in ("", "f") for name in (
        "acos", "acosh", "asin", "asinh", "atan", "atan2", "atanh", "ceil", "cos", "cosh",
        "exp", "expm1", "fabs", "floor", "fmod", "log", "log10", "log1p", "pow", "round",
        "sin", "sinh", "sqrt", "tan", "tanh", "trunc"))


def _extension(name, relative):
    """numba's C extension module `name` (file `relative` in numba's folder, without its
    suffix), the one in sys.modules when numba or this module loaded it already."""
    if name in sys.modules:
        return sys.modules[name]
    folder = os.path.dirname(importlib.util.find_spec("numba").origin)  # does not import it
    base = os.path.join(folder, *relative.split("/"))
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        if os.path.exists(base + suffix):
            loader = importlib.machinery.ExtensionFileLoader(name, base + suffix)
            spec = importlib.util.spec_from_file_location(name, base + suffix, loader=loader)
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            loader.exec_module(module)
            return module
    raise ImportError(f"numba's extension {name} not found in {folder}")
