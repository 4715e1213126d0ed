"""Start-up: `import flexure.core` (and of flexure.controllers, flexure.fmu) stays cheap.

The heavy packages (python-control and matplotlib 0.5 s each, numba 0.3 s, scikit-sundae,
fmpy, libcosimpy) are imported where they are used, and the public names of each package on
first use (PEP 562). These are structural checks in a fresh interpreter, not timings.
"""

import json
import sys

import children
import pytest
from cli_runs import warm_command_modules

HEAVY = ("control", "matplotlib", "fmpy", "libcosimpy", "numba", "sksundae")


def loaded_after(code):
    """The top-level packages of HEAVY (and numpy, scipy) in sys.modules after `code`."""
    probe = (f"{code}\nimport json, sys\n"
             f"print(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}} & "
             f"{set(HEAVY) | {'numpy', 'scipy'}!r})))")
    completed = children.run([sys.executable, "-c", probe], capture_output=True, text=True,
                             check=True)
    return set(json.loads(completed.stdout.splitlines()[-1]))


def test_import_core_loads_no_heavy_package():
    loaded = loaded_after("import flexure.core")
    assert not loaded & set(HEAVY), f"import flexure.core imported {sorted(loaded)}"
    assert not loaded & {"numpy", "scipy"}, f"import flexure.core imported {sorted(loaded)}"


@pytest.mark.parametrize("package", ["flexure.controllers", "flexure.fmu"])
def test_import_subpackages_loads_no_heavy_package(package):
    loaded = loaded_after(f"import {package}")
    assert not loaded & set(HEAVY), f"import {package} imported {sorted(loaded)}"


def test_analysis_loads_no_control_matplotlib_or_fmu():
    loaded = loaded_after("from flexure.core import load_scene, natural_frequencies\n"
                          "natural_frequencies(load_scene('truss_1dof_x'))")
    assert not loaded & {"control", "matplotlib", "fmpy", "libcosimpy"}, sorted(loaded)


@pytest.mark.parametrize("arguments", [["analyze", "truss_1dof_x"],
                                       ["analyze", "stage_planar_1dof", "--static", "--json"]])
def test_the_analyze_command_imports_no_numba(arguments):
    """Statics and modes run in numpy: an element module declares its compiled kernels
    without importing numba (numerics/jit.py's `Kernel`), which costs about 0.2 s of CPU."""
    loaded = loaded_after(f"from flexure.core.cli import main\nmain({arguments!r})")
    assert "numba" not in loaded, f"flexure {' '.join(arguments)} imported numba"


def test_a_kernel_is_compiled_where_another_kernel_calls_it():
    """A `Kernel` called from compiled code is typed as numba's dispatcher, made then."""
    from flexure.core.numerics.jit import kernel

    def twice(x):
        return 2.0 * x

    inner = kernel(twice, cache=False)
    assert not inner.is_made

    def outer_function(x):
        return inner(x) + 1.0

    outer = kernel(outer_function, cache=False)
    assert outer(3.0) == 7.0 and inner.is_made and len(inner.signatures) == 1


@pytest.mark.parametrize("package", ["flexure.core", "flexure.controllers", "flexure.fmu"])
def test_every_public_name_resolves_and_is_listed(package):
    module = __import__(package, fromlist=["__all__"])
    assert set(module.__all__) <= set(dir(module))
    for name in module.__all__:
        assert getattr(module, name) is not None, name
    namespace = {}
    exec(f"from {package} import *", namespace)
    assert set(module.__all__) <= set(namespace)
    with pytest.raises(AttributeError):
        module.no_such_name  # noqa: B018


def test_a_name_listed_under_two_submodules_is_refused():
    from flexure.core.lazy_imports import lazy_exports

    with pytest.raises(ValueError, match="^pkg: 'Model' is listed under both 'model' and "
                                         "'scene.api'$"):
        lazy_exports("pkg", {"model": ("Model",), "scene.api": ("Scene", "Model")})


def test_submodules_still_import_through_the_package():
    from flexure.core import elements
    from flexure.core.mechanics import assembly

    assert hasattr(assembly, "__file__") and hasattr(elements, "ELEMENT_TYPES")


def test_a_command_imports_only_its_own_subcommand():
    # `flexure analyze` must not pay for the loop's imports (scipy.interpolate, the
    # co-simulation), nor the FMU's
    probe = ("import json, sys\nfrom flexure.core.cli import build_parser\n"
             "build_parser(['analyze', 'truss_1dof_x'])\n"
             "print(json.dumps(sorted(m for m in sys.modules if m.startswith("
             "('flexure.controllers', 'flexure.fmu')))))")
    completed = children.run([sys.executable, "-c", probe], capture_output=True, text=True,
                             check=True)
    assert json.loads(completed.stdout.splitlines()[-1]) == []


def test_the_bare_command_still_lists_every_subcommand(capsys):
    from flexure.core.cli import main

    assert main([]) == 1  # the help, and exit code 1
    listed = capsys.readouterr().out
    for command in ("analyze", "bench", "fmu", "import", "loop", "reduce", "simulate", "sweep"):
        assert f"    {command} " in listed, command


def test_a_simulation_finds_sundials_without_importing_sksundae():
    """CVODE and IDA come from the shared libraries scikit-sundae's wheel ships; importing
    the package itself would cost 0.3 s of CPU (scipy.optimize) for nothing."""
    loaded = loaded_after("from flexure.core import load_scene, simulate\n"
                          "simulate(load_scene('truss_1dof_x'), 1e-3, method='cvode-bdf')")
    assert "numba" in loaded and "sksundae" not in loaded, sorted(loaded)


def test_sundials_missing_is_named(monkeypatch):
    import importlib.util

    from flexure.core.simulation import sundials_libraries

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *args: None if name == "sksundae" else real(name, *args))
    with pytest.raises(ImportError, match="scikit-sundae is not installed: flexure needs its "
                                          "SUNDIALS libraries"):
        sundials_libraries.library_folder()


@pytest.mark.parametrize(("arguments", "plot"), [
    (["loop", "--no-plot"], False),
    (["loop", "stage_planar_3dof", "--no-plot", "--json"], False),
    (["loop", "--plot", "PLOT"], True),
])
def test_the_loop_command_imports_neither_python_control_nor_scipy_signal(
        arguments, plot, tmp_path):
    """The designed loop computes its controller, delays, closed-loop poles and margins with
    numpy (controllers/lti.py, robustness.py, spline.py): a whole `flexure loop` run, with or
    without its plot, ends with python-control, scipy.signal, scipy.interpolate,
    scipy.optimize and the FMU packages not imported; nor SUNDIALS' compiled callbacks,
    which its ESDIRK integrator does not call; nor numba, when the engine's entries load as
    object code (the second run: the first may load through numba, which writes them)."""
    png = tmp_path / "loop.png"
    arguments = [str(png) if a == "PLOT" else a for a in arguments]
    code, stdout, loaded = warm_command_modules(arguments, (
        "m.split('.')[0] in ('control', 'fmpy', 'pythonfmu', 'libcosimpy', 'sksundae') "
        "or m.split('.')[:2] in (['scipy', 'signal'], ['scipy', 'interpolate'], "
        "['scipy', 'optimize']) or m.endswith('.simulation.sundials') "
        "or m in ('numba', 'numba.core')"), tmp_path)
    assert code == 0, stdout
    assert loaded == [], f"flexure {' '.join(arguments)} imported {loaded}"
    assert png.is_file() == plot


def test_a_short_simulation_imports_neither_scipy_linalg_nor_scipy_sparse(tmp_path):
    """A warm `flexure simulate` of a small scene needs no scipy: the packing orders its
    matrices in plain Python (numerics/graph_orders.py), the constraint check's condition
    number and the default atol's frequency come from numpy and the engine, the cached engine
    loads without numba's registry refresh (numerics/jit.py) and names no numba module that
    imports scipy.linalg. Each would cost 0.1 to 0.3 s of CPU of a 10 ms run."""
    code, stdout, loaded = warm_command_modules(
        ["simulate", "stage_planar_3dof", "--t-end", "0.01", "--input", "F=1"],
        "m.split('.')[:2] in (['scipy', 'linalg'], ['scipy', 'sparse']) "
        "or m.startswith('numba.np.linalg')", tmp_path)
    assert code == 0, stdout
    assert loaded == [], f"flexure simulate imported {loaded}"


@pytest.mark.parametrize("method", ["cvode-bdf", "ida", "esdirk"])
def test_a_warm_short_simulation_imports_no_numba(tmp_path, method):
    """A warm `flexure simulate` loads the engine's entries as object code (numerics/
    object_code.py) and restarts its integrator through C entries (`restart_plant_now`,
    `cvode_restart_now`, `esdirk_entry.restart_now`): numba, 0.15 s of CPU to import, is not
    imported at all, nor llvmlite's IR builder's users (numba's intrinsics)."""
    code, stdout, loaded = warm_command_modules(
        ["simulate", "stage_planar_3dof", "--t-end", "0.005", "--input", "F=1", "--method",
         method],
        "m.split('.')[0] == 'numba' and m.count('.') < 2 and not m.startswith('numba._')",
        tmp_path)
    assert code == 0, stdout
    assert loaded == [], f"flexure simulate --method {method} imported {loaded}"


def test_the_subcommands_are_read_from_flexures_own_entry_points():
    """`flexure` reads its subcommands from its distribution's entry_points.txt (no
    importlib.metadata); the same as importlib.metadata lists, and only its section's."""
    import importlib.metadata

    from flexure.core.cli import entry_points_of, entry_points_section

    expected = {(e.name, e.value) for e in importlib.metadata.entry_points(
        group="flexure.commands")}
    assert set(entry_points_of("flexure.commands")) == expected
    text = ("[console_scripts]\nflexure = flexure.core.cli:main\n\n[flexure.commands]\n"
            "# a comment\nanalyze = flexure.core.cli.analyze:register\n"
            "loop=flexure.controllers.cli:register\n[other]\nx = y:z\n")
    assert entry_points_section(text, "flexure.commands") == [
        ("analyze", "flexure.core.cli.analyze:register"),
        ("loop", "flexure.controllers.cli:register")]


def test_a_linear_simulator_imports_no_python_control():
    """The linear plant needs A, B, C, D alone (`state_space_matrices`): building a
    LinearSimulator loads neither python-control nor matplotlib."""
    loaded = loaded_after("from flexure.core import LinearSimulator, load_scene\n"
                          "LinearSimulator(load_scene('stage_planar_3dof'))")
    assert "numpy" in loaded and not loaded & {"control", "matplotlib"}, sorted(loaded)


@pytest.mark.parametrize("arguments", [
    ["simulate", "manipulator_control", "--t-end", "0.001", "--input", "F1=1"],
    ["analyze", "manipulator_reduced", "--static", "--set", "nodes.E.force=[0, 0, 1]"],
])
def test_a_warm_command_on_a_sparse_model_imports_no_numba(tmp_path, arguments):
    """Packing a model whose J and augmented system are sparse (the manipulators) factors
    each candidate ordering from Python (`sparse_lu.StaticLU`): through a C entry
    (`sparse_lu_entry.factor_now`), so that a warm run loads it as object code and imports no
    numba (0.3 to 0.7 s of CPU: half of a short simulation of manipulator_control)."""
    code, stdout, loaded = warm_command_modules(
        arguments, "m.split('.')[0] == 'numba' and m.count('.') < 2 "
        "and not m.startswith('numba._')", tmp_path)
    assert code == 0, stdout
    assert loaded == [], f"flexure {' '.join(arguments)} imported {loaded}"
