"""flexure.controllers: motion profiles, feedback and feedforward design, the closed loop.

    from flexure.controllers import run_loop
    result = run_loop("stage_planar_1dof", stroke=1e-3, duration=1.0, fs=4000.0)
    result.summary()["error_ratio"]          # max |r - y| / stroke, target 0.001

- `ThirdOrderProfile`: jerk-limited point-to-point moves (profiles.py).
- `design_feedback`: PID-like loops for a cross-over on the scene's linear model, with phase,
  gain and modulus margins of the sampled loop (feedback.py).
- `low_frequency_model`, `StableInverse`: feedforward, the inverse of the low-frequency model
  and a stable approximate inverse of models with bad zeros (feedforward.py).
- `run_loop`: the sampled loop around the in-process simulation, the scene FMU under fmpy, or
  the controller and scene FMUs in libcosim (runner.py, plants.py, cosim.py,
  controller_fmu.py); `flexure loop` on the command line (cli.py).

Only flexure.core's public API is used: no physics here.
"""

from .feedback import ControlDesignError, DiscreteController, FeedbackDesign, design_feedback
from .feedforward import LowFrequencyModel, StableInverse, low_frequency_model
from .profiles import ProfileError, ThirdOrderProfile
from .runner import TARGET, LoopController, LoopError, LoopResult, build_loop, run_loop

__all__ = [
    "TARGET", "ControlDesignError", "DiscreteController", "FeedbackDesign", "LoopController",
    "LoopError", "LoopResult", "LowFrequencyModel", "ProfileError", "StableInverse",
    "ThirdOrderProfile", "build_loop", "design_feedback", "low_frequency_model", "run_loop",
]
