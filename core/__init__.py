"""flexure.core: SPACAR-style flexible multibody models and their analyses.

    from flexure.core import load_scene, static_equilibrium, natural_frequencies
    model = load_scene("stage_planar_3dof")          # a file path or a built-in scene name
    natural_frequencies(model).frequencies_hz        # Hz, at the static equilibrium

The public names are imported on first use (PEP 562): `import flexure.core` loads neither
numpy, scipy, the element modules nor SUNDIALS, so that a command such as `flexure --help`
and a package that only needs the exceptions start fast. `from flexure.core import X` and
`flexure.core.X` work for every name of `__all__`, and `dir(flexure.core)` lists them.
"""

from .errors import ConstraintError, ConvergenceError, FlexureError, SceneError, SimulationError
from .lazy_imports import lazy_exports

__version__ = "0.1.0"

# public name -> the submodule that defines it (imported by __getattr__ on first use)
_LAZY = {
    "Compliance": "analysis.compliance", "compliance": "analysis.compliance",
    "InverseStatics": "analysis.inverse_statics", "inverse_statics": "analysis.inverse_statics",
    "LinearModel": "analysis.linearization", "linearize": "analysis.linearization",
    "Modes": "analysis.modal", "buckling_load_factors": "analysis.modal",
    "natural_frequencies": "analysis.modal",
    "principal_gains": "analysis.statespace", "state_space": "analysis.statespace",
    "StaticSolution": "analysis.statics", "static_equilibrium": "analysis.statics",
    "beam_stresses": "analysis.stresses", "stresses_along": "analysis.stresses",
    "check_exact_constraint": "mechanics.constraints", "choose_dofs": "mechanics.constraints",
    "proposed_releases": "mechanics.constraints",
    "Kinematics": "mechanics.kinematics",
    "Mechanics": "mechanics.mechanics",
    "steady_port_values": "mechanics.actuators", "steady_slopes": "mechanics.actuators",
    "input_columns": "mechanics.ports", "input_values": "mechanics.ports",
    "output_rows": "mechanics.ports", "output_value": "mechanics.ports",
    "port_description": "mechanics.ports",
    "Model": "model",
    "blas_threads": "numerics.blas",
    "apply_overrides": "scene.overrides",
    "build_model": "scene.building", "builtin_scenes": "scene.building",
    "load_scene": "scene.building", "scene_path": "scene.building",
    "scene_toml": "scene.scene_writer",
    "read_spacar": "scene.spacar_input",
    "Scene": "scene.api", "to_toml": "scene.api",
    "controller_step": "simulation.sampled_loop", "run_sampled_loop": "simulation.sampled_loop",
    "LinearSimulator": "simulation.linear_simulator",
    "SimulationResult": "simulation.simulation", "Simulator": "simulation.simulation",
    "simulate": "simulation.simulation",
    "METHODS": "simulation.simulator", "prepare": "simulation.prepare",
    "default_atol": "simulation.tolerances",
}

__all__ = [
    "Compliance", "ConstraintError", "ConvergenceError", "FlexureError", "InverseStatics",
    "Kinematics", "inverse_statics",
    "LinearModel", "LinearSimulator", "METHODS",
    "Mechanics", "Model", "Modes", "blas_threads", "SceneError", "SimulationError",
    "SimulationResult",
    "Simulator", "StaticSolution", "apply_overrides", "beam_stresses", "buckling_load_factors",
    "build_model",
    "builtin_scenes", "check_exact_constraint", "choose_dofs", "compliance", "default_atol",
    "input_columns", "input_values", "output_rows", "output_value", "port_description",
    "linearize", "load_scene", "proposed_releases", "read_spacar", "Scene", "to_toml",
    "natural_frequencies", "controller_step", "prepare", "principal_gains", "run_sampled_loop",
    "scene_path", "scene_toml",
    "simulate",
    "state_space", "static_equilibrium", "steady_port_values", "steady_slopes",
    "stresses_along",
]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
