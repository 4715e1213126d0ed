"""flexure.controllers: motion profiles, feedback and feedforward design, the closed loop.

    from flexure.controllers import run_loop
    result = run_loop("stage_planar_1dof", stroke=1e-3, duration=1.0, fs=4000.0)
    result.summary()["error_ratio"]          # max |r - y| / stroke, target 0.001

- `ThirdOrderProfile`: jerk-limited point-to-point moves (profiles.py).
- `design_feedback`: PID-like loops for a cross-over on the scene's linear model, with phase,
  gain and modulus margins of the sampled loop (feedback.py, robustness.py), computed with
  the plain-numpy state spaces of lti.py: the loop never imports python-control.
- `low_frequency_model`, `StableInverse`: feedforward, the inverse of the low-frequency model
  and a stable approximate inverse of models with bad zeros (feedforward.py).
- `LoopController`: feedback plus feedforward at one sample rate, the same object on every
  plant and inside the controller FMU (loop_controller.py); `build_loop` designs it for a
  scene (loop_design.py).
- `run_loop`: the sampled loop (sample_loop.py) around the in-process simulation, the scene
  FMU under fmpy, the linearised model stepped exactly (plants.py), or the controller and
  scene FMUs in libcosim (cosim.py, controller_fmu.py); its `LoopResult` (loop_result.py);
  `flexure loop` on the command line (cli.py).
- One's own feedback (a discrete python-control system or callables, user_controller.py)
  and reference (samples or r(t), user_reference.py) in place of the designed ones; encoder
  quantisation and a sinusoidal (mains) force at the actuators (disturbances.py).

The modules import one way: errors, profiles, lti, spline -> robustness -> feedback,
feedforward, disturbances, user_reference -> loop_controller, user_controller ->
loop_design, sample_loop, plants, controller_fmu -> cosim -> runner -> cli (runner imports
cosim, and with it the FMU packages, only for the FMU plants).

Only flexure.core's public API is used: no physics here.
"""

from flexure.core.lazy_imports import lazy_exports

# submodule -> the public names it defines, imported on first use (PEP 562): importing
# flexure.controllers loads neither python-control nor the models
_LAZY = {
    "feedback": ("ControlDesignError", "DiscreteController", "FeedbackDesign",
                 "design_feedback"),
    "feedforward": ("LowFrequencyModel", "StableInverse", "low_frequency_model"),
    "loop_controller": ("LoopController",),
    "loop_design": ("LoopError", "build_loop"),
    "loop_result": ("TARGET", "LoopResult"),
    "profiles": ("ProfileError", "ThirdOrderProfile"),
    "runner": ("run_loop",),
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _LAZY)
