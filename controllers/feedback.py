"""PID-like feedback designed on the scene's linearised model for a requested cross-over.

Each loop closes one input force on the position output at the same coordinate (colocated,
as the VCMs and their sensors of the book chapter). Per loop, with the cross-over w_c:

    C(s) = k_p  (s + w_i) / s  (s / w_z + 1) / (s / w_p + 1)  w_lp^2 / (s^2 + 2 z w_lp s + w_lp^2)
                integral action    lead around w_c              second-order low-pass

with w_i = w_c / 10, w_z = w_c / 3, w_p = 3 w_c, w_lp = 10 w_c and z = 0.5 by default (the
textbook recipe for a mass line: the lead gives 53 degrees at w_c, the integrator costs 6 and
the low-pass 6, so 41 degrees in continuous time; sampling at 4 kHz with the hold and one
sample of delay costs 1.5 w_c Ts = 6 more: 35 degrees, gain margin 4.2, modulus margin 0.55).
The controller runs at the sample rate fs as the Tustin discretisation (pre-warped at w_c);
the plant is seen through a zero-order hold (exact discretisation of the full linear model,
parasitic modes included) and one sample of computation delay z^-1: the force computed from
y(t_k) is applied on [t_(k+1), t_(k+2)), the timing of a co-simulation master that transfers
values once per macro step (see loop_controller.py). k_p is set so that |L(e^(j w_c Ts))| = 1
for the discrete loop gain L(z) = P_zoh(z) z^-1 C(z).

The design reports phase margin, gain margin and modulus margin (1 / max |S|, the smallest
distance of L to -1) of the sampled loop (robustness.py), and refuses (ControlDesignError) a
design whose closed loop has a pole on or outside the unit circle. It computes with the plain
numpy systems of lti.py; the python-control objects a user reads (`FeedbackDesign.controller`,
`.continuous`, `.loop_gain`) are built from them on first access.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from flexure.core import FlexureError, blas_threads

from .lti import LinearSystem, append, series, transfer_function, tustin, zoh
from .robustness import Robustness, check_robustness, delay_block

if TYPE_CHECKING:  # python-control takes a second to import: imported where it is used
    import control
    from numpy.typing import ArrayLike

    from flexure.core import LinearModel, Model


class ControlDesignError(FlexureError, ValueError):
    """A controller cannot be designed: unstable closed loop, no colocated output, bad rate."""


@dataclass(frozen=True)
class LoopPair:
    """One feedback loop: the input force and the colocated position output it controls."""

    input_index: int
    output_index: int
    input_name: str
    output_name: str


@dataclass
class FeedbackDesign:
    """A discrete decentralised controller and what its design found.

    `feedback` is the discrete controller (dt = 1/fs) from the errors r - y (m) of the loops
    to their forces (N), a plain-numpy `LinearSystem`; `controller` the same as a
    python-control StateSpace, `continuous` the controllers C(s) before discretisation (one
    python-control TransferFunction per loop, from `shapes`) and `loop_gain` L(z) of the
    first loop with the others open (from `first_loop`), each built on first access. The
    margins are the worst over the loops, each taken with the other loops open (the
    closed-loop poles are those of all loops closed together).
    """

    pairs: list
    crossover_rad_s: float
    sample_rate_hz: float
    delay_samples: int
    shapes: list  # (num, den) of each loop's C(s), descending powers of s: N/m
    feedback: LinearSystem | None  # the discrete controller, errors (m) to forces (N)
    first_loop: LinearSystem | None  # L(z) of the first loop, the others open
    phase_margin_deg: float
    gain_margin: float
    modulus_margin: float
    closed_loop_poles: np.ndarray
    robustness: Robustness | None = None  # margins per loop, others open and closed; |S|
    # "designed" here; "state space" or "callable" for a controller of one's own
    # (user_controller.py), whose callable kind has no margins (nan) and no poles
    kind: str = "designed"

    @property
    def controller(self) -> control.StateSpace | None:
        """The discrete controller as a python-control StateSpace (dt = 1/fs), from the
        errors (m, rad) to the forces (N, N m); None for a callable one. Imports
        python-control."""
        return None if self.feedback is None else self.feedback.to_control()

    @property
    def continuous(self) -> list:
        """Each loop's C(s) before discretisation, a python-control TransferFunction (N/m);
        empty for a controller of one's own. Imports python-control."""
        if not self.shapes:
            return []
        import control

        return [control.tf(num, den) for num, den in self.shapes]

    @property
    def loop_gain(self) -> control.StateSpace | None:
        """L(z) = P_zoh(z) z^-d C(z) of the first loop, the others open, a python-control
        StateSpace; None for a controller of one's own. Imports python-control."""
        return None if self.first_loop is None else self.first_loop.to_control()

    @property
    def spectral_radius(self) -> float:
        """The largest closed-loop pole magnitude (< 1: stable; nan when not known)."""
        poles = np.asarray(self.closed_loop_poles)
        return float(np.max(np.abs(poles))) if poles.size else float("nan")

    def summary(self) -> dict[str, object]:
        """The numbers the CLI and the report print.

        Returns
        -------
        dict
            "crossover_rad_s" (rad/s), "sample_rate_hz" (Hz), "phase_margin_deg" (degrees),
            "gain_margin" and "modulus_margin" (unitless): the worst loop's, the other loops
            open; "closed_loop_spectral_radius", "loops", "controller_kind",
            "robustness_checked"; with several loops also the margins with the others
            closed and the MIMO "sensitivity_peak".
        """
        summary = {"crossover_rad_s": self.crossover_rad_s,
                   "sample_rate_hz": self.sample_rate_hz,
                   "phase_margin_deg": self.phase_margin_deg, "gain_margin": self.gain_margin,
                   "modulus_margin": self.modulus_margin,
                   "closed_loop_spectral_radius": self.spectral_radius,
                   "loops": [f"{p.input_name} -> {p.output_name}" for p in self.pairs],
                   "controller_kind": self.kind,
                   "robustness_checked": self.kind != "callable"}
        if self.robustness is not None and len(self.pairs) > 1:
            closed = self.robustness.closed_margins.min(axis=0)
            summary |= {"gain_margin_others_closed": float(closed[0]),
                        "phase_margin_others_closed_deg": float(closed[1]),
                        "modulus_margin_others_closed": float(closed[2]),
                        "sensitivity_peak": self.robustness.sensitivity_peak}
        return summary


def colocated_pairs(model, loops: Sequence[str] | None = None) -> list:
    """The (input, position output) pairs that form the loops.

    Without `loops`: the pairs on the same coordinate (or about the same global axis of a 3-D
    rotational node: a moment and its angle), one per input. With `loops`, the pairs they
    name, "INPUT:OUTPUT" each (an input and a position output of the scene, each in one
    loop at most), in their order; the other inputs stay open (held at zero force).
    ControlDesignError naming what is wrong otherwise.
    """
    from flexure.core import port_description

    if loops is not None:
        return _chosen_pairs(model, loops)
    pairs = []
    for i, port in enumerate(model.inputs):
        match = [j for j, out in enumerate(model.outputs)
                 if out.location == port.location and out.quantity == "position"]
        if not match:
            where = (port_description(model, port, is_input=True) if port.about_axis
                     else model.coordinate_names[port.coordinate])
            raise ControlDesignError(
                f"{model.source}: input {port.name!r} has no position output on the same "
                f"coordinate ({where}); declare one in [outputs] to close a loop on it")
        j = match[0]
        pairs.append(LoopPair(i, j, port.name, model.outputs[j].name))
    return pairs


def _chosen_pairs(model, loops):
    """The LoopPairs of "INPUT:OUTPUT" texts (`colocated_pairs`)."""
    inputs = {port.name: i for i, port in enumerate(model.inputs)}
    outputs = {port.name: j for j, port in enumerate(model.outputs)
               if port.quantity == "position"}
    if not loops:
        raise ControlDesignError("--loop: expected at least one INPUT:OUTPUT pair")
    pairs = []
    for text in loops:
        name, sep, output = (part.strip() for part in str(text).partition(":"))
        if not sep or not name or not output:
            raise ControlDesignError(f"--loop {text!r}: expected INPUT:OUTPUT, e.g. F:x")
        if name not in inputs:
            raise ControlDesignError(f"--loop {text}: {model.name} has no input {name!r}; its "
                                     f"inputs are {', '.join(inputs) or 'none'}")
        if output not in outputs:
            raise ControlDesignError(
                f"--loop {text}: {model.name} has no position output {output!r}; its position "
                f"outputs are {', '.join(outputs) or 'none'}")
        for pair in pairs:
            if name == pair.input_name or output == pair.output_name:
                raise ControlDesignError(
                    f"--loop {text}: {name if name == pair.input_name else output} is in the "
                    f"loop {pair.input_name}:{pair.output_name} already; each input and output "
                    "closes one loop")
        pairs.append(LoopPair(inputs[name], outputs[output], name, output))
    return pairs


def pid_lowpass_polynomials(crossover: float, *, gain: float = 1.0,
                            integral_ratio: float = 10.0, lead_ratio: float = 3.0,
                            lowpass_ratio: float = 10.0, lowpass_damping: float = 0.5,
                            ) -> tuple[np.ndarray, np.ndarray]:
    """The continuous PID-like controller C(s) around `crossover` (rad/s) as its numerator
    and denominator (descending powers of s; C in N/m): the module docstring's product
    k_p (s + w_i) (s / w_z + 1) w_lp^2 / (s (s / w_p + 1) (s^2 + 2 z w_lp s + w_lp^2))."""
    wc = float(crossover)
    wi, wz, wp, wlp = wc / integral_ratio, wc / lead_ratio, wc * lead_ratio, wc * lowpass_ratio
    num = gain * np.polymul(np.polymul([1.0, wi], [1.0 / wz, 1.0]), [wlp**2])
    den = np.polymul(np.polymul([1.0, 0.0], [1.0 / wp, 1.0]),
                     [1.0, 2 * lowpass_damping * wlp, wlp**2])
    return num, den


def pid_lowpass(crossover: float, *, gain: float = 1.0, integral_ratio: float = 10.0,
                lead_ratio: float = 3.0, lowpass_ratio: float = 10.0,
                lowpass_damping: float = 0.5) -> control.TransferFunction:
    """The continuous PID-like controller C(s) (N/m) around `crossover` (rad/s), a
    python-control TransferFunction (`pid_lowpass_polynomials`)."""
    import control

    return control.tf(*pid_lowpass_polynomials(
        crossover, gain=gain, integral_ratio=integral_ratio, lead_ratio=lead_ratio,
        lowpass_ratio=lowpass_ratio, lowpass_damping=lowpass_damping))


@blas_threads()
def design_feedback(model: Model, *, crossover: float = 300.0, fs: float = 4000.0,
                    delay_samples: int = 1, linear_model: LinearModel | None = None,
                    plant: control.StateSpace | LinearSystem | None = None,
                    loops: Sequence[str] | None = None, **shape: float) -> FeedbackDesign:
    """Design the discrete colocated loops of `model` for a cross-over at a sample rate.

    Parameters
    ----------
    model : Model
        With a position output on the coordinate (or about the axis) of every input.
    crossover : float
        The cross-over frequency w_c, rad/s, below the Nyquist frequency pi fs.
    fs : float
        The sample rate, Hz.
    delay_samples : int
        Samples of computation delay in the loop (>= 0).
    linear_model : LinearModel, optional
        The linearisation for the plant (default: at the static equilibrium).
    plant : control.StateSpace or LinearSystem, optional
        A continuous plant with the model's inputs and outputs, instead of the linear model.
    loops : sequence of str, optional
        "INPUT:OUTPUT" pairs that form the loops, the other inputs open (default: every
        input with its colocated position output; `colocated_pairs`).
    **shape : float
        integral_ratio, lead_ratio, lowpass_ratio, lowpass_damping for `pid_lowpass`
        (unitless).

    Returns
    -------
    FeedbackDesign
        The discrete controller from errors (m, rad) to forces (N, N m; V for a drive
        signal) and its margins.

    Raises
    ------
    ControlDesignError
        A sample rate or cross-over out of range, a negative delay, an input without a
        colocated position output, a plant without gain at the cross-over, or an unstable
        closed loop.
    """
    if not (np.isfinite(fs) and fs > 0):
        raise ControlDesignError(f"sample rate must be a positive number of Hz, got {fs}")
    if not (np.isfinite(crossover) and 0 < crossover < np.pi * fs):
        raise ControlDesignError(
            f"cross-over must lie between 0 and the Nyquist frequency pi fs = {np.pi * fs:g} "
            f"rad/s, got {crossover}")
    if delay_samples < 0:
        raise ControlDesignError(f"delay_samples must be >= 0, got {delay_samples}")
    from flexure.core import state_space_matrices  # the models (numba, scipy) on first use

    pairs = colocated_pairs(model, loops)
    full = (LinearSystem.of(plant) if plant is not None
            else LinearSystem(*state_space_matrices(model, linear_model=linear_model)))
    Ts = 1.0 / fs
    sub = full.subsystem([p.output_index for p in pairs], [p.input_index for p in pairs])
    plant_d = zoh(sub, Ts)
    z = np.exp(1j * crossover * Ts)
    shapes, discrete = [], []
    for k, pair in enumerate(pairs):
        num, den = pid_lowpass_polynomials(crossover, **shape)
        num_z, den_z = tustin(num, den, Ts, prewarp=crossover)
        c_z = np.polyval(num_z, z) / np.polyval(den_z, z)
        magnitude = abs(complex(plant_d.response(z)[k, k]) * c_z)
        if not np.isfinite(magnitude) or magnitude == 0:
            raise ControlDesignError(f"loop {pair.input_name}: the plant has no gain at "
                                     f"{crossover} rad/s")
        shapes.append((num / magnitude, den))
        discrete.append(transfer_function(num_z / magnitude, den_z, Ts))
    controller = append(*discrete) if len(discrete) > 1 else discrete[0]
    delays = delay_block(len(pairs), delay_samples, Ts)
    first = series(controller.subsystem([0], [0]), delays.subsystem([0], [0]),
                   plant_d.subsystem([0], [0]))
    design = FeedbackDesign(
        pairs=pairs, crossover_rad_s=float(crossover), sample_rate_hz=float(fs),
        delay_samples=int(delay_samples), shapes=shapes, feedback=controller,
        first_loop=first, phase_margin_deg=np.nan, gain_margin=np.nan, modulus_margin=np.nan,
        closed_loop_poles=np.zeros(0))
    # margins per loop with the other loops open (the worst of each reported) and closed
    robust = check_robustness(design, plant_d, name=model.name)
    gm, pm, sm = robust.open_margins.min(axis=0)
    poles = robust.closed_loop_poles
    design = replace(design, phase_margin_deg=float(pm), gain_margin=float(gm),
                     modulus_margin=float(sm), closed_loop_poles=poles, robustness=robust)
    if not np.all(np.abs(poles) < 1.0):
        worst = poles[np.argmax(np.abs(poles))]
        raise ControlDesignError(
            f"{model.name}: the closed loop at cross-over {crossover:g} rad/s and {fs:g} Hz is "
            f"unstable: pole z = {worst:.6g} (|z| = {abs(worst):.6f} >= 1); phase margin "
            f"{pm:.1f} deg, gain margin {gm:.3g}. Lower the cross-over or raise the sample rate")
    return design


class DiscreteController:
    """A discrete state-space controller stepped one sample at a time (plain numpy).

    `step(e_k)` returns u_k = C x_k + D e_k and moves to x_(k+1) = A x_k + B e_k.

    Parameters
    ----------
    sys : LinearSystem or control.StateSpace
        A discrete system (anything with A, B, C, D), from errors (m, rad) to forces (N,
        N m, or V for a drive signal); its time step is the caller's sample period.
    """

    def __init__(self, sys: LinearSystem | control.StateSpace) -> None:
        self.A, self.B, self.C, self.D = (np.ascontiguousarray(np.atleast_2d(
            np.asarray(m, float))) for m in (sys.A, sys.B, sys.C, sys.D))
        self.x = np.zeros(self.A.shape[0])
        self._next = np.empty(self.A.shape[0])  # controller_step's scratch for A x + B e

    def reset(self) -> None:
        """Set the state back to zero."""
        self.x = np.zeros(self.A.shape[0])

    def step(self, e: ArrayLike) -> np.ndarray:
        """The output u_k for the error e_k, advancing the state.

        The arithmetic is flexure.core's compiled `controller_step`, which the compiled
        in-process loop uses too, so every plant sees the same forces bit for bit.

        Parameters
        ----------
        e : array_like (n_loops,)
            The errors r - y, in the loops' output units (m, rad).

        Returns
        -------
        ndarray (n_loops,)
            u_k, in the loops' input units (N, N m, V).
        """
        from flexure.core import controller_step

        e = np.ascontiguousarray(np.atleast_1d(np.asarray(e, float)))
        u = np.empty(self.C.shape[0])
        controller_step(self.A, self.B, self.C, self.D, self.x, e, u, self._next)
        return u

    def to_dict(self) -> dict[str, dict[str, list]]:
        """The matrices for JSON.

        Returns
        -------
        dict
            {"A": {"shape": [rows, columns], "values": row-major list}, "B": ..., "C": ...,
            "D": ...}.
        """
        return {k: {"shape": list(getattr(self, k).shape),
                    "values": getattr(self, k).ravel().tolist()} for k in "ABCD"}

    @classmethod
    def from_dict(cls, data: dict[str, dict[str, list]]) -> DiscreteController:
        """The controller of `to_dict`, at its zero initial state.

        Parameters
        ----------
        data : dict
            As `to_dict` writes it.

        Returns
        -------
        DiscreteController
        """
        obj = cls.__new__(cls)
        for k in "ABCD":
            setattr(obj, k, np.asarray(data[k]["values"], float).reshape(data[k]["shape"]))
        obj.x = np.zeros(obj.A.shape[0])
        obj._next = np.empty(obj.A.shape[0])
        return obj
