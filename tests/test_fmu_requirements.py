"""A self-describing FMU: its Python requirements inside it, a readable line when the host's
Python lacks one, only the platforms tried, a unit on every variable (`flexure fmu doctor`:
test_fmu_doctor.py).

The requirements are checked against what the slave really imports (an import hook in a fresh
interpreter, every integrator method stepped), and the missing-requirement line against a real
host: fmpy in a child Python whose `import threadpoolctl` fails (a sitecustomize on its path).
"""

import json
import os
import sys
import textwrap
import zipfile
from xml.etree import ElementTree as ET

import children
import pytest
from cli_runs import run
from fmpy import read_model_description

from flexure.core.elements import section_keys
from flexure.core.scene.building import NODE_KEYS, scene_key
from flexure.core.scene.sections import CALCULATORS
from flexure.fmu import (
    FMUBuildError,
    build_slave_fmu,
    validate_fmu_file,
)
from flexure.fmu.builder import TRIED_PLATFORMS
from flexure.fmu.model_description import BASE_UNITS
from flexure.fmu.pythonfmu_workarounds import PYTHONFMU_LOGGER_LAYOUTS, log_to_host
from flexure.fmu.requirements import (
    RUNTIME_IMPORTS,
    Requirement,
    Requirements,
    at_least,
    format_requirements,
    parse_requirements,
    runtime_requirements,
)
from flexure.fmu.scene_slave import METHODS

SCENE = "stage_planar_1dof"
# beyond the defaults, section dimensions and a modulus, whose units the slave does not give
GEOMETRY = ["sections.leaf.height", "sections.leaf.width", "sections.leaf.E"]


def requirements_of(path):
    with zipfile.ZipFile(path) as archive:
        return parse_requirements(archive.read("resources/requirements.txt").decode())


# -- what the FMU says it needs ---------------------------------------------------------------

IMPORT_PROBE = textwrap.dedent("""
    import builtins, importlib, json, sys, tempfile, zipfile
    path, methods = sys.argv[1], json.loads(sys.argv[2])
    folder = tempfile.mkdtemp()
    zipfile.ZipFile(path).extractall(folder)
    resources = folder + "/resources"
    module_name = open(resources + "/slavemodule.txt").read().strip()
    imported, original = set(), builtins.__import__

    def recording(name, globals=None, locals=None, fromlist=(), level=0):
        importer = (globals or {}).get("__name__", "")
        # the FMU's own copy, or the identical installed flexure standing in for it
        if level == 0 and (importer.startswith(("_flexure_", "flexure."))
                           or importer == module_name):
            imported.add(name.split(".")[0])
        return original(name, globals, locals, fromlist, level)

    import importlib.util
    find_spec = importlib.util.find_spec

    def finding(name, package=None):
        # a package whose files the core needs without importing it (SUNDIALS' libraries
        # beside sksundae) is a requirement too; the FMU's own check of its requirements
        # (fmu/requirements.py) finds every one of them, and is not counted
        caller = sys._getframe(1).f_globals.get("__name__", "")
        if ".core." in caller and "." not in name:
            imported.add(name)
        return find_spec(name, package)

    builtins.__import__ = recording
    importlib.util.find_spec = finding
    sys.path.insert(0, resources)
    module = importlib.import_module(module_name)
    slave_class = getattr(module, module_name.rsplit("_", 1)[0])
    loaded_by_esdirk = None
    for method in methods:
        slave = slave_class(instance_name="probe", resources=resources)
        vr = next(r for r, v in slave.vars.items() if v.name == "integrator.method")
        slave.set_string([vr], [method])
        slave.setup_experiment(0.0)
        slave.enter_initialization_mode()
        slave.exit_initialization_mode()
        assert slave.do_step(0.0, 1e-3) and not slave.broken, (method, slave.log_queue)
        if loaded_by_esdirk is None:
            loaded_by_esdirk = sorted(m for m in sys.modules if m.split(".")[0] == "sksundae")
    builtins.__import__, importlib.util.find_spec = original, find_spec
    outside = sorted(name for name in imported if name not in sys.stdlib_module_names
                     and not name.startswith("_flexure_")
                     and name not in ("flexure", "pythonfmu"))
    print(json.dumps([outside, loaded_by_esdirk]))
""")


def test_the_requirements_are_what_the_slave_imports(stage_fmu):
    """Every module the bundled flexure and the slave script import while a scene FMU is
    instantiated and stepped with each integrator method, outside the standard library, the
    FMU's own package and pythonfmu (shipped inside): exactly the requirements' modules."""
    probe = children.run([sys.executable, "-c", IMPORT_PROBE, str(stage_fmu),
                          json.dumps(list(METHODS))], capture_output=True, text=True,
                         timeout=300)
    assert probe.returncode == 0, probe.stderr[-2000:]
    imported, loaded_by_esdirk = json.loads(probe.stdout.splitlines()[-1])
    # the check before the slave finds each requirement without running it: an FMU stepped
    # by the default ESDIRK never imports scikit-sundae (0.6 s)
    assert METHODS[0] == "esdirk" and loaded_by_esdirk == []
    requirements = requirements_of(stage_fmu)
    # scipy: only a large model's sparse ordering analysis imports it (numerics/sparse_lu.py);
    # a small scene's FMU starts without it
    assert imported == sorted(item.module for item in requirements.items
                              if item.module != "scipy")
    assert [(i.distribution, i.module) for i in requirements.items] == list(
        RUNTIME_IMPORTS["core"])
    assert {i.module for i in requirements.items} == {"numpy", "scipy", "numba", "llvmlite",
                                                      "threadpoolctl", "sksundae"}


def test_the_requirements_are_pinned_in_the_file_and_the_model_description(stage_fmu):
    import importlib.metadata

    requirements = requirements_of(stage_fmu)
    assert requirements.python == "3.11"  # pyproject's requires-python
    # flexure declares no llvmlite of its own: numba brings the one it needs
    declared = {"numpy": "1.26", "scipy": "1.11", "numba": "0.60", "llvmlite": None,
                "threadpoolctl": "3.1", "scikit-sundae": "1.1"}
    for item in requirements.items:
        assert item.version == importlib.metadata.version(item.distribution)
        assert item.minimum == declared[item.distribution]
    with zipfile.ZipFile(stage_fmu) as archive:
        text = archive.read("resources/requirements.txt").decode()
        root = ET.fromstring(archive.read("modelDescription.xml"))
    pins = [line.split()[0] for line in text.splitlines() if line and line[0] != "#"]
    assert pins == [item.pin() for item in requirements.items]  # what pip reads
    assert root.get("description").endswith(
        "Needs in the host's Python (resources/requirements.txt): Python >= 3.11, "
        + ", ".join(pins))
    listed = root.find("VendorAnnotations/Tool[@name='flexure']/PythonRequirements")
    assert listed.get("python") == ">=3.11"
    assert [(r.get("distribution"), r.get("version"), r.get("module"), r.get("minimum"))
            for r in listed] == [(i.distribution, i.version, i.module, i.minimum)
                                 for i in requirements.items]
    assert validate_fmu_file(stage_fmu) == []


def test_pip_reads_the_requirements_file(stage_fmu, tmp_path):
    """`pip install -r requirements.txt` (dry run, offline: everything is installed here)."""
    with zipfile.ZipFile(stage_fmu) as archive:
        (tmp_path / "requirements.txt").write_bytes(archive.read("resources/requirements.txt"))
    pip = children.run([sys.executable, "-m", "pip", "install", "--dry-run", "--no-index",
                        "-r", str(tmp_path / "requirements.txt")], capture_output=True,
                       text=True, timeout=120)
    assert pip.returncode == 0, pip.stderr
    for item in requirements_of(stage_fmu).items:
        assert f"Requirement already satisfied: {item.pin()}" in pip.stdout


def test_only_the_platforms_tried_are_in_the_fmu(stage_fmu, tmp_path):
    with zipfile.ZipFile(stage_fmu) as archive:
        binaries = [n for n in archive.namelist() if n.startswith("binaries/")]
    assert TRIED_PLATFORMS == ("linux64",)
    assert binaries == [f"binaries/linux64/{SCENE}.so"]  # pythonfmu also ships win64
    with pytest.raises(FMUBuildError, match="no binary for the platforms darwin64"):
        build_slave_fmu(_tiny_script(tmp_path), tmp_path / "mac.fmu", platforms=["darwin64"])
    assert not (tmp_path / "mac.fmu").exists()


TINY_SLAVE = textwrap.dedent("""
    import os

    from flexure.fmu.slave import SafeSlave


    class TinyProbe(SafeSlave):
        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.y = 1.0
            self.add_real("y", causality="output", unit="m")

        def advance(self, t, h):
            pass
""")


def _tiny_script(tmp_path):
    script = tmp_path / "tiny_slave_probe.py"
    script.write_text(TINY_SLAVE)
    return script


def test_runtime_requirements_of_other_bundles_and_extra_distributions():
    own = runtime_requirements((), ["control"])
    assert [(i.distribution, i.module) for i in own.items] == [("flexure", "flexure"),
                                                               ("control", "control")]
    assert own.items[1].minimum == "0.10"  # flexure declares control>=0.10
    mapped = runtime_requirements(("core", "fmu"), ["scikit-sundae"])
    assert [i.distribution for i in mapped.items] == [d for d, _ in RUNTIME_IMPORTS["core"]]
    with pytest.raises(ValueError, match="'no-such-dist': no such distribution is installed"):
        runtime_requirements(("fmu",), ["no-such-dist"])
    with pytest.raises(FMUBuildError, match="no such distribution is installed"):
        build_slave_fmu(__file__, "x.fmu", requirements=["no-such-dist"])


def test_the_requirements_file_round_trips_and_a_bad_line_is_named():
    requirements = Requirements("3.11", (Requirement("numpy", "2.1.0", "numpy", "1.26"),
                                         Requirement("scikit-sundae", "1.2", "sksundae")))
    text = format_requirements(requirements, "first line\n\nthird")
    assert text.splitlines()[:3] == ["# first line", "#", "# third"]
    assert parse_requirements(text) == requirements
    with pytest.raises(ValueError, match=r"r.txt, line 2: expected 'NAME==VERSION  # import "
                                         r"MODULE; needs >=MINIMUM', got 'numpy>=1'"):
        parse_requirements("# python >= 3.11\nnumpy>=1\n", "r.txt")
    assert at_least("1.26.0rc1", "1.26") and at_least("2", "1.26.4")
    assert not at_least("1.25.9", "1.26") and not at_least("0.59", "0.60")


# -- a host whose Python lacks a requirement ---------------------------------------------------

HOST = textwrap.dedent("""
    import json, sys
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
    path = sys.argv[1]
    md = read_model_description(path)
    results, binaries = {}, []
    for logging_on in (False, True):  # debug logging off, then on
        logs = []
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(
            lambda env, name, status, category, message: logs.append(
                [status, name.decode(), message.decode()]))
        folder = extract(path)
        identifier = md.coSimulation.modelIdentifier
        binaries.append(f"{folder}/binaries/linux64/{identifier}.so")
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=folder, instanceName="host_a",
                        modelIdentifier=identifier)
        try:
            fmu.instantiate(callbacks=callbacks, loggingOn=logging_on)
            outcome = "instantiated"
        except Exception as error:
            outcome = str(error)
        results["on" if logging_on else "off"] = {"outcome": outcome, "logs": logs}
    # the binaries whose interpreter guard the bundled flexure releases at exit
    # (the bundled flexure may stand in under two names: one module)
    guarded = sorted({p for name, module in list(sys.modules.items())
                      if name.endswith(".fmu.pythonfmu_workarounds")
                      for p in module.guarded_binaries()})
    print(json.dumps({"runs": results, "binaries": binaries, "guarded": guarded}))
""")

BLOCK_THREADPOOLCTL = textwrap.dedent("""
    import sys

    class NoThreadpoolctl:  # this Python "lacks" threadpoolctl
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] == "threadpoolctl":
                raise ImportError(f"No module named {name!r}", name=name)

    sys.meta_path.insert(0, NoThreadpoolctl())
""")


def without_threadpoolctl(tmp_path):
    (tmp_path / "sitecustomize.py").write_text(BLOCK_THREADPOOLCTL)
    return {**os.environ, "PYTHONPATH": str(tmp_path), "TMPDIR": str(tmp_path)}  # fmpy unzips


def test_a_host_without_a_requirement_logs_one_line_naming_it(stage_fmu, tmp_path):
    """fmpy in a child Python without threadpoolctl instantiates the FMU with debug logging off,
    then on (each from a folder of its own), and exits cleanly. (With every requirement, the
    same FMU instantiates: test_fmu.py, and test_fmu_doctor.py.)"""
    host = children.run([sys.executable, "-c", HOST, str(stage_fmu)], capture_output=True,
                        text=True, timeout=300, env=without_threadpoolctl(tmp_path))
    assert host.returncode == 0, host.stderr[-2000:]
    printed = json.loads(host.stdout.splitlines()[-1])
    results = printed["runs"]
    # each failed instance's binary is guarded against pythonfmu's double release at exit
    # ("corrupted double-linked list" after the host's last line, now and then)
    assert sorted(printed["guarded"]) == sorted(printed["binaries"])
    pin = next(i.pin() for i in requirements_of(stage_fmu).items
               if i.distribution == "threadpoolctl")
    for logging_on, result in results.items():
        assert result["outcome"] == "Failed to instantiate model"
        status, name, line = result["logs"][0]
        assert (status, name) == (3, "host_a") and "\n" not in line
        assert line.startswith(f"{SCENE} cannot run in this Python: threadpoolctl is missing "
                               "(import threadpoolctl: ImportError: No module named "
                               "'threadpoolctl'); install into this Python")
        assert f"python -m pip install '{pin}'" in line and "requirements.txt" in line
        # with debug logging off the host hears that line only; with it on, pythonfmu's
        # fatal message follows (the exception, carrying the same line)
        assert len(result["logs"]) == (1 if logging_on == "off" else 2)
    assert results["on"]["logs"][1][0] == 4 and line in results["on"]["logs"][1][2]


# the tiny slave, and then an error as its script runs in a host without what it needs
FAILS_IN_HOST = TINY_SLAVE.replace("TinyProbe", "FailsInHost") + textwrap.dedent("""

    if os.environ.get("BREAK_SLAVE"):
        raise RuntimeError("broken on purpose")
""")


def test_a_slave_script_that_fails_in_the_host_is_named_and_its_binary_guarded(tmp_path):
    """The launcher turns the script's error into a stand-in: fmi2Instantiate fails with one
    line naming the script's line and error, and the host exits cleanly with the binary
    guarded (pythonfmu's fatal error alone left it unguarded: a crash at exit, now and then)."""
    script = tmp_path / "FailsInHost.py"
    script.write_text(FAILS_IN_HOST)
    path = build_slave_fmu(script, tmp_path / "FailsInHost.fmu")
    host = children.run([sys.executable, "-c", HOST, str(path)], capture_output=True,
                        text=True, timeout=300,
                        env={**os.environ, "BREAK_SLAVE": "1", "TMPDIR": str(tmp_path)})
    assert host.returncode == 0, host.stderr[-2000:]
    printed = json.loads(host.stdout.splitlines()[-1])
    assert sorted(printed["guarded"]) == sorted(printed["binaries"])
    line = FAILS_IN_HOST.splitlines().index('    raise RuntimeError("broken on purpose")') + 1
    for result in printed["runs"].values():
        assert result["outcome"] == "Failed to instantiate model"
        assert result["logs"][0] == [3, "host_a", "FailsInHost: its slave script failed as it "
                                     f"ran (FailsInHost.slave.py, line {line}): RuntimeError: "
                                     "broken on purpose"]


def test_a_slave_script_that_fails_at_build_raises_its_own_error(tmp_path, monkeypatch):
    script = tmp_path / "FailsAtBuild.py"
    script.write_text(FAILS_IN_HOST.replace("FailsInHost", "FailsAtBuild"))
    monkeypatch.setenv("BREAK_SLAVE", "1")
    with pytest.raises(RuntimeError, match="broken on purpose") as raised:
        build_slave_fmu(script, tmp_path / "FailsAtBuild.fmu")
    assert raised.traceback[-1].path == script  # the script's own line, not the launcher's
    assert not (tmp_path / "FailsAtBuild.fmu").exists()


def test_the_host_logger_is_called_only_for_the_known_pythonfmu_binary(tmp_path):
    import hashlib

    import pythonfmu

    binary = (os.path.dirname(pythonfmu.__file__)
              + "/resources/binaries/linux64/libpythonfmu-export.so")
    with open(binary, "rb") as handle:  # a new pythonfmu: check its logger's layout first
        assert hashlib.sha256(handle.read()).hexdigest() in PYTHONFMU_LOGGER_LAYOUTS
    (tmp_path / "binaries" / "linux64").mkdir(parents=True)
    (tmp_path / "binaries" / "linux64" / "m.so").write_bytes(b"another binary")
    kwargs = {"logger": 12345, "instance_name": "a", "resources": str(tmp_path / "resources")}
    assert log_to_host(kwargs, "not read") is False  # unknown binary: no memory is read
    assert log_to_host({**kwargs, "logger": None}, "not read") is False


# -- units --------------------------------------------------------------------------------------

def test_every_numeric_scene_key_has_a_unit():
    sections = set(section_keys()) | {key.name for calculator in CALCULATORS.values()
                                      for key in calculator.inputs}
    keys = ([f"sections.s.{name}" for name in sections]
            + [f"nodes.n.{name}" for name in NODE_KEYS] + ["elements.e.segments"])
    units = {key: scene_key(key).unit for key in keys}
    assert set(units.values()) <= set(BASE_UNITS), units


def test_tunable_geometry_gets_its_unit(stage_fmu):
    units = {v.name: v.unit for v in read_model_description(str(stage_fmu)).modelVariables}
    assert units["sections.leaf.height"] == units["sections.leaf.width"] == "m"
    assert units["sections.leaf.E"] == "Pa"
    assert [name for name, unit in units.items() if not unit] == [
        "integrator.method", "integrator.max_steps"]  # not Reals: FMI 2.0 gives them none



def test_the_launcher_runs_again_without_a_new_class_even_when_its_folder_is_gone(stage_fmu,
                                                                                   tmp_path):
    """What pythonfmu's binary does at every instantiation: run the slave script again in the
    namespace of its first import, with fresh locals. The launcher carries the script and the
    requirements as text, so the first import's folder may be gone (a host that unpacks each
    instance anew and removes it); the slave class is looked up, not created again."""
    import importlib
    import shutil

    folder = tmp_path / "unpacked"
    with zipfile.ZipFile(stage_fmu) as archive:
        archive.extractall(folder)
    resources = str(folder / "resources")
    name = (folder / "resources" / "slavemodule.txt").read_text().strip()
    text = (folder / "resources" / f"{name}.py").read_text()
    sys.path.insert(0, resources)
    try:
        module = importlib.import_module(name)
        cls = getattr(module, SCENE)
        bundled = cls.__base__.__module__.rsplit(".", 1)[0]  # _flexure_<hash>.fmu
        marker = importlib.import_module(f"{bundled}.pythonfmu_workarounds").SlaveMarker
        shutil.rmtree(folder)
        classes = len(cls.__base__.__subclasses__())  # SceneSlave's, of every scene loaded
        for _ in range(2):
            local_namespace = {}
            exec(compile(text, name, "exec"), module.__dict__, local_namespace)
            assert local_namespace == {SCENE: marker}
            assert getattr(module, SCENE) is cls
        assert len(cls.__base__.__subclasses__()) == classes  # none created
    finally:
        sys.path.remove(resources)
        sys.modules.pop(name, None)


def test_fmu_env_says_what_a_native_host_needs(capsys):
    code, out, _ = run(capsys, "fmu", "env")
    lines = out.splitlines()
    # in a venv its folder is the host's user site as well, so that the .pth files of its
    # site-packages (an editable flexure's) run in the embedded interpreter
    venv = ["export PYTHONUSERBASE"] if sys.prefix != sys.base_prefix else []
    exports = [line.split("=")[0] for line in lines if line.startswith("export ")]
    assert code == 0 and exports == [
        "export LD_PRELOAD", "export PYTHONHOME", "export PYTHONPATH", *venv]
    assert all(line.startswith("# ") for line in lines[len(exports):])
    if venv:
        assert f"export PYTHONUSERBASE='{sys.prefix}'" in lines
    assert "resources/requirements.txt" in out and "flexure fmu doctor FMU --native" in out
