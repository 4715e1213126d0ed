"""The copy of flexure an FMU carries, and when the host's identical flexure stands in for it.

An FMU bundles flexure as `_flexure_<hash of the sources>`; in a host whose own flexure has
those sources, the bundle's modules are the host's (one set of modules, one compiled-code
cache). Checked: the stand-in in a fresh interpreter, the bundle's own copy when the sources
differ or FLEXURE_FMU_OWN_COPY is set, and (slow: it compiles the copy's engine) the same
numbers from both.
"""

import json
import os
import sys
import textwrap
import zipfile

import children
import pytest

from flexure.fmu import build_scene_fmu, bundle_name
from flexure.fmu.bundle import write_bundle

SCENE = "stage_planar_3dof"

# in a fresh interpreter: import the bundle's model module from `folder`, say where it lives
WHICH_COPY = textwrap.dedent("""
    import importlib, json, sys
    folder, package = sys.argv[1], sys.argv[2]
    sys.path.insert(0, folder)
    bundle = importlib.import_module(package)
    model = importlib.import_module(package + ".core.model")
    print(json.dumps([bundle.STANDS_IN, model.__name__, model.__file__,
                      model.__spec__.name]))
""")


def which_copy(folder, package, own_copy=False):
    env = dict(os.environ)
    env.pop("FLEXURE_FMU_OWN_COPY", None)
    if own_copy:
        env["FLEXURE_FMU_OWN_COPY"] = "1"
    run = children.run([sys.executable, "-c", WHICH_COPY, str(folder), package],
                       capture_output=True, text=True, timeout=120, env=env)
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout.splitlines()[-1])


def test_the_identical_installed_flexure_stands_in_for_the_bundle(tmp_path):
    import flexure.core.model

    package = write_bundle(tmp_path).name
    assert package == bundle_name(("core", "fmu"))
    stands_in, name, file, spec_name = which_copy(tmp_path, package)
    assert stands_in is True
    # the installed module itself, its own spec kept (not the alias's)
    assert (name, spec_name) == ("flexure.core.model", "flexure.core.model")
    assert os.path.samefile(file, flexure.core.model.__file__)


def test_the_bundle_runs_its_own_copy_when_asked_to(tmp_path):
    package = write_bundle(tmp_path).name
    stands_in, name, file, _ = which_copy(tmp_path, package, own_copy=True)
    assert stands_in is False and name == f"{package}.core.model"
    assert os.path.commonpath([file, str(tmp_path)]) == str(tmp_path)


def test_the_bundle_runs_its_own_copy_when_the_installed_sources_differ(tmp_path):
    """A bundle of other sources than the installed flexure's (here: its parts list says
    controllers too, so the installed sources hash to another name) never stands in."""
    root = write_bundle(tmp_path)
    init = root / "__init__.py"
    text = init.read_text()
    assert "\nPARTS = ('core', 'fmu')" in text
    init.write_text(text.replace("\nPARTS = ('core', 'fmu')",
                                 "\nPARTS = ('core', 'fmu', 'controllers')"))
    stands_in, name, file, _ = which_copy(tmp_path, root.name)
    assert stands_in is False and name == f"{root.name}.core.model"
    assert os.path.commonpath([file, str(tmp_path)]) == str(tmp_path)


def test_a_scene_fmu_carries_a_bundle_named_by_its_sources(tmp_path):
    fmu = build_scene_fmu(SCENE, tmp_path / f"{SCENE}.fmu")
    with zipfile.ZipFile(fmu) as archive:
        tops = {n.split("/")[1] for n in archive.namelist() if n.startswith("resources/_flex")}
        init = archive.read(f"resources/{bundle_name(('core', 'fmu'))}/__init__.py").decode()
    assert tops == {bundle_name(("core", "fmu"))}
    assert "\nPARTS = ('core', 'fmu')" in init


STEP_FMU = textwrap.dedent("""
    import json, sys
    import fmpy
    result = fmpy.simulate_fmu(sys.argv[1], stop_time=0.05, output_interval=1e-3,
                               start_values={"F": 1.0})
    print(json.dumps([[float(v) for v in row] for row in result]))
""")


@pytest.mark.slow
def test_the_own_copy_and_the_stand_in_give_the_same_numbers(tmp_path):
    """The FMU stepped by fmpy in two fresh interpreters, once on the installed flexure and
    once on its own copy (whose engine compiles into its own cache): bit for bit equal."""
    fmu = build_scene_fmu(SCENE, tmp_path / f"{SCENE}.fmu")
    results = []
    for own_copy in ("", "1"):
        env = {**os.environ, "FLEXURE_FMU_OWN_COPY": own_copy}
        run = children.run([sys.executable, "-c", STEP_FMU, str(fmu)], capture_output=True,
                           text=True, timeout=600, env=env)
        assert run.returncode == 0, run.stderr[-2000:]
        results.append(json.loads(run.stdout.splitlines()[-1]))
    assert len(results[0]) == 51 and results[0] == results[1]
    assert max(abs(row[1]) for row in results[0]) > 1e-6  # the stage moved under the 1 N
