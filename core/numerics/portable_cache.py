"""Compiled code that travels: this copy's compiled-code cache exported for a portable CPU
target, and installed into another machine's cache. An FMU carries its engine this way.

**Export** (`export_compiled`), in a process whose numba compiles for a portable target
(NUMBA_CPU_NAME=generic: no CPU-specific instructions), once the code a use needs has run:
the cache files (numba's index `.nbi` and data `.nbc` files) of every function of this copy of
flexure that has compiled code in the process are copied into a folder, with `manifest.json`
saying what the code needs of the process that loads it (`target_description`: Python,
numba, llvmlite and numpy versions, machine, operating system, numba's code-generation
target) and which copy of flexure it belongs to (package name and sources hash).

**Install** (`install_compiled`), in the process that will use it: if the manifest matches
this process and this copy of flexure, the files are copied into this copy's folder of the
cache (`jit.cache_root`: the user's, writable; the source may sit in a read-only folder), and
each index is rewritten so that its entries name this process's code-generation target.
numba files each compiled function under (signature, target triple, CPU name, CPU features)
and looks up only its own CPU's; code for the generic CPU runs on every CPU of the
architecture, so filing it under this process's CPU is safe, and it is then found whatever
CPU numba's code generator was created for, also in a host that imported numba and compiled
before the FMU was loaded. A function whose index is in the cache already is left as it is
(this machine compiled or installed it before). When something does not match, nothing is
installed and the reason is returned: the code then compiles as it would without it.
"""

import glob
import io
import json
import os
import pickle
import platform
import shutil
import sys

from . import jit

MANIFEST = "manifest.json"
FORMAT = 1
PORTABLE_CPU = ("generic", "")  # numba's CPU name and features of portable code
# what must be equal between the exporting and the installing process
MATCHED = ("python", "implementation", "abiflags", "numba", "llvmlite", "numpy", "machine",
           "system", "triple")


def target_description() -> dict:
    """What compiled code of this process needs of the process that loads it.

    Returns
    -------
    dict
        python ("3.11"), implementation, abiflags, numba, llvmlite and numpy versions, machine
        ("x86_64"), system ("Linux"), and numba's code-generation target: triple, cpu_name,
        cpu_features (this process's: NUMBA_CPU_NAME and NUMBA_CPU_FEATURES, or the host's).
    """
    import llvmlite
    import numba
    import numpy
    from numba.core.registry import cpu_target

    triple, cpu_name, cpu_features = cpu_target.target_context.codegen().magic_tuple()
    return {"python": "{}.{}".format(*sys.version_info[:2]),
            "implementation": sys.implementation.name, "abiflags": getattr(sys, "abiflags", ""),
            "numba": numba.__version__, "llvmlite": llvmlite.__version__,
            "numpy": numpy.__version__, "machine": platform.machine(),
            "system": platform.system(), "triple": triple, "cpu_name": cpu_name,
            "cpu_features": cpu_features}


def compiled_functions() -> list:
    """The Python functions of this copy of flexure's core that have compiled code in this
    process: kernels called at least once, C callbacks, entry points whose address was taken
    (each a module global of its module)."""
    from numba.core.ccallback import CFunc
    from numba.core.dispatcher import Dispatcher

    prefix = f"{jit.package_name()}.core."
    found = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith(prefix) or module is None:
            continue
        for value in list(vars(module).values()):
            if isinstance(value, jit.Kernel) and value.is_made and value.signatures:
                function = value.py_func
            elif isinstance(value, Dispatcher) and value.signatures:
                function = value.py_func
            elif isinstance(value, CFunc):
                function = value.__wrapped__
            elif isinstance(value, jit.CompiledEntry) and value.is_compiled:
                function = value.function
            else:
                continue
            found[(function.__code__.co_filename, function.__qualname__)] = function
    return [found[key] for key in sorted(found)]


def export_compiled(dest) -> dict:
    """Copy the cache files of `compiled_functions()` and a manifest into the folder `dest`.

    Parameters
    ----------
    dest : str or Path
        The folder to write (created; its files are relative to this copy's cache folder).

    Returns
    -------
    dict
        The manifest written: `target_description()` and format, package, sources,
        functions, files, bytes, and not_cached: the compiled functions numba did not keep
        in the cache (they compile wherever the code is installed).

    Raises
    ------
    RuntimeError
        This process has no cache folder.
    """
    folder = jit.package_cache_folder()
    if folder is None:
        raise RuntimeError("no writable cache folder: nothing compiled was kept to export")
    # Each index is read once and written as read, with the data files that reading names:
    # another process compiling into the cache meanwhile rewrites an index (numba writes the
    # new overload's data file, then the index), and a second read of it could name a data
    # file this export did not copy. (numba replaces a named data file only with the code
    # of the same overload.)
    indexes, data_files, not_cached = {}, [], []
    for function in compiled_functions():
        index = jit.cache_index_path(function)
        if not os.path.isfile(index):
            not_cached.append(f"{function.__module__}.{function.__qualname__}")
            continue
        with open(index, "rb") as handle:
            indexes[index] = handle.read()
        _, _, overloads = _parse_index(indexes[index])  # its data files, not stale ones
        data_files += [os.path.join(os.path.dirname(index), name)
                       for name in sorted(set(overloads.values()))]
    os.makedirs(dest, exist_ok=True)
    size = 0
    for path in data_files:
        target = os.path.join(dest, os.path.relpath(path, folder))
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(path, target)
        size += os.path.getsize(path)
    for path, raw in indexes.items():  # after their data files, as numba writes them
        target = os.path.join(dest, os.path.relpath(path, folder))
        os.makedirs(os.path.dirname(target), exist_ok=True)
        with open(target, "wb") as handle:
            handle.write(raw)
        size += len(raw)
    functions, files = len(indexes), len(indexes) + len(data_files)
    manifest = {"format": FORMAT, **target_description(), "package": jit.package_name(),
                "sources": jit.sources_hash(), "functions": functions, "files": files,
                "bytes": size, "not_cached": not_cached}
    with open(os.path.join(dest, MANIFEST), "w") as handle:
        json.dump(manifest, handle, indent=1)
    return manifest


def mismatch(manifest: dict) -> str | None:
    """Why compiled code described by `manifest` cannot run in this process (None if it
    can): a version, the machine or the code-generation target differs, or the code belongs
    to another copy of flexure."""
    if not isinstance(manifest, dict):
        return f"its {MANIFEST} is not a JSON object"
    if manifest.get("format") != FORMAT:
        return (f"its {MANIFEST} is of format {manifest.get('format')!r}; this flexure reads "
                f"format {FORMAT}")
    here = target_description()
    for key in MATCHED:
        if str(manifest.get(key)) != str(here[key]):
            return (f"it was compiled for {key} {manifest.get(key)}; this Python has "
                    f"{key} {here[key]}")
    shipped = (manifest.get("cpu_name"), manifest.get("cpu_features"))
    if shipped != PORTABLE_CPU and shipped != (here["cpu_name"], here["cpu_features"]):
        return (f"it was compiled for the CPU {shipped[0]!r}, not for a portable target "
                "(NUMBA_CPU_NAME=generic)")
    for key, value in (("package", jit.package_name()), ("sources", jit.sources_hash())):
        if manifest.get(key) != value:
            return f"it belongs to another copy of flexure ({key} {manifest.get(key)!r})"
    return None


def install_compiled(source, folder=None) -> tuple[bool, str]:
    """Install the compiled code exported into the folder `source` into this copy's cache.

    Parameters
    ----------
    source : str or Path
        A folder written by `export_compiled` (read only).
    folder : str or Path, optional
        Where to install it; default this copy's folder of the cache
        (`jit.package_cache_folder`), where its kernels look for their compiled code.

    Returns
    -------
    (bool, str)
        Whether it was installed, and one line saying what was done or why not.
    """
    try:
        with open(os.path.join(source, MANIFEST)) as handle:
            manifest = json.load(handle)
    except (OSError, ValueError) as error:
        return False, f"its {MANIFEST} cannot be read ({type(error).__name__}: {error})"
    reason = mismatch(manifest)
    if reason is not None:
        return False, reason
    folder = jit.package_cache_folder() if folder is None else str(folder)
    if folder is None:
        return False, "there is no writable cache folder to install it into"
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as error:
        return False, f"the cache folder {folder} cannot be written ({error.strerror})"
    here = target_description()
    shipped = (here["triple"], manifest["cpu_name"], manifest["cpu_features"])
    target = (here["triple"], here["cpu_name"], here["cpu_features"])
    installed, kept, failed = 0, 0, []
    for index in sorted(glob.glob(os.path.join(glob.escape(str(source)), "**", "*.nbi"),
                                  recursive=True)):
        relative = os.path.relpath(index, source)
        destination = os.path.join(folder, relative)
        if os.path.exists(destination):
            kept += 1
            continue
        try:
            _install_index(index, destination, shipped, target)
            installed += 1
        except (OSError, ValueError, pickle.UnpicklingError, EOFError) as error:
            failed.append(f"{relative} ({type(error).__name__})")
    what = (f"installed the compiled code of {installed} functions (built for the CPU target "
            f"{manifest['cpu_name']!r}) into {folder}")
    if kept:
        what += f"; {kept} were there already"
    if failed:
        what += f"; {len(failed)} could not be read and will compile: {', '.join(failed)}"
    return True, what


def _install_index(index, destination, shipped, target):
    """Copy one function's data files, then its index with its entries of the `shipped`
    target filed under `target` (written last, under a temporary name first: a process
    reading the cache meanwhile finds either no index or a complete one)."""
    from numba.core.serialize import dumps

    version, stamp, overloads = _read_index(index)
    overloads = {(key[0], target if key[1] == shipped else key[1], *key[2:]): name
                 for key, name in overloads.items()}
    os.makedirs(os.path.dirname(destination), exist_ok=True)
    for name in sorted(set(overloads.values())):  # a stale file of that name is replaced
        shutil.copyfile(os.path.join(os.path.dirname(index), name),
                        os.path.join(os.path.dirname(destination), name))
    temporary = f"{destination}.{os.getpid()}.tmp"
    with open(temporary, "wb") as handle:
        pickle.dump(version, handle, protocol=-1)
        handle.write(dumps((stamp, overloads)))
    os.replace(temporary, destination)


def _read_index(path):
    """(numba version, source stamp, {(signature, target, hashes): data file name}) of a
    numba cache index; ValueError if it is not one."""
    with open(path, "rb") as handle:
        return _parse_index(handle.read())


def _parse_index(raw):
    """`_read_index` of an index's bytes: numba pickles its version, then the pickled
    (stamp, overloads)."""
    stream = io.BytesIO(raw)
    version = pickle.load(stream)
    stamp, overloads = pickle.loads(stream.read())
    if not isinstance(overloads, dict):
        raise ValueError("not a numba cache index")
    return version, stamp, overloads
