"""Building scene FMUs and the `flexure fmu` command line (build, check, env), and the
regression references: <scene>_in.csv drives the FMU, <scene>_ref.csv is what it must give."""

import json
import zipfile

import pytest
from fmpy import read_model_description
from fmpy_slave import SCENES

from flexure.core import scene_path
from flexure.fmu import FMUBuildError, build_scene_fmu
from flexure.fmu.regression import check_fmu, compare, read_csv

# -- build and command line ------------------------------------------------------------------


def test_build_rejects_an_unknown_tunable_key(tmp_path):
    with pytest.raises(FMUBuildError, match="sections.leaf.EdX.*does not declare it"):
        build_scene_fmu("stage_planar_3dof", tmp_path / "x.fmu",
                        tunable=["sections.leaf.EdX"])


def test_cli_build_check_and_env(tmp_path, capsys):
    from flexure.core.cli import main

    fmu = tmp_path / "truss.fmu"
    assert main(["fmu", "build", "truss_1dof_x", "-o", str(fmu), "--no-tunable"]) == 0
    assert str(fmu) in capsys.readouterr().out
    md = read_model_description(str(fmu))
    assert [v.name for v in md.modelVariables if v.causality == "parameter"] == [
        "integrator.method", "integrator.rtol", "integrator.atol", "integrator.max_steps"]
    scenes = scene_path("truss_1dof_x").parent
    inputs, reference = scenes / "truss_1dof_x_in.csv", scenes / "truss_1dof_x_ref.csv"
    assert main(["fmu", "check", str(fmu), str(inputs), str(reference)]) == 0
    assert "matches" in capsys.readouterr().out
    changed = tmp_path / "changed_ref.csv"
    changed.write_text(_shifted_reference(reference))
    assert main(["fmu", "check", str(fmu), str(inputs), str(changed)]) == 1
    assert "x: max |error|" in capsys.readouterr().out
    assert main(["fmu", "build", "truss_1dof_x", "-o", str(fmu), "--tunable",
                 "nodes.9.mass"]) == 2
    error = capsys.readouterr().err
    assert "nodes.9.mass" in error and "Traceback" not in error
    assert main(["fmu", "check", str(fmu), str(tmp_path / "none_in.csv"), str(reference)]) == 2
    assert "none_in.csv: no such file" in capsys.readouterr().err
    assert main(["fmu", "env", "--json"]) == 0
    values = json.loads(capsys.readouterr().out)
    assert "libpython3" in values["LD_PRELOAD"] and "site-packages" in values["PYTHONPATH"]
    # The printed environment is what a shell (and the JVM test) uses.
    assert main(["fmu", "env"]) == 0
    assert capsys.readouterr().out.startswith("export LD_PRELOAD=")
    with zipfile.ZipFile(fmu) as archive:  # flexure travels inside, under a hashed name
        names = archive.namelist()
    assert any(n.startswith("resources/_flexure_") and n.endswith("core/simulation/simulation.py")
               for n in names)


def _shifted_reference(path):
    """The reference CSV with x moved by 1 mm at the last sample."""
    lines = path.read_text().splitlines()
    time, value = lines[-1].split(",")
    lines[-1] = f"{time},{float(value) + 1e-3!r}"
    return "\n".join(lines) + "\n"


# -- regression references -------------------------------------------------------------------


@pytest.mark.parametrize("scene", SCENES)
def test_regression_reference(scene, scene_fmus):
    """FMI cross-check style: <scene>_in.csv drives the FMU, <scene>_ref.csv is what it gave
    when the reference was written; every output within 1e-5 of its range + 1e-8."""
    folder = scene_path(scene).parent
    problems = check_fmu(scene_fmus(scene), folder / f"{scene}_in.csv",
                         folder / f"{scene}_ref.csv")
    assert problems == []


def test_regression_compare_reports_a_changed_signal():
    reference = read_csv(scene_path("truss_1dof_x").parent / "truss_1dof_x_ref.csv")
    changed = reference.copy()
    assert compare(changed, reference) == []
    changed["x"][50] += 1e-4 * (reference["x"].max() - reference["x"].min()) + 1e-8
    (problem,) = compare(changed, reference)
    assert problem.startswith("x: max |error|") and "t = 0.05 s" in problem


def test_regression_tolerance_catches_a_one_percent_change(scene_fmus):
    """1 % more mass on the truss (a tunable parameter) must fail the regression test."""
    from flexure.fmu.regression import simulate

    scene = "truss_1dof_x"
    path = scene_fmus(scene)
    folder = scene_path(scene).parent
    mass = float(next(v.start for v in read_model_description(str(path)).modelVariables
                      if v.name == "nodes.2.mass"))
    result = simulate(path, folder / f"{scene}_in.csv",
                      start_values={"nodes.2.mass": 1.01 * mass})
    (problem,) = compare(result, read_csv(folder / f"{scene}_ref.csv"))
    assert problem.startswith("x: max |error|")
