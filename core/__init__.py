"""flexure.core: SPACAR-style flexible multibody models and their analyses.

    from flexure.core import load_scene, static_equilibrium, natural_frequencies
    model = load_scene("stage_planar_3dof")          # a file path or a built-in scene name
    natural_frequencies(model).frequencies_hz        # Hz, at the static equilibrium
"""

from .blas import limit_blas_threads
from .constraints import check_exact_constraint
from .errors import ConstraintError, ConvergenceError, FlexureError, SceneError, SimulationError
from .kinematics import Kinematics
from .linearization import LinearModel, linearize
from .mechanics import Mechanics
from .modal import Modes, buckling_load_factors, natural_frequencies
from .model import Model
from .scene import build_model, builtin_scenes, load_scene, scene_path
from .simulation import SimulationResult, Simulator, default_atol, simulate
from .statespace import state_space
from .statics import StaticSolution, static_equilibrium
from .stresses import beam_stresses, stresses_along

limit_blas_threads()  # small matrices: one BLAS thread is fastest (see core/blas.py)

__version__ = "0.1.0"

__all__ = [
    "ConstraintError", "ConvergenceError", "FlexureError", "Kinematics", "LinearModel",
    "Mechanics", "Model", "Modes", "SceneError", "SimulationError", "SimulationResult",
    "Simulator", "StaticSolution", "beam_stresses", "buckling_load_factors", "build_model",
    "builtin_scenes", "check_exact_constraint", "default_atol", "linearize", "load_scene",
    "natural_frequencies", "scene_path", "simulate", "state_space", "static_equilibrium",
    "stresses_along",
]
