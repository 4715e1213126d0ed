"""The closed loop: a sampled controller (feedback plus feedforward) around a plant.

One loop, whatever the plant. At the samples t_k = k / fs (k = 0 .. N):

    y_k   = plant output (the colocated positions of the loops), measured at t_k
    e_k   = r_k - y_k                         r: the profile plus the initial positions
    u_k+1 = C(z) e_k + u_ff,k+1               computed at t_k, applied on [t_k+1, t_k+2)
    plant: u_k held over [t_k, t_k+1)         (zero-order hold)

so the force is computed from a measurement one sample older than the interval it acts on:
one sample of computation delay, as in a real-time controller that writes its output at the
next clock tick. That is also exactly the timing of a co-simulation master that transfers
the values between the FMUs once per macro step (libcosim's fixed-step algorithm: the
controller FMU reads y_k at the start of its step over [t_k, t_k+1] and its new output reaches
the plant at the start of the next step), so the in-process loop, the loop around the fmpy
FMU and the libcosim co-simulation all compute the same sequence. The design (feedback.py)
includes that delay and the hold in its margins. u_0 = u_ff,0 (nothing measured yet).

u_ff,k is the mean over [t_k, t_k+1) of the continuous feedforward (feedforward.py), so the
held force carries no half-sample lag. The error reported is max_k |e_k| over the samples,
during the move and a settling time after it.
"""

import contextlib
import tempfile
import time as _time
from dataclasses import dataclass, field

import numpy as np

from flexure.core import FlexureError

from .feedback import DiscreteController, design_feedback
from .feedforward import low_frequency_model
from .loop_controller import LoopController
from .profiles import ThirdOrderProfile

TARGET = 1e-3  # the tracking target: max |error| / stroke
PLANTS = ("inprocess", "fmu", "libcosim")


class LoopError(FlexureError, ValueError):
    """A closed-loop run was asked for with impossible settings."""


@dataclass
class LoopResult:
    """The samples of a closed-loop run and its summary.

    t (N+1,) s; reference, position, error (N+1, n_loops) m; force, feedforward
    (N+1, n_loops) N, the force held from t_k (the last row repeats the one before).
    """

    t: np.ndarray
    reference: np.ndarray
    position: np.ndarray
    force: np.ndarray
    feedforward: np.ndarray
    stroke: float
    design: dict
    settings: dict = field(default_factory=dict)
    wall_time_s: float = 0.0

    @property
    def error(self):
        return self.reference - self.position

    @property
    def max_abs_error(self):
        return float(np.max(np.abs(self.error)))

    def summary(self):
        """The dictionary `flexure loop --json` prints (SI units)."""
        ratio = self.max_abs_error / abs(self.stroke)
        axis = self.settings.get("axis", 0)
        return {
            "scene": self.settings.get("scene"), "plant": self.settings.get("plant"),
            "feedforward": self.settings.get("feedforward"),
            "feedforward_kind": self.settings.get("feedforward_kind"),
            "max_abs_error": self.max_abs_error, "stroke": self.stroke,
            "error_ratio": ratio, "target": TARGET, "passed": bool(ratio <= TARGET),
            "max_abs_error_during_move": float(np.max(np.abs(
                self.error[self.t <= self.settings.get("move_end", np.inf), axis]))),
            "final_error": float(np.max(np.abs(self.error[-1]))),
            "max_abs_force": float(np.max(np.abs(self.force))),
            "max_abs_feedback_force": float(np.max(np.abs(self.force - self.feedforward))),
            "phase_margin_deg": self.design["phase_margin_deg"],
            "gain_margin": self.design["gain_margin"],
            "modulus_margin": self.design["modulus_margin"],
            "crossover_rad_s": self.design["crossover_rad_s"],
            "sample_rate_hz": self.design["sample_rate_hz"],
            "closed_loop_spectral_radius": self.design["closed_loop_spectral_radius"],
            "loops": self.design["loops"],
            "duration": self.settings.get("duration"), "settle": self.settings.get("settle"),
            "rtol": self.settings.get("rtol"), "wall_time_s": self.wall_time_s,
        }

    def plot(self, path, *, title=None):
        """Reference, position, error and force against time, saved as a PNG."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        axis = self.settings.get("axis", 0)
        fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
        axes[0].plot(self.t, self.reference[:, axis] * 1e3, label="reference")
        axes[0].plot(self.t, self.position[:, axis] * 1e3, "--", label="position")
        axes[0].set_ylabel("position (mm)")
        axes[0].legend(loc="lower right")
        band = TARGET * abs(self.stroke) * 1e6
        error = self.error[:, axis] * 1e6
        axes[1].plot(self.t, error, label="error r - y")
        if np.max(np.abs(error)) > 0.05 * band:  # the target band would flatten the error
            axes[1].axhline(band, color="r", lw=0.8, ls=":", label=f"target +-{band:.3g} um")
            axes[1].axhline(-band, color="r", lw=0.8, ls=":")
        else:
            axes[1].text(0.01, 0.04, f"target +-{band:.3g} um: far off this scale",
                         transform=axes[1].transAxes, va="bottom", fontsize=9, color="r")
        axes[1].set_ylabel("error (um)")
        axes[1].legend(loc="upper right")
        axes[2].step(self.t, self.force[:, axis], where="post", label="total force")
        axes[2].step(self.t, self.feedforward[:, axis], where="post", ls="--",
                     label="feedforward")
        axes[2].set_ylabel("force (N)")
        axes[2].set_xlabel("time (s)")
        axes[2].legend(loc="upper right")
        s = self.summary()
        fig.suptitle(title or (
            f"{s['scene']} ({s['plant']}): stroke {self.stroke * 1e3:g} mm, "
            f"max |e| = {s['max_abs_error'] * 1e6:.3g} um = {100 * s['error_ratio']:.3g} % "
            f"(target 0.1 %), {'passed' if s['passed'] else 'FAILED'}"), fontsize=10)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        return path


def build_loop(model, *, stroke=1e-3, duration=1.0, fs=4000.0, crossover=300.0,
               feedforward=True, settle=0.25, axis=0, feedforward_model=None,
               **design_options):
    """Design the feedback and the feedforward of `model`; returns (LoopController, design).

    `feedforward` is True or "modal" (the inverse of the low-frequency model, m a + c v + k x),
    "inverse" (the stable approximate inverse of the full linear model sampled with a
    zero-order hold, `StableInverse`: one loop only), or False for feedback alone.
    `feedforward_model` replaces the low-frequency model derived from `model` (e.g. a
    deliberately wrong one, `low_frequency_model(model).scaled(mass=1.1, stiffness=1.1)`).
    """
    if not np.isfinite(stroke) or stroke == 0:
        raise LoopError(f"stroke must be a finite, non-zero distance (m), got {stroke}")
    for name, value in (("duration", duration), ("fs", fs), ("settle", settle)):
        if not np.isfinite(value) or (value <= 0 if name != "settle" else value < 0):
            raise LoopError(f"{name} must be a positive finite number, got {value}")
    design = design_feedback(model, crossover=crossover, fs=fs, **design_options)
    n = len(design.pairs)
    if not 0 <= axis < n:
        raise LoopError(f"axis {axis} out of range: {model.name} has {n} loop(s)")
    profile = ThirdOrderProfile(stroke, duration)
    samples = int(round((duration + settle) * fs))
    offsets = [model.initial_coordinates[model.outputs[p.output_index].coordinate]
               for p in design.pairs]
    kind = _feedforward_kind(feedforward)
    lf, explicit = None, None
    if kind == "modal":
        lf = feedforward_model if feedforward_model is not None else low_frequency_model(model)
    elif kind == "inverse":
        explicit = _inverse_forces(model, design, profile, fs, samples, offsets)
    controller = LoopController(DiscreteController(design.controller), profile, fs=fs,
                                samples=samples, offsets=offsets, feedforward=lf, axis=axis,
                                feedforward_forces=explicit)
    return controller, design


def _feedforward_kind(feedforward):
    if feedforward is True or feedforward == "modal":
        return "modal"
    if feedforward is False or feedforward is None or feedforward == "none":
        return None
    if feedforward == "inverse":
        return "inverse"
    raise LoopError(f"feedforward must be 'modal', 'inverse' or False, got {feedforward!r}")


def _inverse_forces(model, design, profile, fs, samples, offsets):
    """Feedforward from the stable inverse of the sampled full linear model (one loop)."""
    import control

    from flexure.core import linearize, state_space

    from .feedforward import StableInverse

    if len(design.pairs) != 1:
        raise LoopError(f"{model.name}: the 'inverse' feedforward handles one loop, the scene "
                        f"has {len(design.pairs)}; use the 'modal' feedforward")
    pair = design.pairs[0]
    lin = linearize(model)
    plant = state_space(model, linear_model=lin)[pair.output_index, pair.input_index]
    inverse = StableInverse(control.c2d(plant, 1.0 / fs, method="zoh"))
    equilibrium = lin.solution.config.x[model.outputs[pair.output_index].coordinate]
    k = np.arange(samples + 2)
    # u_k, held on [t_k, t_k+1), makes the sampled linear output follow r_k (deviations
    # from the linearisation point, which carries the scene's constant loads).
    reference = offsets[0] - equilibrium + profile.position(k / fs)
    return inverse.apply(reference)[:, None]


def run_loop(scene, *, stroke=1e-3, duration=1.0, fs=4000.0, crossover=300.0,
             feedforward=True, plant="inprocess", settle=0.25, axis=0, method="esdirk3", rtol=1e-8,
             feedforward_model=None, workdir=None, progress=None, **design_options):
    """Run the closed loop on a scene (a model, a file or a built-in name).

    Parameters
    ----------
    scene : Model or str
    stroke, duration : float
        The third-order move (m, s).
    fs : float
        Sample rate (Hz) of the controller and communication step of the plant.
    crossover : float
        The requested cross-over (rad/s).
    feedforward : bool or str
        True or "modal": the inverse of the low-frequency model; "inverse": the stable
        approximate inverse of the full linear model (see `build_loop`); False: none.
    plant : "inprocess", "fmu" or "libcosim"
    settle : float
        Time (s) simulated after the move.
    method : str
        The plant's integrator (every plant uses the same): a `flexure.core.METHODS` name.
        The default, the one-step ESDIRK of order 3, takes the change of the held force at
        every sample without a restart (one step per sample at 4 kHz on the built-in stages).
    rtol : float
        Relative tolerance of the plant's integrator (every plant uses the same).
    feedforward_model : LowFrequencyModel, optional
        Use this model for the feedforward instead of the scene's own.
    workdir : path, optional
        Where the FMUs are built and kept (default: a temporary folder, removed after).
    progress : callable, optional
        Called with the fraction of the samples done (0 to 1) as the loop runs, e.g. a
        `flexure.core.progress.Progress`.

    Returns
    -------
    LoopResult
    """
    if plant not in PLANTS:
        raise LoopError(f"unknown plant {plant!r}; expected one of {', '.join(PLANTS)}")
    if not (isinstance(rtol, (int, float, np.floating)) and np.isfinite(rtol) and 0 < rtol < 1):
        raise LoopError(f"rtol must be a number between 0 and 1, got {rtol!r}")
    from flexure.core import METHODS

    if method not in METHODS:
        raise LoopError(f"unknown method {method!r}; expected one of {', '.join(METHODS)}")
    from flexure.core import load_scene  # the models (numba, scipy) on first use

    model = load_scene(scene) if isinstance(scene, (str, bytes)) or hasattr(
        scene, "__fspath__") else scene
    controller, design = build_loop(
        model, stroke=stroke, duration=duration, fs=fs, crossover=crossover,
        feedforward=feedforward, settle=settle, axis=axis,
        feedforward_model=feedforward_model, **design_options)
    kind = _feedforward_kind(feedforward)
    settings = {"scene": model.name, "plant": plant, "feedforward": kind is not None,
                "feedforward_kind": kind or "none",
                "duration": duration, "settle": settle, "axis": axis, "move_end": duration,
                "method": method, "rtol": rtol}
    if plant == "inprocess":  # the engine's compilation (first use only) is not the loop's
        from flexure.core import prepare

        prepare(model, loop_method=method)
    start = _time.perf_counter()
    with contextlib.ExitStack() as stack:
        if workdir is None and plant != "inprocess":  # FMUs built for this run only
            workdir = stack.enter_context(tempfile.TemporaryDirectory(
                prefix="flexure_loop_", ignore_cleanup_errors=True))
        t, reference, position, force = _run_plant(plant, model, scene, controller, design,
                                                   method=method, rtol=rtol, workdir=workdir,
                                                   progress=progress)
    wall = _time.perf_counter() - start
    return LoopResult(t=t, reference=reference, position=position, force=force,
                      feedforward=controller.feedforward[: len(t)].copy(), stroke=stroke,
                      design=design.summary(), settings=settings, wall_time_s=wall)


def _run_plant(plant, model, scene, controller, design, *, method, rtol, workdir, progress):
    if plant == "libcosim":
        from .cosim import run_cosimulation

        return run_cosimulation(model, scene, controller, design, method=method, rtol=rtol,
                                workdir=workdir, progress=progress)
    if plant == "inprocess":
        return _compiled_loop(model, controller, design, method=method, rtol=rtol,
                              progress=progress)
    from .cosim import scene_fmu
    from .plants import FmuPlant

    adapter = FmuPlant(scene_fmu(scene, model, workdir), method=method, rtol=rtol)
    try:
        return simulate_loop(adapter, controller, design, progress=progress)
    finally:
        adapter.close()


def _compiled_loop(model, controller, design, *, method, rtol, progress):
    """The in-process loop as one compiled run (flexure.core.run_sampled_loop): the same
    samples, forces and integrator calls as `simulate_loop` with an in-process plant."""
    from flexure.core import Simulator, run_sampled_loop

    sim = Simulator(model, method=method, rtol=rtol)
    feedback = controller.controller
    t, position, force = run_sampled_loop(
        sim, fs=controller.fs, samples=controller.samples, reference=controller.reference,
        feedforward=controller.feedforward,
        controller=(feedback.A, feedback.B, feedback.C, feedback.D),
        loop_inputs=[pair.input_index for pair in design.pairs],
        loop_outputs=[pair.output_index for pair in design.pairs], progress=progress)
    return t, controller.reference[: len(t)].copy(), position, force


def simulate_loop(plant, controller, design, *, progress=None):
    """Step `plant` (plants.py interface) under `controller`; returns t, r, y, u arrays.

    `progress`, if given, is called with the fraction of samples done, about 100 times.
    """
    pairs = design.pairs
    n_inputs = len(plant.input_names)
    inputs = [p.input_index for p in pairs]
    outputs = [p.output_index for p in pairs]
    N, fs = controller.samples, controller.fs
    position = np.empty((N + 1, len(pairs)))
    force = np.empty((N + 1, len(pairs)))
    controller.reset()
    y = plant.reset()[outputs]
    u = controller.initial_output()
    full = np.zeros(n_inputs)
    report_every = max(1, N // 100)
    for k in range(N):
        if progress is not None and k % report_every == 0:
            progress(k / N)
        position[k] = y
        force[k] = u
        u_next, _ = controller.step(k, y)
        full[inputs] = u
        plant.set_input(full)
        plant.advance((k + 1) / fs)
        y = plant.output()[outputs]
        u = u_next
    if progress is not None:
        progress(1.0)
    position[N], force[N] = y, force[N - 1]
    t = np.arange(N + 1) / fs
    return t, controller.reference[: N + 1].copy(), position, force
