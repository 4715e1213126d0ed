"""Build FMI 2.0 co-simulation FMUs with pythonfmu: any slave script, or a scene.

How an FMU carries "the code it needs"
-------------------------------------
A pythonfmu FMU runs in the host's Python (or, in a non-Python host, in the libpython that is
preloaded), so the packages the bundled flexure imports must be installed there: the FMU lists
them, pinned, in resources/requirements.txt and its model description, checks them before its
slave runs (`flexure.fmu.requirements`; `flexure fmu doctor` checks them from the command
line; `flexure fmu env` prints what a non-Python host needs). flexure itself is *bundled*:
the FMU's resources hold a copy of the flexure packages it uses (`core`, the runtime part of
`fmu`, and on request `controllers`) under the package name `_flexure_<hash>`, where the hash
is taken over the bundled sources (`flexure.fmu.bundle`). The slave script's `flexure` imports
are rewritten to that name. So:

- an FMU does not depend on the flexure version installed in the host, and keeps giving the
  results it was built (and regression-tested) with;
- FMUs built from the same flexure sources share one bundled package in a process (same name,
  same code: harmless), FMUs built from different sources get different names and do not mix;
- in a host whose own flexure has the bundle's sources, that flexure stands in for the bundle
  (`bundle_init.py`): the same code, without a second compilation of the engine;
- every slave script is a module of its own name (a scene FMU's is `<scene>_<hash>`), because
  pythonfmu imports the script by name and Python caches modules per process: two FMUs with
  the same script name would silently share the first one's class.

The model identifier is the slave class name (pythonfmu's rule); for a scene it is the scene
name, so FMUs of different scenes coexist in one process.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import tempfile
import zipfile
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from flexure.core import FlexureError

from .bundle import bundle_name, rewrite_imports, write_bundle
from .model_description import fix_model_description
from .pythonfmu_binary import RECORD, choose_binary, record
from .requirements import FILE_NAME, format_requirements, runtime_requirements

# The platforms whose binaries an FMU keeps: those flexure's FMUs were run on (docs/fmu.md).
# pythonfmu 0.7.0 ships binaries for linux64 and win64 and copies both into every FMU.
TRIED_PLATFORMS = ("linux64",)

# The slave script pythonfmu's binary imports (resources/<stem>.py): it checks the FMU's
# requirements (flexure.fmu.requirements) before the slave script proper runs in its namespace
# and locals, as if it were this file. Both travel as text in it: pythonfmu's binary runs it
# again at every instantiation, in the namespace of the first import, whose unpacked folder
# may be gone by then. The slave script is also shipped as <stem>.slave.py, the file its
# tracebacks name.
LAUNCHER = '''"""The slave script of this FMU, written by flexure's FMU builder.

It checks that this Python has what the FMU imports ({requirements}), installs the compiled
engine the FMU carries (resources/flexure-engine, where it fits this Python), then runs the
slave script {source} (a copy of it is beside this file); if something is missing, or the
script fails as it runs, the slave class is a stand-in that logs what and fails.
"""

from {package}.fmu.compiled_engine import install as _install_engine
from {package}.fmu.requirements import failed_script as _failed_script
from {package}.fmu.requirements import stand_in as _stand_in
from {package}.fmu.requirements import unmet_requirements as _unmet_requirements

_REQUIREMENTS = {requirements_text!r}
_SOURCE = {source_text!r}

_unmet = _unmet_requirements(_REQUIREMENTS, __file__)
if _unmet is None:
    _install_engine(__file__, {package!r})  # the compiled engine it carries, if it fits here
    try:
        exec(compile(_SOURCE, __file__[: -len(".py")] + ".slave.py", "exec"), globals(),
             locals())
    except Exception as _error:  # noqa: BLE001 -- named by the stand-in, not fatal
        ScriptFailed = _failed_script(_error, __file__, locals())
else:
    MissingRequirements = _stand_in(_unmet)
'''


# Appended to every slave script (see flexure.fmu.pythonfmu_workarounds.keep_script_namespace).
KEEP_NAMESPACE = """

# Added by flexure's FMU builder: works around pythonfmu 0.7.0 releasing this namespace, and
# leaking what it finds in the locals of its re-execution of this script.
from flexure.fmu.pythonfmu_workarounds import (  # noqa: E402
    keep_script_namespace as _keep_script_namespace,
)

_keep_script_namespace(globals(), locals())
"""


def _run_once(script_path):
    """Run the slave script once, here, so that an error in it is raised by the build with the
    script's own traceback. In the FMU the launcher turns such an error into a stand-in that
    names it in the host's log (`requirements.failed_script`): pythonfmu's build, which
    imports the launcher, would then only say that it found no slave class."""
    code = compile(script_path.read_text(), str(script_path), "exec")
    exec(code, {"__name__": f"{script_path.stem}_checked", "__file__": str(script_path)})


def _requirements_header(bundle):
    from flexure.core import __version__

    what = (f"the flexure {__version__} bundled in it ({', '.join(bundle)})" if bundle
            else "its slave script")
    return (f"The Python packages this FMU imports: {what}.\n"
            f"Pinned to the versions it was built with (Python "
            f"{'.'.join(map(str, sys.version_info[:3]))} on {' '.join(TRIED_PLATFORMS)}); "
            "install them into "
            "the Python\nthat runs the FMU:  python -m pip install -r requirements.txt\n"
            "A version at or above the one after 'needs' works too: `flexure fmu doctor "
            "FMU` checks.")


def build_slave_fmu(script_path: str | Path, dest: str | Path, *,
                    project_files: Iterable[str | Path] = (),
                    bundle: Iterable[str] = ("core", "fmu"), validate: bool = True,
                    requirements: Iterable[str] = (),
                    platforms: Iterable[str] = TRIED_PLATFORMS,
                    units: Mapping[str, str] | None = None,
                    pythonfmu_binary: str | None = None, **options: Any) -> Path:
    """Build an FMI 2.0 co-simulation FMU from a pythonfmu slave script.

    Parameters
    ----------
    script_path : str or Path
        A Python file with one `Fmi2Slave` subclass (usually a `flexure.fmu.slave.SafeSlave`
        subclass). Its class name is the model identifier; give the file a name no other
        FMU in the same process uses. Its `flexure` imports are rewritten to the bundle.
    dest : str or Path
        The .fmu file to write, or a directory (the file is then `<class name>.fmu`).
    project_files : iterable of path, optional
        More files or folders to ship in resources/ (pythonfmu's project_files).
    bundle : tuple of str, optional
        Which flexure packages to bundle: any of "core", "fmu", "controllers"; () for none
        (then the host's Python must have flexure installed).
    validate : bool, optional
        Run fmpy's validation and raise `FMUBuildError` listing the problems.
    requirements : iterable of str, optional
        Distributions the script itself imports beyond what the bundle needs, each
        "DISTRIBUTION" or "DISTRIBUTION:MODULE" (e.g. "control"); pinned to their installed
        versions in resources/requirements.txt with the bundle's own
        (`flexure.fmu.requirements`), and checked before the slave is instantiated.
    platforms : iterable of str, optional
        The platforms whose pythonfmu binaries the FMU keeps (default `TRIED_PLATFORMS`,
        those flexure's FMUs were run on); pythonfmu copies all it has.
    units : dict, optional
        {variable name: unit} for Real variables the slave declares without a unit.
    pythonfmu_binary : str, optional
        "auto": flexure's corrected build of pythonfmu's binary where it fits, else the stock
        one (`flexure.fmu.pythonfmu_binary`); "corrected": that build or an FMUBuildError;
        "stock": pythonfmu's own. Default: the environment variable FLEXURE_FMU_BINARY, else
        "auto". The FMU records which in resources/pythonfmu-binary.json.
    **options
        pythonfmu's CoSimulation flags; state get/set and serialisation default to True.

    Returns
    -------
    Path
        The FMU written.

    Raises
    ------
    FMUBuildError
        An unknown bundle part, a script pythonfmu cannot build, no binary for the
        platforms, an unknown `pythonfmu_binary` or a corrected one asked for that does not
        fit, or (with `validate`) the problems fmpy's validation reports.
    """
    from pythonfmu import FmuBuilder

    script_path = Path(script_path)
    try:  # chosen first: a refusal costs no build
        binaries = {platform: choose_binary(platform, pythonfmu_binary)
                    for platform in platforms}
    except ValueError as error:
        raise FMUBuildError(f"{script_path}: {error}") from None
    options.setdefault("canGetAndSetFMUstate", True)
    options.setdefault("canSerializeFMUstate", True)
    bundle = tuple(bundle)
    for part in bundle:
        if part not in ("core", "fmu", "controllers"):
            raise FMUBuildError(f"bundle: unknown flexure package {part!r}; expected core, "
                                "fmu or controllers")
    if bundle and "fmu" not in bundle:  # the slave base and the namespace workaround
        bundle += ("fmu",)
    try:
        needs = runtime_requirements(bundle, requirements)
    except ValueError as error:
        raise FMUBuildError(f"{script_path}: {error}") from None
    _run_once(script_path)
    # pythonfmu imports the script by its name to find the class: a module of that name
    # already loaded in this process (another FMU's) would be taken instead. Set it aside.
    shadowed = sys.modules.pop(script_path.stem, None)
    modules_before = set(sys.modules)
    path_before = list(sys.path)
    with tempfile.TemporaryDirectory(prefix="flexure_fmu_") as temp:
        source = Path(temp) / "src"
        source.mkdir()
        files = [Path(p) for p in project_files]
        package = None
        if bundle:
            package_dir = write_bundle(source, tuple(bundle))
            package = package_dir.name
            files.append(package_dir)
        listed = format_requirements(needs, _requirements_header(bundle))
        (source / FILE_NAME).write_text(listed)
        files.append(source / FILE_NAME)
        text = script_path.read_text()
        script = source / script_path.name
        if package:  # the launcher checks the requirements, then runs the script
            text = rewrite_imports(text, package)
            (source / f"{script_path.stem}.slave.py").write_text(text)
            files.append(source / f"{script_path.stem}.slave.py")
            launcher = LAUNCHER.format(package=package, source=f"{script_path.stem}.slave.py",
                                       requirements=FILE_NAME, requirements_text=listed,
                                       source_text=text)
            script.write_text(launcher + rewrite_imports(KEEP_NAMESPACE, package))
        else:
            script.write_text(text + KEEP_NAMESPACE)
        try:
            built = Path(FmuBuilder.build_FMU(script, dest=dest, project_files=files,
                                              **options))
        finally:
            # pythonfmu imported the script and the bundle from the temporary folder and
            # left that folder on sys.path: forget both, so a later import finds the FMU's
            # own resources instead.
            for name in set(sys.modules) - modules_before:
                module = sys.modules[name]
                if str(getattr(module, "__file__", "") or "").startswith(temp) or (
                        package and name.startswith(package)):
                    del sys.modules[name]
            sys.path[:] = path_before
            if shadowed is not None:
                sys.modules[script_path.stem] = shadowed
    _patch_model_description(built, requirements=needs, units=units, binaries=binaries)
    if validate:
        problems = validate_fmu_file(built)
        if problems:
            raise FMUBuildError(f"{built}: fmpy validate reports: " + "; ".join(problems))
    return built


def validate_fmu_file(path: str | Path) -> list[str]:
    """fmpy's validation problems of an FMU.

    Parameters
    ----------
    path : str or Path
        The .fmu file.

    Returns
    -------
    list of str
        The problems; empty when the FMU is valid.
    """
    from fmpy.validation import validate_fmu

    return [str(p) for p in validate_fmu(str(path))]


def _patch_model_description(path, *, requirements=None, units=None, binaries):
    """Rewrite the FMU zip with a completed modelDescription.xml (its requirements and the
    missing units added), the binaries of the platforms `binaries` names only, each the
    corrected build where `binaries` says so, and resources/pythonfmu-binary.json saying
    which."""
    path = Path(path)
    temporary = path.with_suffix(".fmu.tmp")
    kept, stock_sha256 = [], {}
    with zipfile.ZipFile(path) as source, zipfile.ZipFile(
            temporary, "w", compression=zipfile.ZIP_DEFLATED) as target:
        for item in source.infolist():
            parts = item.filename.split("/")
            data = source.read(item.filename)
            if parts[0] == "binaries" and len(parts) > 2:
                if parts[1] not in binaries:
                    continue
                kept.append(parts[1])
                stock_sha256[parts[1]] = hashlib.sha256(data).hexdigest()
                if binaries[parts[1]].data is not None:
                    data = binaries[parts[1]].data
            if item.filename == "modelDescription.xml":
                data = fix_model_description(data, requirements=requirements, units=units)
            target.writestr(item, data)
        chosen = {platform: binaries[platform] for platform in kept}
        target.writestr(f"resources/{RECORD}", record(chosen, stock_sha256))
    if not kept:
        temporary.unlink()
        path.unlink()
        raise FMUBuildError(f"{path}: pythonfmu has no binary for the platforms "
                            f"{', '.join(binaries) or '(none given)'}")
    shutil.move(temporary, path)


class FMUBuildError(FlexureError):
    """An FMU could not be built or does not validate."""


def default_tunable(scene: Mapping[str, Any]) -> list[str]:
    """The scene keys a scene FMU exposes as parameters by default.

    Damping (EdA, EdI of every section that declares it), which a user fits to measurements,
    and every key the scene marks tunable in `[scene] tunable` (e.g. a payload mass).

    Parameters
    ----------
    scene : mapping
        The scene dictionary.

    Returns
    -------
    list of str
        Dotted scene keys ("sections.leaf.EdA" in N s, "nodes.3.mass" in kg).
    """
    keys = []
    for name, section in scene.get("sections", {}).items():
        keys += [f"sections.{name}.{k}" for k in ("EdA", "EdI") if k in section]
    marked = scene.get("scene", {}).get("tunable", [])
    return keys + [key for key in marked if key not in keys]


def build_scene_fmu(scene: str | Path, dest: str | Path | None = None, *,
                    tunable: Iterable[str] | None = None,
                    von_mises: bool = False, validate: bool = True,
                    overrides: dict | None = None, engine: bool | None = None,
                    pythonfmu_binary: str | None = None) -> Path:
    """Build the co-simulation FMU of a scene.

    Parameters
    ----------
    scene : str or Path
        A scene file or the name of a built-in scene.
    dest : str or Path, optional
        The .fmu file to write, or a directory; default `<scene name>.fmu` here.
    tunable : iterable of str, optional
        Dotted scene keys to expose as parameters (each must be a number the scene file
        declares, e.g. "sections.leaf.EdA", "nodes.3.mass"); default `default_tunable`.
    von_mises : bool, optional
        Add the output "von_mises_max" (Pa), the largest von Mises stress at the ends of the
        beams; the scene needs beams or trusses whose section gives its dimensions.
    validate : bool, optional
        Run fmpy's validation on the result.
    overrides : dict, optional
        {dotted scene key: value} set on the scene first (`flexure.core.load_scene`); the FMU
        carries the scene with them, written by `flexure.core.scene_toml`.
    engine : bool, optional
        Put the engine into the FMU, compiled for a portable CPU target
        (`flexure.fmu.portable_engine`): a host with the same Python, numpy and numba then
        loads it instead of compiling for a minute at its first instantiation. It compiles
        here once per version of flexure (about a minute of CPU; later builds load it, about
        2 s) and adds about 0.7 MB (docs/fmu.md). Default: True, unless the environment
        variable FLEXURE_FMU_ENGINE is "0" (for FMUs run only where flexure is installed,
        e.g. a test suite's: that flexure runs in place of the FMU's copy).
    pythonfmu_binary : str, optional
        Which pythonfmu binary the FMU carries: "auto", "corrected" or "stock"
        (`build_slave_fmu`).

    Returns
    -------
    Path
        The FMU written; its model identifier is the scene name.

    Raises
    ------
    FMUBuildError
        A scene that cannot be read, a name that cannot be a model identifier, a tunable key
        the scene does not declare or that is not a number, a von Mises output without
        beams, or a build or validation failure.
    SceneError
        The scene (with its overrides) does not build.
    ConstraintError
        The model is not exactly constrained.
    """
    import keyword

    from flexure.core import FlexureError, apply_overrides, build_model, scene_path, scene_toml
    from flexure.core.scene.building import parse_toml
    from flexure.core.scene.overrides import describe_overrides

    from .scene_slave import scene_value

    path = scene_path(scene)
    try:  # a TOML scene or a SPACAR input file (.dat), as load_scene reads them
        data = parse_toml(path)
    except FlexureError as error:
        raise FMUBuildError(str(error)) from None
    model = build_model(data, overrides=overrides, source=str(path), default_name=path.stem)
    if model.kinematic_inputs and model.actuators:  # the engine takes one or the other
        raise FMUBuildError(f"{path}: the kinematic inputs "
                            f"{', '.join(p.name for p in model.kinematic_inputs)} and the "
                            f"actuators {', '.join(a.name for a in model.actuators)}: a time "
                            "simulation takes kinematic inputs only without actuators; no FMU "
                            "of this scene")
    # the FMU carries the scene it was built from: the file's own text where it is TOML as
    # given, otherwise the scene written back (an imported SPACAR file, overrides)
    if path.suffix.lower() == ".toml" and not overrides:
        text = path.read_text()
    else:
        if overrides:
            data = apply_overrides(data, overrides, source=str(path))
        with_overrides = f" with {describe_overrides(overrides)}" if overrides else ""
        text = scene_toml(data, f"{path.name}{with_overrides}")
    name = model.name
    if keyword.iskeyword(name) or name.startswith("_"):
        raise FMUBuildError(f"{path}: scene.name: {name!r} cannot be an FMU model identifier "
                            "(a Python keyword or a leading underscore); rename the scene")
    tunable = default_tunable(data) if tunable is None else list(tunable)
    for key in tunable:
        try:
            value = scene_value(data, key)
        except KeyError:
            raise FMUBuildError(f"{path}: tunable key {key!r}: the scene does not declare it "
                                f"(expected e.g. {', '.join(default_tunable(data)) or 'none'})"
                                ) from None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise FMUBuildError(f"{path}: tunable key {key!r}: expected a number, got "
                                f"{value!r}")
    if von_mises:
        _check_stresses(model, path)
    package = bundle_name(("core", "fmu"))
    digest = hashlib.sha256(
        f"{package}\0{text}\0{tunable}\0{name}\0{von_mises}".encode()).hexdigest()[:10]
    dest = Path(f"{name}.fmu") if dest is None else Path(dest)
    with tempfile.TemporaryDirectory(prefix="flexure_scene_") as temp:
        script = Path(temp) / f"{name}_{digest}.py"
        script.write_text(scene_script(name, text, tunable, von_mises))
        built = build_slave_fmu(script, dest, validate=validate,
                                pythonfmu_binary=pythonfmu_binary)
    if engine is None:
        engine = os.environ.get("FLEXURE_FMU_ENGINE", "").strip() != "0"
    if engine:
        from .portable_engine import add_compiled_engine

        add_compiled_engine(built)
    return built


def _check_stresses(model, path):
    """FMUBuildError unless the model has beams whose stresses can be computed."""
    import numpy as np

    from flexure.core import beam_stresses

    # which beams have a section is the model's: any configuration and resultants name them
    names = beam_stresses(model, model.initial_coordinates,
                          np.zeros(len(model.deformation_names))).names
    if not names:
        raise FMUBuildError(f"{path}: von Mises output: the scene has no beam or truss whose "
                            "section gives its dimensions (width and height, or diameter), so "
                            "there is no stress to report")


def scene_script(name: str, text: str, tunable: tuple[str, ...], von_mises: bool) -> str:
    """The Python source of a scene's slave module, as the FMU carries it.

    Parameters
    ----------
    name : str
        The slave class's name (the script's stem); a scene without [scene] name takes it.
    text : str
        The scene's TOML text.
    tunable : tuple of str
        The scene keys the FMU exposes as parameters.
    von_mises : bool
        Whether the FMU reports the largest von Mises stress.

    Returns
    -------
    str
    """
    # pythonfmu's binary executes this script again at every instantiation, in the module's
    # namespace with fresh locals: there the class is looked up instead of being created anew.
    # A new class is cyclic garbage once the appended footer drops it (about 4 kB for
    # truss_1dof_x, waiting for the garbage collector: 0.25 MB of RSS over the 1000 cycles of
    # tests/test_fmu_memory.py's leak case).
    return (
        f'"""FMU slave of the flexure scene {name} (generated by flexure fmu build)."""\n\n'
        # Import the module, not the class: pythonfmu's binary looks for the slave class
        # among the classes in this module's namespace, and must find only this one.
        "from flexure.fmu import scene_slave\n\n"
        f"if {name!r} in globals():  # a re-execution by pythonfmu's binary: no new class\n"
        f"    {name} = globals()[{name!r}]\n"
        "else:\n"
        f"    class {name}(scene_slave.SceneSlave):\n"
        f"        scene_toml = {text!r}\n"
        f"        tunable = {tuple(tunable)!r}\n"
        f"        von_mises = {bool(von_mises)!r}\n"
    )
