"""Compiled code exported from one process's cache and installed into another's
(flexure.core.numerics.portable_cache): what does not fit this process is refused with the
reason; what fits is installed, its entries filed under this process's CPU, and the engine
then loads without compiling a single function. The FMU that carries such code:
tests/test_fmu_engine.py."""

import json
import os
import pickle
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import children
import pytest
from numba.core.serialize import dumps

from flexure.core.numerics import jit, portable_cache
from flexure.core.numerics.jit import package_name, sources_hash
from flexure.core.numerics.portable_cache import (
    MANIFEST,
    export_compiled,
    install_compiled,
    mismatch,
    target_description,
)

# a child run: optionally install an export into its empty cache, then a 10 ms step of the
# 1-DOF stage; it counts numba's compilations and the entry points that had to compile. Its
# numba compiles a function first, as a host using numba may have: numba's code generator is
# made for this machine's CPU before anything is installed
SIMULATE = textwrap.dedent("""
    import json, sys
    import numba
    numba.njit(lambda x: x + 1)(1)
    from numba.core import event
    from flexure.core.numerics import jit
    from flexure.core.numerics.portable_cache import export_compiled, install_compiled

    class Count(event.Listener):
        compiled = 0
        def on_start(self, ev):
            Count.compiled += 1
        def on_end(self, ev):
            pass

    event.register("numba:compile", Count())
    action, folder = sys.argv[1], sys.argv[2]
    installed = install_compiled(folder) if action == "install" else None
    from flexure.core import load_scene, simulate
    result = simulate(load_scene("stage_planar_1dof"), 0.01, inputs={"F": 1.0})
    exported = export_compiled(folder) if action == "export" else None
    print(json.dumps({"installed": installed, "exported": exported,
                      "compiled": Count.compiled + jit.compilation_notice().functions,
                      "announced": jit.compilation_notice().announced,
                      "x": result.outputs["x"].tolist()}))
""")


def child(action, folder, cache):
    done = children.run([sys.executable, "-c", SIMULATE, action, str(folder)],
                        capture_output=True, text=True, check=False,
                        env={**os.environ, "FLEXURE_CACHE_DIR": str(cache)})
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def relabel(folder, old, new):
    """File the entries of every index under `folder` of the target `old` (every target,
    when None) under `new`."""
    for index in Path(folder).rglob("*.nbi"):
        with open(index, "rb") as handle:
            version = pickle.load(handle)
            stamp, overloads = pickle.loads(handle.read())
        overloads = {(k[0], new if old is None or k[1] == old else k[1], *k[2:]): v
                     for k, v in overloads.items()}
        with open(index, "wb") as handle:
            pickle.dump(version, handle, protocol=-1)
            handle.write(dumps((stamp, overloads)))


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    """What a 10 ms step of the 1-DOF stage compiles, exported from a child whose cache is
    this session's, then made to look like a portable export: every entry filed under the
    generic CPU (the code itself is this machine's: it runs here, which is all a test of the
    filing needs; tests/test_fmu_engine.py installs real portable code)."""
    folder = tmp_path_factory.mktemp("export")
    from flexure.core.numerics.jit import cache_root

    result = child("export", folder, cache_root())
    manifest = json.loads((folder / MANIFEST).read_text())
    here = (manifest["triple"], manifest["cpu_name"], manifest["cpu_features"])
    relabel(folder, here, (manifest["triple"], "generic", ""))
    manifest.update(cpu_name="generic", cpu_features="")
    (folder / MANIFEST).write_text(json.dumps(manifest))
    return folder, result


@pytest.mark.slow
def test_installed_code_is_loaded_without_compiling(export, tmp_path):
    folder, exported = export
    manifest = json.loads((folder / MANIFEST).read_text())
    assert manifest["functions"] >= 1 and manifest["not_cached"] == []
    assert list(folder.rglob("engine.rhs_entry-*.nbi"))  # what CVODE's callback calls
    assert manifest["package"] == package_name() == "flexure"
    cache = tmp_path / "cache"
    installed = child("install", folder, cache)
    ok, message = installed["installed"]
    assert ok, message
    assert message.startswith(f"installed the compiled code of {manifest['functions']} "
                              "functions (built for the CPU target 'generic')")
    assert installed["compiled"] == 0 and not installed["announced"]
    assert installed["x"] == pytest.approx(exported["x"], rel=1e-12, abs=1e-18)
    # filed under this machine's CPU, as this process's numba looks it up
    here = target_description()
    index = next((cache / package_name() / sources_hash()[:20]).rglob("*.nbi"))
    with open(index, "rb") as handle:
        pickle.load(handle)
        _, overloads = pickle.loads(handle.read())
    # (a cache that other targets also wrote, as under .ci/second_cpu_target, keeps theirs)
    assert (here["triple"], here["cpu_name"], here["cpu_features"]) in {
        key[1] for key in overloads}
    # the same export again: nothing to do, the cache keeps what it has
    again = child("install", folder, cache)
    assert again["installed"][1].startswith("installed the compiled code of 0 functions")
    assert f"{manifest['functions']} were there already" in again["installed"][1]


def test_the_same_files_unfiled_for_this_cpu_compile(export, tmp_path):
    """The count above can see a compilation: the same files copied into the cache as they
    are, filed under a CPU target this process is not (the generic one; and under no real
    one, where .ci/second_cpu_target makes this process generic and its cache holds the
    host's too), are not found by this process's numba, and the engine announces that it
    compiles (the child is stopped then: it would take a minute)."""
    folder, _ = export
    copy = tmp_path / package_name() / sources_hash()[:20]
    shutil.copytree(folder, copy, ignore=shutil.ignore_patterns(MANIFEST))
    if target_description()["cpu_name"] == "generic":
        relabel(copy, None, (target_description()["triple"], "no-such-cpu", ""))
    with subprocess.Popen([sys.executable, "-c", SIMULATE, "none", str(folder)],
                          env={**os.environ, "FLEXURE_CACHE_DIR": str(tmp_path)},
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True) as run:
        try:
            first = children.lines_until(run, run.stderr, lambda line: True, 120)[0]
        finally:
            run.kill()
    assert first.startswith("flexure: compiling its engine for "), first


def test_an_index_that_cannot_be_read_is_named_and_the_rest_installed(export, tmp_path):
    folder, _ = export
    broken = tmp_path / "broken"
    shutil.copytree(folder, broken)
    index = sorted(broken.rglob("*.nbi"))[0]
    index.write_bytes(b"not a pickle")
    ok, message = install_compiled(broken, tmp_path / "cache")
    functions = json.loads((folder / MANIFEST).read_text())["functions"]
    assert ok and f"of {functions - 1} functions" in message
    assert message.endswith(f"1 could not be read and will compile: "
                            f"{index.relative_to(broken)} (UnpicklingError)")


def write_index(path, overloads):
    """A numba cache index naming `overloads` ({key: data file name})."""
    with open(path, "wb") as handle:
        pickle.dump("0.0", handle, protocol=-1)
        handle.write(dumps(((0.0, 0), overloads)))


def test_an_index_rewritten_during_the_export_is_carried_as_it_was_read(tmp_path, monkeypatch):
    """Another process compiling into the cache while an export copies it (as a test
    worker or a second command may) adds an overload: numba writes its data file, then the
    index. The export carries each index as it read it with the data files that one names,
    so that every index it carries installs."""
    cache, export = tmp_path / "cache", tmp_path / "export"
    cache.mkdir()
    index = cache / "module.function-1.py311.nbi"
    first = {("(float64,)", ("triple", "cpu", ""), "hash"): "module.function-1.py311.1.nbc"}
    write_index(index, first)
    (cache / "module.function-1.py311.1.nbc").write_bytes(b"code")
    monkeypatch.setattr(jit, "package_cache_folder", lambda: str(cache))
    monkeypatch.setattr(jit, "cache_index_path", lambda function: str(index))
    monkeypatch.setattr(portable_cache, "compiled_functions", lambda: [write_index])
    copy, compiled_meanwhile = shutil.copyfile, []

    def copy_while_another_process_compiles(source, target, **options):
        if not compiled_meanwhile:
            (cache / "module.function-1.py311.2.nbc").write_bytes(b"other code")
            write_index(index, {**first, ("(int64,)", ("triple", "cpu", ""), "hash"):
                                "module.function-1.py311.2.nbc"})
            compiled_meanwhile.append(source)
        return copy(source, target, **options)

    monkeypatch.setattr(shutil, "copyfile", copy_while_another_process_compiles)
    manifest = export_compiled(export)
    assert compiled_meanwhile and manifest["functions"] == 1 and manifest["files"] == 2
    with open(export / index.name, "rb") as handle:
        pickle.load(handle)
        _, overloads = pickle.loads(handle.read())
    assert overloads == first
    monkeypatch.setattr(shutil, "copyfile", copy)
    ok, message = install_compiled(export, tmp_path / "installed")
    assert ok and message.startswith("installed the compiled code of 1 functions"), message
    assert "could not be read" not in message


@pytest.mark.parametrize("change, says", [
    ({"numba": "0.0.1"}, "it was compiled for numba 0.0.1; this Python has numba "),
    ({"python": "3.99"}, "it was compiled for python 3.99; this Python has python "),
    ({"numpy": "1.0.0"}, "it was compiled for numpy 1.0.0; this Python has numpy "),
    ({"machine": "riscv64"}, "it was compiled for machine riscv64; this Python has machine "),
    ({"cpu_name": "znver3", "cpu_features": "+avx2"},
     "it was compiled for the CPU 'znver3', not for a portable target"),
    ({"package": "_flexure_000000000000"}, "it belongs to another copy of flexure (package "),
    ({"sources": "0" * 64}, "it belongs to another copy of flexure (sources "),
    ({"format": 2}, "its manifest.json is of format 2; this flexure reads format 1"),
])
def test_an_export_that_does_not_fit_this_process_is_refused(tmp_path, change, says):
    manifest = {"format": 1, **target_description(), "cpu_name": "generic",
                "cpu_features": "", "package": package_name(), "sources": sources_hash()}
    assert mismatch(manifest) is None
    (tmp_path / MANIFEST).write_text(json.dumps({**manifest, **change}))
    ok, message = install_compiled(tmp_path, tmp_path / "cache")
    assert not ok and message.startswith(says), message
    assert not (tmp_path / "cache").exists()


@pytest.mark.parametrize("text, says", [
    (None, "its manifest.json cannot be read (FileNotFoundError: "),
    ("{not json", "its manifest.json cannot be read (JSONDecodeError: "),
    ("[1, 2]", "its manifest.json is not a JSON object"),
])
def test_a_manifest_that_cannot_be_read_is_refused(tmp_path, text, says):
    if text is not None:
        (tmp_path / MANIFEST).write_text(text)
    ok, message = install_compiled(tmp_path, tmp_path / "cache")
    assert not ok and message.startswith(says), message


def test_a_cache_folder_that_cannot_be_written_is_refused(export, tmp_path):
    folder, _ = export
    (tmp_path / "file").write_text("")
    ok, message = install_compiled(folder, tmp_path / "file" / "cache")
    assert not ok
    assert message == (f"the cache folder {tmp_path / 'file' / 'cache'} cannot be written "
                       "(Not a directory)")
