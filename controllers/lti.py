"""Linear time-invariant systems in plain numpy: the part of python-control the loop uses.

A `LinearSystem` is a state space (A, B, C, D) with a sample period dt (s; 0 for a continuous
system):

    continuous:  x' = A x + B u,         y = C x + D u
    discrete:    x_k+1 = A x_k + B u_k,  y_k = C x_k + D u_k

The loop's design (feedback.py) and its robustness check (robustness.py) need only a few
operations on such systems, each the same arithmetic as python-control's (the tests hold the
two side by side on the real designs):

- `transfer_function`: a SISO N(s) / D(s) or N(z) / D(z) realised in the controllable
  canonical form (scipy.signal.tf2ss's, which python-control uses without slycot);
- `tustin`: the bilinear discretisation with pre-warping of such a transfer function
  (control.c2d(..., "tustin", prewarp_frequency=w));
- `zoh`: the exact discretisation with a zero-order hold (control.c2d(..., "zoh"));
- `series`, `append`, `delay`: interconnections (control's `*`, `append`, z^-d);
- `LinearSystem.response` and `LinearSystem.poles`, and `unity_feedback_poles`: the
  frequency response at a point z and the poles of the loop closed with -I.

python-control takes a second to import (scipy.signal and matplotlib's pyplot come with it),
ten times the loop itself; with these the loop imports it only where a user asks for one of
its objects (`LinearSystem.to_control`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LinearSystem:
    """A state space (A, B, C, D) with sample period `dt` (s), 0 for a continuous system.

    Units are the caller's: inputs and outputs in the units of the signals they carry (N,
    m, ...); the states' in whatever the realisation makes them.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt: float = 0.0

    def __post_init__(self) -> None:
        D = np.atleast_2d(np.asarray(self.D, float))
        n = np.asarray(self.A).size and np.atleast_2d(self.A).shape[0]
        A = np.asarray(self.A, float).reshape(n, n)
        B = np.asarray(self.B, float).reshape(n, D.shape[1])
        C = np.asarray(self.C, float).reshape(D.shape[0], n)
        for name, value in zip("ABCD", (A, B, C, D), strict=True):
            object.__setattr__(self, name, value)

    @classmethod
    def of(cls, system) -> LinearSystem:
        """`system` as a LinearSystem: itself, or anything with A, B, C, D and dt (a
        python-control StateSpace), or a python-control TransferFunction (converted by
        python-control, which the caller has imported already). A dt of True (python-control's
        unspecified sample period) stays True."""
        if isinstance(system, LinearSystem):
            return system
        if not hasattr(system, "A"):
            import control  # a transfer function: the caller's python-control realises it

            system = control.ss(system)
        dt = system.dt
        return cls(system.A, system.B, system.C, system.D,
                   dt if dt is True else float(dt or 0.0))

    @property
    def states(self) -> int:
        """The number of states."""
        return self.A.shape[0]

    @property
    def discrete(self) -> bool:
        """Whether the system is sampled (dt > 0, or python-control's unspecified True)."""
        return self.dt is True or self.dt > 0

    def subsystem(self, outputs, inputs) -> LinearSystem:
        """The system from the inputs `inputs` to the outputs `outputs` (lists of indices),
        its states unchanged (python-control's `sys[outputs, inputs]`)."""
        return LinearSystem(self.A, self.B[:, inputs], self.C[outputs, :],
                            self.D[np.ix_(outputs, inputs)], self.dt)

    def response(self, point: complex) -> np.ndarray:
        """C (point I - A)^-1 B + D, (outputs, inputs) complex: the frequency response at
        z = exp(j w dt) for a discrete system, at s = j w for a continuous one."""
        if self.states == 0:
            return self.D.astype(complex)
        solved = np.linalg.solve(point * np.eye(self.states) - self.A, self.B)
        return self.C @ solved + self.D

    def poles(self) -> np.ndarray:
        """The eigenvalues of A (z for a discrete system, s for a continuous one)."""
        return np.linalg.eigvals(self.A) if self.states else np.zeros(0, complex)

    def to_control(self):
        """The system as a python-control StateSpace (imports python-control)."""
        import control

        return control.ss(self.A, self.B, self.C, self.D, self.dt)


def transfer_function(num, den, dt: float = 0.0) -> LinearSystem:
    """The SISO N / D (coefficients in descending powers of s or z) in the controllable
    canonical form: A's first row -d_1..-d_n (D monic), B = e_1, C = n_i - n_0 d_i,
    D = n_0 (scipy.signal.tf2ss's realisation). ValueError for an improper one."""
    num, den = np.trim_zeros(np.atleast_1d(np.asarray(num, float)), "f"), \
        np.trim_zeros(np.atleast_1d(np.asarray(den, float)), "f")
    if den.size == 0:
        raise ValueError("a transfer function needs a nonzero denominator")
    if num.size > den.size:
        raise ValueError("the transfer function is improper (more zeros than poles)")
    num, den = num / den[0], den / den[0]
    num = np.concatenate([np.zeros(den.size - num.size), num])
    n = den.size - 1
    A = np.vstack([-den[None, 1:], np.eye(n - 1, n)]) if n else np.zeros((0, 0))
    B = np.eye(n, 1)
    C = num[None, 1:] - num[0] * den[None, 1:]
    return LinearSystem(A, B, C, [[num[0]]], dt)


def tustin(num, den, dt: float, *, prewarp: float | None = None):
    """The bilinear (Tustin) discretisation of N(s) / D(s) at the sample period `dt` (s):
    s = k (z - 1) / (z + 1), k = 2 / dt, or k = w / tan(w dt / 2) pre-warped at w (rad/s)
    so that the discrete response at z = exp(j w dt) is the continuous one at s = j w.

    Returns (num_z, den_z), coefficients in descending powers of z, den_z monic."""
    num, den = np.atleast_1d(np.asarray(num, float)), np.atleast_1d(np.asarray(den, float))
    k = 2.0 / dt if prewarp is None else prewarp / math.tan(prewarp * dt / 2.0)
    order = max(num.size, den.size) - 1

    def substituted(coefficients):
        # sum_i c_i s^(order - i) times (z + 1)^order, c padded to the common order
        padded = np.concatenate([np.zeros(order + 1 - coefficients.size), coefficients])
        total = np.zeros(order + 1)
        for i, c in enumerate(padded):
            power = order - i
            term = np.polymul(np.poly(np.ones(power)), np.poly(-np.ones(order - power)))
            total += c * k**power * term
        return total

    num_z, den_z = substituted(num), substituted(den)
    return num_z / den_z[0], den_z / den_z[0]


def zoh(system: LinearSystem, dt: float) -> LinearSystem:
    """The continuous `system` sampled with a zero-order hold at the period `dt` (s):
    [[Ad, Bd], [0, I]] = expm(dt [[A, B], [0, 0]]), C and D unchanged (exact for inputs held
    over each period; control.c2d(sys, dt, "zoh") computes the same matrix exponential)."""
    from scipy.linalg import expm  # loaded with flexure.core's models already

    n, m = system.states, system.B.shape[1]
    augmented = np.zeros((n + m, n + m))
    augmented[:n, :n], augmented[:n, n:] = system.A, system.B
    sampled = expm(dt * augmented)[:n, :]
    return LinearSystem(sampled[:, :n], sampled[:, n:], system.C, system.D, dt)


def series(*systems: LinearSystem) -> LinearSystem:
    """The systems in series, the signal through the first, then the second, ... (with
    python-control's operators: last * ... * first). The states: the first's, then the
    second's, ...; the sample periods must agree."""
    first, *rest = systems
    A, B, C, D = first.A, first.B, first.C, first.D
    for after in rest:
        if not math.isclose(after.dt, first.dt, rel_tol=1e-12, abs_tol=0.0):
            raise ValueError(f"systems in series need one sample period, got {first.dt} "
                             f"and {after.dt}")
        A = np.block([[A, np.zeros((A.shape[0], after.states))],
                      [after.B @ C, after.A]])
        B = np.vstack([B, after.B @ D])
        C = np.hstack([after.D @ C, after.C])
        D = after.D @ D
    return LinearSystem(A, B, C, D, first.dt)


def append(*systems: LinearSystem) -> LinearSystem:
    """The systems side by side, block-diagonal (control.append): inputs, outputs and states
    of the first, then of the second, ..."""
    from scipy.linalg import block_diag  # loaded with flexure.core's models already

    return LinearSystem(block_diag(*[s.A for s in systems]), block_diag(*[s.B for s in systems]),
                        block_diag(*[s.C for s in systems]), block_diag(*[s.D for s in systems]),
                        systems[0].dt)


def delay(channels: int, samples: int, dt: float) -> LinearSystem:
    """z^-samples on each of `channels` channels, sampled at `dt` (s): a shift register of
    `samples` states per channel (python-control's realisation of 1 / z^samples), or the
    identity for no delay. ValueError for a negative number of samples."""
    if samples < 0:
        raise ValueError(f"delay_samples must be >= 0, got {samples}")
    if samples == 0:
        return LinearSystem(np.zeros((0, 0)), np.zeros((0, channels)),
                            np.zeros((channels, 0)), np.eye(channels), dt)
    one = transfer_function([1.0], np.eye(1, samples + 1)[0], dt)
    return append(*[one] * channels)


def unity_feedback_poles(loop: LinearSystem) -> np.ndarray:
    """The poles of the loop gain `loop` closed with -I (control.feedback(loop, I)): the
    eigenvalues of A - B (I + D)^-1 C."""
    n = loop.D.shape[0]
    closed = loop.A - loop.B @ np.linalg.solve(np.eye(n) + loop.D, loop.C)
    return np.linalg.eigvals(closed) if closed.size else np.zeros(0, complex)
