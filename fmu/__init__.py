"""flexure.fmu: every scene as an FMI 2.0 co-simulation FMU (pythonfmu), and the tools to build
any flexure slave as one.

    from flexure.fmu import build_scene_fmu
    build_scene_fmu("stage_planar_3dof", "stage_planar_3dof.fmu")

- `build_scene_fmu(scene, dest, *, tunable=None)`: a scene's FMU (`flexure fmu build`).
- `build_slave_fmu(script, dest, *, project_files=(), bundle=("core", "fmu"))`: any pythonfmu
  slave script (e.g. a controller) with flexure bundled and the model description completed.
- `SafeSlave`, `UnitReal`: the base of a slave whose failures become FMI statuses.
- `fix_model_description(xml)`: units, UnitDefinitions, InitialUnknowns, variabilities.
- `fmu_environment()`: what a non-Python host needs (`flexure fmu env`).
- `check_fmu(fmu, in_csv, ref_csv)`, `write_reference(...)`: FMI cross-check style regression
  tests (`flexure fmu check`).
"""

from .builder import (
    FMUBuildError,
    build_scene_fmu,
    build_slave_fmu,
    bundle_name,
    default_tunable,
    validate_fmu_file,
)
from .env import fmu_environment
from .model_description import fix_model_description
from .regression import check_fmu, write_reference
from .slave import SafeSlave, UnitReal, escape_log

__all__ = [
    "FMUBuildError", "SafeSlave", "UnitReal", "build_scene_fmu", "build_slave_fmu",
    "bundle_name", "check_fmu", "default_tunable", "escape_log", "fix_model_description",
    "fmu_environment", "validate_fmu_file", "write_reference",
]
