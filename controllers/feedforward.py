"""Feedforward: a stable inverse of the low-frequency model applied to the motion profile.

Low-frequency model. With n actuated inputs, the n lowest modes of the linearised model (the
suspension modes the actuators drive; the parasitic modes lie above the cross-over) give,
in modal coordinates eta with mass-normalised shapes Phi (unit modal mass),

    eta'' + Phi^T C0 Phi eta' + diag(w^2) eta = Phi^T DF^T b u,     y = DF_y Phi eta

so that for a desired output motion y(t) of the colocated sensors the forces are

    u = M_ff y'' + C_ff y' + K_ff y,   M_ff = B_r^-1 C_r^-1,  C_ff = B_r^-1 (Phi^T C0 Phi) C_r^-1,
                                       K_ff = B_r^-1 diag(w^2) C_r^-1

with B_r = Phi^T DF^T b and C_r = DF_y Phi. For one DOF this is u = m a + c v + k x with the
modal mass m = 1 / phi_x^2, the modal damping and the modal stiffness: the inverse of
1 / (m s^2 + c s + k), a polynomial in s and so stable, with no poles at all.

Zero-order hold. The force u_k is held over [t_k, t_k + Ts); it should equal the mean of the
continuous feedforward over that interval, not its value at t_k (which lags by half a sample).
`forces` therefore uses the exact interval means of the profile's position, velocity and
acceleration (profiles.interval_average).

Models with zeros. A general (e.g. non-colocated) SISO model P(z) = z^-d B(z) / A(z) has
zeros that cannot be inverted stably: outside the unit circle (non-minimum phase), or close
to it (lightly damped). `StableInverse` is the zero-phase-error tracking inverse (Tomizuka,
1987): the acceptable zeros are inverted, each unacceptable factor (1 - b z^-1) is replaced
by its zero-phase mirror (1 - b z)(1 - b z^-1) / (1 - b)^2 evaluated with preview of the
known profile, so the phase error is zero and the DC gain exact. Zeros well outside the unit
circle are inverted exactly by a filter run backwards in time over the known profile (the
non-causal stable inversion); the inputs then start before the motion, by a few time
constants of those zeros.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from .feedback import ControlDesignError, colocated_pairs

if TYPE_CHECKING:  # names for the annotations only
    import control
    from numpy.typing import ArrayLike

    from flexure.core import LinearModel, Model


@dataclass(frozen=True)
class LowFrequencyModel:
    """u = mass @ y'' + damping @ y' + stiffness @ (y - equilibrium) on the loops' outputs.

    Units: kg, N s/m, N/m (square matrices, one row and column per loop); `equilibrium` (m)
    holds the outputs at the static equilibrium under the scene's constant loads (the
    linearisation point), so the feedforward also carries those loads: a scene that starts
    away from its equilibrium is held where it starts.
    """

    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    frequencies_hz: np.ndarray  # the modes it keeps
    equilibrium: np.ndarray = None  # (n_loops,) m; None means zeros

    def scaled(self, *, mass: float = 1.0, damping: float = 1.0,
               stiffness: float = 1.0) -> LowFrequencyModel:
        """The same model with its matrices multiplied by factors (a model error study).

        Parameters
        ----------
        mass, damping, stiffness : float
            The factors on each matrix (unitless).

        Returns
        -------
        LowFrequencyModel
        """
        return replace(self, mass=self.mass * mass, damping=self.damping * damping,
                       stiffness=self.stiffness * stiffness)

    def force(self, position: ArrayLike, velocity: ArrayLike,
              acceleration: ArrayLike) -> np.ndarray:
        """The forces for an output motion.

        Parameters
        ----------
        position : array_like (..., n_loops)
            The outputs, m (rad for an angle).
        velocity : array_like (..., n_loops)
            m/s (rad/s).
        acceleration : array_like (..., n_loops)
            m/s^2 (rad/s^2).

        Returns
        -------
        ndarray (..., n_loops)
            N (N m for a moment).
        """
        p, v, a = (np.asarray(x, float) for x in (position, velocity, acceleration))
        eq = 0.0 if self.equilibrium is None else np.asarray(self.equilibrium, float)
        return a @ self.mass.T + v @ self.damping.T + (p - eq) @ self.stiffness.T

    def state_space(self) -> control.StateSpace:
        """The model as a continuous state space: states [y, y'], y'' = M^-1 (u - C y' - K y).

        Returns
        -------
        control.StateSpace
            From the forces (N) to the outputs' displacements from equilibrium (m).
        """
        import control

        n = self.mass.shape[0]
        inverse = np.linalg.inv(self.mass)
        A = np.block([[np.zeros((n, n)), np.eye(n)],
                      [-inverse @ self.stiffness, -inverse @ self.damping]])
        B = np.vstack([np.zeros((n, n)), inverse])
        return control.ss(A, B, np.hstack([np.eye(n), np.zeros((n, n))]), np.zeros((n, n)))

    def to_dict(self) -> dict[str, list]:
        """The matrices for JSON.

        Returns
        -------
        dict of str to list
            "mass" (kg), "damping" (N s/m), "stiffness" (N/m), "frequencies_hz" (Hz) and,
            when set, "equilibrium" (m), as nested lists.
        """
        return {k: np.asarray(getattr(self, k)).tolist()
                for k in ("mass", "damping", "stiffness", "frequencies_hz", "equilibrium")
                if getattr(self, k) is not None}

    @classmethod
    def from_dict(cls, data: dict[str, list]) -> LowFrequencyModel:
        """The model of `to_dict`.

        Parameters
        ----------
        data : dict of str to list
            As `to_dict` writes it.

        Returns
        -------
        LowFrequencyModel
        """
        return cls(**{k: np.asarray(v, float) for k, v in data.items()})


def low_frequency_model(model: Model, *, linear_model: LinearModel | None = None,
                        pairs: list | None = None) -> LowFrequencyModel:
    """The low-frequency model of `model` on its colocated loops (module docstring): its n
    lowest modes for n loops.

    Parameters
    ----------
    model : Model
        With a position output on the coordinate (or about the axis) of every input.
    linear_model : LinearModel, optional
        The linearisation to use (default: at the static equilibrium).
    pairs : list of LoopPair, optional
        The loops (default: every input with its colocated output, `colocated_pairs`).

    Returns
    -------
    LowFrequencyModel
        Mass (kg), damping (N s/m), stiffness (N/m) on the loops' outputs (kg m^2, N m s/rad,
        N m/rad for an angle), the modes' frequencies (Hz) and the outputs at equilibrium (m).

    Raises
    ------
    ControlDesignError
        An input without a colocated position output, or lowest modes the loops do not
        drive or see.
    """
    # the models on first use
    from flexure.core import (
        input_columns,
        linearize,
        natural_frequencies,
        output_rows,
        output_value,
    )

    pairs = colocated_pairs(model) if pairs is None else pairs
    lin = linear_model or linearize(model)
    modes = natural_frequencies(model, linear_model=lin)
    r = len(pairs)
    phi = modes.shapes[:, :r]
    omega = 2 * np.pi * modes.frequencies_hz[:r]
    x = lin.solution.config.x
    # a force on its coordinate, or a moment's generalised force at the linearisation point
    b = input_columns(model, x, [model.inputs[pair.input_index] for pair in pairs])
    B_r = phi.T @ lin.DF.T @ b
    outputs = [model.outputs[p.output_index] for p in pairs]
    C_r = output_rows(model, x, lin.DF, outputs) @ phi
    # a degenerate r-th mode is refused even where B_r happens to be invertible: its inverse
    # would be that of whichever r modes the eigensolver returned
    if (np.linalg.cond(B_r) > 1e12 or np.linalg.cond(C_r) > 1e12
            or _degenerate(modes.frequencies_hz, r)):
        raise ControlDesignError(refusal_message(model, pairs, modes.frequencies_hz, r))
    left, right = np.linalg.inv(B_r), np.linalg.inv(C_r)
    return LowFrequencyModel(
        mass=left @ right,
        damping=left @ (phi.T @ lin.C0 @ phi) @ right,
        stiffness=left @ np.diag(omega**2) @ right,
        frequencies_hz=modes.frequencies_hz[:r].copy(),
        equilibrium=np.array([output_value(model, port, x) for port in outputs]),
    )


DEGENERATE_RTOL = 1e-6  # frequencies this close are one eigenvalue to the eigensolver


def _degenerate(frequencies_hz, r):
    """Whether mode r + 1 has mode r's frequency (DEGENERATE_RTOL), so that the r lowest
    modes are no unique set."""
    return (len(frequencies_hz) > r and abs(frequencies_hz[r] - frequencies_hz[r - 1])
            <= DEGENERATE_RTOL * abs(frequencies_hz[r - 1]))


def refusal_message(model, pairs, frequencies_hz, r):
    """Why the modal feedforward has no inverse of the r lowest modes, and what to do: when
    mode r has the frequency of mode r + 1 (a symmetric mechanism), "the r lowest modes" are
    any r of a larger eigenspace, which the eigensolver picks at random; otherwise the
    loops do not drive or see one of them."""
    loops = ", ".join(f"{p.input_name}->{p.output_name}" for p in pairs)
    lowest = ", ".join(f"{f:.6g}" for f in frequencies_hz[:r])
    remedy = ("use --feedforward inverse (the inverse of the model's own linear dynamics), "
              "or --no-feedforward")
    if _degenerate(frequencies_hz, r):
        equal = [k + 1 for k, f in enumerate(frequencies_hz)
                 if abs(f - frequencies_hz[r - 1]) <= DEGENERATE_RTOL * abs(f)]
        return (f"{model.name}: the modal feedforward inverts the {r} lowest mode(s) for "
                f"{r} loop(s) ({loops}), but modes {', '.join(map(str, equal))} share one "
                f"frequency ({frequencies_hz[r - 1]:.6g} Hz), so which of them count as the "
                f"lowest {r} is the eigensolver's arbitrary choice. Close loops on the lowest "
                f"{equal[-1]} modes (an input with its colocated position output for each), "
                "break the symmetry (the scene's dimensions), or " + remedy)
    return (f"{model.name}: the modal feedforward needs the {r} lowest mode(s) ({lowest} Hz) "
            f"driven and seen by the {r} loop(s) ({loops}), and one is not (a mode the inputs "
            "do not move, or the outputs do not see): close the loops on the inputs that move "
            "the lowest modes, or " + remedy)


def low_frequency_plant(lf_model: LowFrequencyModel, model: Model,
                        pairs: list | None = None) -> control.StateSpace:
    """The low-frequency model as the loops drive it: from the forces (N), or where a voice
    coil of `model` drives a loop's input, from its drive signal (V).

    A voltage-driven coil adds its current i (A) to the states [y, y'], acting as the force
    Km i and driven by L di/dt = G u - R i - Km y' (the port's velocity is its colocated
    output's); its back-EMF damps the modes by Km^2 / R (N s/m) at low frequency. A
    current-driven coil is the gain Km G (N/V), no state. The amplifiers' saturation is not
    modelled (their slope G inside the limits).

    Parameters
    ----------
    lf_model : LowFrequencyModel
        Of `model`'s loops (`low_frequency_model`).
    model : Model
        Whose `actuators` drive the loops' inputs.
    pairs : list of LoopPair, optional
        The loops (default: `colocated_pairs(model)`).

    Returns
    -------
    control.StateSpace
        Continuous, states [y (m), y' (m/s), the coil currents (A)], from the loops' inputs
        (N or V) to their outputs' displacements from equilibrium (m).
    """
    import control

    pairs = colocated_pairs(model) if pairs is None else pairs
    plain = lf_model.state_space()
    n = len(pairs)
    gain = np.ones(n)  # N per unit input
    coils = []  # (loop, actuator) of every voltage-driven coil
    for actuator in model.actuators:
        loops = [k for k, pair in enumerate(pairs) if pair.input_index == actuator.input]
        if not loops:
            continue
        if actuator.drive == "current":
            gain[loops[0]] = actuator.force_constant * actuator.amplifier_gain
        else:
            coils.append((loops[0], actuator))
    c = len(coils)
    A = np.zeros((2 * n + c, 2 * n + c))
    A[:2 * n, :2 * n] = plain.A
    B = np.zeros((2 * n + c, n))
    B[:2 * n] = plain.B * gain
    for row, (k, actuator) in enumerate(coils, start=2 * n):
        force_column = plain.B[:, k].copy()  # the force of loop k's port, per N
        B[:2 * n, k] = 0.0
        A[:2 * n, row] = actuator.force_constant * force_column
        A[row, n + k] = -actuator.force_constant / actuator.inductance
        A[row, row] = -actuator.resistance / actuator.inductance
        B[row, k] = actuator.amplifier_gain / actuator.inductance
    C = np.hstack([np.eye(n), np.zeros((n, n + c))])
    return control.ss(A, B, C, np.zeros((n, n)))


def forces(lf_model: LowFrequencyModel, profile, t0: float, t1: float, *, direction=None,
           offsets=None) -> np.ndarray:
    """Feedforward forces (N), (n_samples, n_loops), held over the intervals [t0, t1).

    The profile moves the loops along `direction` (n_loops,), default the first loop only,
    from the output positions `offsets` (m, default: the equilibrium, no static force).
    """
    n = lf_model.mass.shape[0]
    direction = np.eye(n)[0] if direction is None else np.asarray(direction, float)
    if offsets is None:
        offsets = np.zeros(n) if lf_model.equilibrium is None else lf_model.equilibrium
    p, v, a = profile.interval_average(t0, t1)
    return lf_model.force(offsets + np.outer(p, direction), np.outer(v, direction),
                          np.outer(a, direction))


class StableInverse:
    """Zero-phase-error tracking (approximate) inverse of a discrete SISO model.

    Parameters
    ----------
    plant : control.TransferFunction or StateSpace, discrete (dt = Ts)
        The model from force (N) to position (m).
    min_damping : float
        Zeros inside the unit circle with a damping ratio below this (as poles of the inverse)
        count as lightly damped and are not inverted; nor are zeros at |z| >= 1.
    radius : float
        Zeros with |z| between `radius` and 1 / `radius` (near the unit circle) are mirrored
        rather than inverted; zeros beyond 1 / `radius` are inverted backwards in time.

    Raises
    ------
    ControlDesignError
        The plant is not a discrete SISO model.
    """

    def __init__(self, plant: control.TransferFunction | control.StateSpace, *,
                 min_damping: float = 0.05, radius: float = 0.999) -> None:
        import control  # 0.5 s to import: only where it is used

        tf = control.tf(plant)
        if not tf.isdtime(strict=True) or tf.ninputs != 1 or tf.noutputs != 1:
            raise ControlDesignError("StableInverse needs a discrete SISO model")
        num = np.trim_zeros(np.asarray(tf.num[0][0], float), "f")
        den = np.asarray(tf.den[0][0], float)
        self.dt = tf.dt
        self.delay = len(den) - len(num)  # relative degree d: P = z^-d B(z^-1) / A(z^-1)
        gain, zeros = num[0], np.roots(num)
        damped = np.array([_damping(z, tf.dt) >= min_damping for z in zeros], bool)
        outside = (np.abs(zeros) > 1.0 / radius) & damped
        bad = ~damped | ((np.abs(zeros) >= radius) & ~outside)
        self.zeros_inverted = zeros[~bad & ~outside]  # stable: a causal filter
        self.zeros_anticausal = zeros[outside]  # non-minimum phase: inverted backwards in time
        self.zeros_mirrored = zeros[bad]  # on or near the unit circle, lightly damped: ZPETC
        self.gain = gain
        self.den = den  # A(z^-1): the denominator coefficients read in powers of z^-1
        self.good = np.atleast_1d(np.real(np.poly(self.zeros_inverted)))  # B_a(z^-1), monic
        self.bad = np.atleast_1d(np.real(np.poly(self.zeros_mirrored)))  # B_u(z^-1), monic
        self.bad_dc = float(np.sum(self.bad))
        self.dc_gain = float(np.sum(num) / np.sum(den))

    def apply(self, reference: ArrayLike) -> np.ndarray:
        """The inputs u_k such that the model output follows `reference`; u_k uses the
        samples up to k + d + m (preview, m mirrored zeros):

            u = A(z^-1) B_u(z) z^d r / (b_0 B_a(z^-1) B_u(1)^2)

        Parameters
        ----------
        reference : array_like (N,)
            r at the samples k = 0..N-1, m; at rest at r_0 before and held at its last value
            after.

        Returns
        -------
        ndarray (N,)
            u_k, N.
        """
        from scipy.signal import lfilter, lfilter_zi

        r = np.asarray(reference, float)
        r0, x, n, m = r[0], r - r[0], len(r), len(self.bad) - 1
        ext = np.concatenate([x, np.full(self.delay + m, x[-1])])
        preview = sum(self.bad[j] * ext[self.delay + j: self.delay + j + n]
                      for j in range(m + 1))
        v = lfilter(self.den, [1.0], preview)
        u = lfilter([1.0], self.good, v) / (self.gain * self.bad_dc**2)
        b = self.zeros_anticausal  # prod 1/(1 - b z^-1) = prod(-1/b) z^k / prod(1 - z/b)
        if b.size:
            a = np.real(np.poly(1.0 / b))  # 1 / prod(1 - z/b), run backwards in time
            reverse = np.concatenate([u, np.full(n, u[-1])])[::-1]
            back = lfilter([1.0], a, reverse, zi=lfilter_zi([1.0], a) * reverse[0])[0][::-1]
            u = np.real(np.prod(-1.0 / b)) * back[b.size: b.size + n]
        return u + r0 / self.dc_gain


def _damping(z, dt):
    """The damping ratio of a zero z (or of its mirror 1/z* outside the unit circle)."""
    z = complex(z)
    if abs(z) > 1:
        z = 1 / np.conj(z)
    if abs(z) == 0:
        return 1.0
    s = np.log(z) / dt
    return 1.0 if abs(s) == 0 else float(-np.real(s) / abs(s))


def drive_signals(model, pairs, forces, reference, fs):
    """The drive signals (V) that make the actuators of the loops give `forces` (N).

    An input a voice coil drives (`Model.actuators`) takes its amplifier's drive signal, not
    a force: with the coil current i = F / Km, a current drive needs u = i / G and a voltage
    drive u = (R i + L di/dt + Km v) / G, the coil's voltage with the back-EMF of the port's
    velocity v, taken as the loop's reference velocity (a colocated loop tracks it to 0.1 %).
    On the hold intervals: v the exact mean (r_k+1 - r_k) fs of the reference, di/dt by central
    differences of the interval means (second order; the L di/dt term is small below R / L).
    The amplifier's saturation is not inverted. Other loops keep their forces.

    Parameters
    ----------
    model : Model
    pairs : list of LoopPair
    forces, reference : arrays (samples + 2, n_loops)
        The feedforward forces (N) held from each sample and the loops' references (m).
    fs : float
        Sample rate (Hz).
    """
    out = np.array(forces, float, copy=True)
    h = 1.0 / fs
    for actuator in model.actuators:
        loops = [k for k, pair in enumerate(pairs) if pair.input_index == actuator.input]
        if not loops:
            continue
        k = loops[0]
        current = out[:, k] / actuator.force_constant
        if actuator.drive == "current":
            out[:, k] = current / actuator.amplifier_gain
            continue
        velocity = np.zeros(len(current))
        velocity[:-1] = np.diff(reference[:, k]) / h
        rate = np.gradient(current, h) if len(current) > 1 else np.zeros(1)
        out[:, k] = (actuator.resistance * current + actuator.inductance * rate
                     + actuator.force_constant * velocity) / actuator.amplifier_gain
    return out
