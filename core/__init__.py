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

# submodule -> the public names it defines (imported by __getattr__ on first use)
_LAZY = {
    "analysis.compliance": ("Compliance", "compliance"),
    "analysis.inverse_dynamics": ("InverseDynamics", "inverse_dynamics", "sampled_path"),
    "analysis.inverse_dynamics_free": ("free_inverse_dynamics", "zero_dynamics"),
    "analysis.inverse_statics": ("InverseStatics", "inverse_statics"),
    "analysis.linearization": ("LinearModel", "linearize"),
    "analysis.modal": ("Modes", "buckling_load_factors", "natural_frequencies"),
    "analysis.motion_response": ("MotionResponse", "motion_response"),
    "analysis.motion_statespace": ("MotionStateSpace", "motion_state_space"),
    "analysis.optimize": ("Optimum", "optimize"),
    "analysis.sensitivity": ("Sensitivities", "sensitivities"),
    "analysis.statespace": ("principal_gains", "state_space", "state_space_matrices",
                            "static_gain"),
    "analysis.statics": ("StaticSolution", "static_equilibrium"),
    "analysis.stresses": ("beam_stresses", "stresses_along"),
    "mechanics.actuators": ("steady_port_values", "steady_slopes"),
    "mechanics.constraints": ("check_exact_constraint", "choose_dofs", "proposed_releases"),
    "mechanics.kinematics": ("Kinematics",),
    "mechanics.motions": ("motion_values",),
    "mechanics.mechanics": ("Mechanics",),
    "mechanics.ports": ("input_columns", "input_values", "output_rows", "output_value",
                        "port_description", "position_port"),
    "model": ("Model",),
    "numerics.blas": ("blas_threads",),
    "scene.api": ("Scene", "to_toml"),
    "scene.building": ("build_model", "builtin_scenes", "load_scene", "scene_path"),
    "scene.overrides": ("apply_overrides",),
    "scene.scene_writer": ("scene_toml",),
    "scene.spacar_input": ("read_spacar",),
    "simulation.linear_simulator": ("LinearSimulator",),
    "simulation.prepare": ("prepare",),
    "simulation.sampled_loop": ("controller_step", "run_sampled_loop"),
    "simulation.simulation": ("SimulationResult", "Simulator", "simulate"),
    "simulation.plausibility": ("RangeCheck", "mechanism_size"),
    "simulation.simulator": ("METHODS",),
    "simulation.tolerances": ("default_atol",),
}

_lazy, __getattr__, __dir__ = lazy_exports(__name__, _LAZY)
__all__ = ["ConstraintError", "ConvergenceError", "FlexureError", "SceneError", "SimulationError",
           *_lazy]
