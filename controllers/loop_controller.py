"""The loop controller: feedback plus feedforward at one sample rate, the same on every plant.

At the samples t_k = k / fs (k = 0 .. N):

    y_k   = plant output (the colocated positions of the loops), measured at t_k
    e_k   = r_k - y_k                         r: the profile plus the initial positions
    u_k+1 = C(z) e_k + u_ff,k+1               computed at t_k, applied on [t_k+1, t_k+2)
    plant: u_k held over [t_k, t_k+1)         (zero-order hold)

so the force is computed from a measurement one sample older than the interval it acts on:
one sample of computation delay, as in a real-time controller that writes its output at the
next clock tick. That is also exactly the timing of a co-simulation master that transfers
the values between the FMUs once per macro step (libcosim's fixed-step algorithm: the
controller FMU reads y_k at the start of its step over [t_k, t_k+1] and its new output reaches
the plant at the start of the next step), so the in-process loop (sample_loop.py), the loop
around the fmpy FMU and the libcosim co-simulation (cosim.py, controller_fmu.py) all compute
the same sequence. The design (feedback.py) includes that delay and the hold in its margins.
u_0 = u_ff,0 (nothing measured yet).

u_ff,k is the mean over [t_k, t_k+1) of the continuous feedforward (feedforward.py), so the
held force carries no half-sample lag.

The references: one loop (`axis`) follows the profile while the others hold; or, with a
`MovePath` (move_path.py), every loop follows its displacement y(s) along the path with the
progress s(t) = the profile (of stroke 1) over time, and the feedforward is
m y'' + c y' + (the path's static forces, or k y of the low-frequency model), with
y' = y_s s', y'' = y_ss s'^2 + y_s s''. Its interval means: those of y' and y'' exact (the
differences of y and y' over the interval), those of y and of the static force by 4-point
Gauss-Legendre quadrature (exact for polynomials of degree 7 in t).

Or the reference is given (`reference`, user_reference.py): the loops' positions at the
samples, the modal feedforward then taken from their cubic spline. The feedback may be one's
own (user_controller.py): a discrete state space, stepped as the designed one, or Python
callables, given the sample index as well. With `disturbances` (disturbances.py) the
controller sees the positions rounded to the encoders' quantum, and a sinusoidal force d_k is
added to the held force:

    e_k = r_k - q round(y_k / q),     u_k+1 = C(z) e_k + u_ff,k+1 + d_k+1,     u_0 = u_ff,0 + d_0

`open_loop_forces` holds u_ff + d (u_ff alone without a disturbance, the very same array).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .disturbances import Disturbances
from .errors import LoopError
from .feedback import DiscreteController
from .feedforward import LowFrequencyModel, forces
from .move_path import MovePath
from .profiles import ThirdOrderProfile
from .user_reference import reference_forces

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from .user_controller import CallableFeedback

_GAUSS_POINTS, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(4)


class LoopController:
    """Feedback plus feedforward at one sample rate; the same object runs in the FMU.

    Parameters
    ----------
    controller : DiscreteController or CallableFeedback
        The discrete feedback C(z) from errors (m) to forces (N), one channel per loop; or
        callables (user_controller.py), stepped with the sample index too.
    profile : ThirdOrderProfile or None
        The motion of the loop `axis`; the other loops hold their initial position. None
        with a `reference`.
    fs : float
        Sample rate (Hz).
    samples : int
        The number of intervals N (the run ends at N / fs).
    offsets : array_like (n_loops,)
        The initial positions of the loops (m): the reference is offsets + profile.
    feedforward : LowFrequencyModel or None
        The model whose inverse gives the feedforward; None for feedback alone.
    axis : int
        The loop that follows the profile.
    feedforward_forces : array_like (samples + 2, n_loops), optional
        Precomputed feedforward forces (N) held from each sample, instead of `feedforward`
        (e.g. from a `StableInverse` of the full linear model).
    path : MovePath, optional
        Every loop follows its displacement along this path, `profile` (of stroke 1) giving
        the progress s(t); `axis` is then unused.
    reference : array_like (samples + 2, n_loops), optional
        The loops' positions (m, rad) at the samples k = 0 .. samples + 1, instead of a
        profile or a path (`user_reference.reference_samples` makes it).
    disturbances : Disturbances, optional
        Encoder quantisation and a sinusoidal force at the actuators.

    Raises
    ------
    LoopError
        No profile, path or reference; both a path and a reference; or a reference of the
        wrong shape.
    """

    def __init__(self, controller: DiscreteController | CallableFeedback,
                 profile: ThirdOrderProfile | None = None, *,
                 fs: float, samples: int, offsets: ArrayLike,
                 feedforward: LowFrequencyModel | None = None, axis: int = 0,
                 feedforward_forces: ArrayLike | None = None, path: MovePath | None = None,
                 reference: ArrayLike | None = None,
                 disturbances: Disturbances | None = None) -> None:
        self.controller, self.profile, self.path = controller, profile, path
        self.fs, self.samples, self.axis = float(fs), int(samples), int(axis)
        self.offsets = np.asarray(offsets, float).reshape(-1)
        self.feedforward_model = feedforward
        self.disturbances = disturbances
        n = self.offsets.size
        direction = np.eye(n)[self.axis]
        k = np.arange(self.samples + 2)
        t = k / self.fs
        self.given_reference = reference is not None
        if self.given_reference:
            if path is not None:
                raise LoopError("a move path and a given reference are two references: "
                                "give one")
            self.reference = np.asarray(reference, float)
            if self.reference.shape != (k.size, n):
                raise LoopError(f"the reference: expected shape ({k.size}, {n}) (samples + 2 "
                                f"rows), got {self.reference.shape}")
        elif profile is None:
            raise LoopError("a LoopController needs a profile, a path with its profile, or "
                            "a reference")
        elif path is None:
            self.reference = self.offsets + np.outer(profile.position(t), direction)
        else:
            self.reference = self.offsets + path.displacement(profile.position(t))
        self.explicit_forces = feedforward_forces is not None
        if self.explicit_forces:
            self.feedforward = np.asarray(feedforward_forces, float).reshape(k.size, n)
        elif feedforward is None:
            self.feedforward = np.zeros((k.size, n))
        elif self.given_reference:
            self.feedforward = reference_forces(feedforward, self.reference, self.fs)
        elif path is not None:
            self.feedforward = _path_forces(feedforward, profile, path, t, (k + 1) / self.fs,
                                            self.offsets)
        else:
            self.feedforward = forces(feedforward, profile, t, (k + 1) / self.fs,
                                      direction=direction, offsets=self.offsets)
        d = disturbances
        self.disturbance = None if d is None or d.amplitude is None else d.forces(k, self.fs)
        self.open_loop_forces = (self.feedforward if self.disturbance is None
                                 else self.feedforward + self.disturbance)
        self.sample_indexed = getattr(controller, "kind", None) == "callable"

    @property
    def compiled(self) -> bool:
        """Whether flexure.core.run_sampled_loop can run this controller: a state space (its
        quantum and disturbance included); a callable needs the Python loop."""
        return not self.sample_indexed

    @property
    def quantum(self) -> np.ndarray | None:
        """The encoders' quantum per loop (m, rad), or None (exact measurements)."""
        return None if self.disturbances is None else self.disturbances.quantum

    def reset(self) -> None:
        """Back to the zero state of the feedback, before sample 0."""
        self.controller.reset()

    def initial_output(self) -> np.ndarray:
        """u_0: the force on [t_0, t_1), before anything is measured.

        Returns
        -------
        ndarray (n_loops,)
            N (N m for a moment, V for a drive signal).
        """
        return self.open_loop_forces[0].copy()

    def step(self, k: int, y: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The next force from the measurement at sample k.

        Parameters
        ----------
        k : int
            The sample index (past `samples` the reference and force are held).
        y : array_like (n_loops,)
            The measured positions y_k, m (rad for an angle).

        Returns
        -------
        u : ndarray (n_loops,)
            u_k+1, N (N m, V).
        e : ndarray (n_loops,)
            e_k, m (rad): the error the controller sees (of the quantised position with
            encoder quantisation).
        """
        k = min(int(k), self.samples)  # past the end: the reference and force are held
        y = np.asarray(y, float)
        if self.disturbances is not None:
            y = self.disturbances.measured(y)
        e = self.reference[k] - y
        u = self.controller.step(e, k) if self.sample_indexed else self.controller.step(e)
        return u + self.open_loop_forces[k + 1], e

    # -- serialisation (the controller FMU is configured by this dictionary) ---------------
    def to_dict(self) -> dict:
        """The JSON-able settings `from_dict` rebuilds this controller from.

        Returns
        -------
        dict
            "controller", "profile", "fs" (Hz), "samples", "offsets" (m), "axis",
            "feedforward", "feedforward_forces" (N), "path", "reference" (m),
            "disturbances".
        """
        p = self.profile
        return {
            "controller": self.controller.to_dict(),
            "profile": None if p is None else {
                "stroke": p.stroke, "duration": p.duration, "jerk_time": p.jerk_time,
                "acceleration_time": p.acceleration_time, "start": p.start},
            "fs": self.fs, "samples": self.samples, "offsets": self.offsets.tolist(),
            "axis": self.axis,
            "feedforward": (None if self.feedforward_model is None
                            else self.feedforward_model.to_dict()),
            "feedforward_forces": (self.feedforward.tolist() if self.explicit_forces
                                   else None),
            "path": None if self.path is None else self.path.to_dict(),
            "reference": self.reference.tolist() if self.given_reference else None,
            "disturbances": None if self.disturbances is None else self.disturbances.to_dict(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> LoopController:
        """The controller of `to_dict`, at its zero initial state.

        Parameters
        ----------
        data : dict
            As `to_dict` writes it.

        Returns
        -------
        LoopController
        """
        ff, profile, disturbances = (data.get(key) for key in ("feedforward", "profile",
                                                                "disturbances"))
        return cls(DiscreteController.from_dict(data["controller"]),
                   None if profile is None else ThirdOrderProfile(**profile), fs=data["fs"],
                   samples=data["samples"], offsets=data["offsets"], axis=data["axis"],
                   feedforward=None if ff is None else LowFrequencyModel.from_dict(ff),
                   feedforward_forces=data.get("feedforward_forces"),
                   path=None if data.get("path") is None else MovePath.from_dict(data["path"]),
                   reference=data.get("reference"),
                   disturbances=None if disturbances is None
                   else Disturbances.from_dict(disturbances))


def _path_forces(model: LowFrequencyModel, profile, path: MovePath, t0, t1, offsets):
    """The feedforward (N) along `path`, held over the intervals [t0, t1); (len(t0), n)."""
    h = (t1 - t0)[:, None]
    s0, sdot0, _, _ = profile.evaluate(t0)
    s1, sdot1, _, _ = profile.evaluate(t1)
    velocity = (path.displacement(s1) - path.displacement(s0)) / h
    acceleration = (path.displacement(s1, 1) * sdot1[:, None]
                    - path.displacement(s0, 1) * sdot0[:, None]) / h
    static = np.zeros_like(velocity)
    for point, weight in zip(_GAUSS_POINTS, _GAUSS_WEIGHTS, strict=True):
        s = profile.position(t0 + (point + 1.0) / 2.0 * (t1 - t0))
        if path.forces is not None:
            static += weight / 2.0 * path.static_force(s)
        else:
            position = offsets + path.displacement(s)
            eq = 0.0 if model.equilibrium is None else np.asarray(model.equilibrium, float)
            static += weight / 2.0 * ((position - eq) @ model.stiffness.T)
    return acceleration @ model.mass.T + velocity @ model.damping.T + static
