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

# submodule -> the public names it defines, imported on first use (PEP 562): importing
# flexure.fmu loads neither pythonfmu nor fmpy
_LAZY = {
    "builder": ("FMUBuildError", "build_scene_fmu", "build_slave_fmu", "default_tunable",
                "validate_fmu_file"),
    "bundle": ("bundle_name",),
    "env": ("fmu_environment",),
    "model_description": ("fix_model_description",),
    "regression": ("check_fmu", "write_reference"),
    "slave": ("SafeSlave", "escape_log"),
    "slave_variables": ("UnitReal",),
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _LAZY)
