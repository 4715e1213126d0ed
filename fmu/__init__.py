"""flexure.fmu: every scene as an FMI 2.0 co-simulation FMU (pythonfmu), and the tools to build
any flexure slave as one.

    from flexure.fmu import build_scene_fmu
    build_scene_fmu("stage_planar_3dof", "stage_planar_3dof.fmu")

- `build_scene_fmu(scene, dest, *, tunable=None, overrides=None)`: a scene's FMU (`flexure fmu
  build`), of the scene with `overrides` {dotted key: value} if given.
- `build_slave_fmu(script, dest, *, project_files=(), bundle=("core", "fmu"))`: any pythonfmu
  slave script (e.g. a controller) with flexure bundled and the model description completed.
- `SafeSlave`, `UnitReal`: the base of a slave whose failures become FMI statuses.
- `fix_model_description(xml)`: units, UnitDefinitions, InitialUnknowns, variabilities.
- `fmu_environment()`: what a non-Python host needs (`flexure fmu env`).
- `check_fmu(fmu, in_csv, ref_csv)`, `write_reference(...)`: FMI cross-check style regression
  tests (`flexure fmu check`).
"""

from flexure.core.lazy_imports import lazy_exports

# public name -> the submodule that defines it, imported on first use (PEP 562): importing
# flexure.fmu loads neither pythonfmu nor fmpy
_LAZY = {
    "FMUBuildError": "builder", "build_scene_fmu": "builder", "build_slave_fmu": "builder",
    "bundle_name": "bundle", "default_tunable": "builder", "validate_fmu_file": "builder",
    "fmu_environment": "env",
    "fix_model_description": "model_description",
    "check_fmu": "regression", "write_reference": "regression",
    "SafeSlave": "slave", "UnitReal": "slave_variables", "escape_log": "slave",
}

__all__ = [
    "FMUBuildError", "SafeSlave", "UnitReal", "build_scene_fmu", "build_slave_fmu",
    "bundle_name", "check_fmu", "default_tunable", "escape_log", "fix_model_description",
    "fmu_environment", "validate_fmu_file", "write_reference",
]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
