"""What the loop meets besides its reference: encoder quantisation and a sinusoidal force.

Both live in the `LoopController` (loop_controller.py), so every plant (in-process, the scene
FMU under fmpy, the controller FMU in libcosim, which runs the same LoopController from its
`to_dict()`) computes the same numbers.

- **Encoder quantisation**: the controller sees each loop's measured position rounded to the
  nearest multiple of its quantum q (m, or rad on an angle),

      y_meas,k = q round(y_k / q),      |y_meas,k - y_k| <= q / 2

  (round half to even, numpy's rule); the errors reported stay r - y with the true y.
- **Sinusoidal disturbance**: a force (N, or N m on an angle) of amplitude a and frequency f
  (Hz; default 50 Hz, the mains disturbance the chapter's experiment saw) added at each loop's
  actuator to the held force,

      d_k = a sin(2 pi f t_k),     t_k = k / fs,     held over [t_k, t_k+1) with u_k.

  This is the sine sampled at the sample instants and held, not the continuous sine: the held
  staircase's component at f has the amplitude sinc(pi f / fs) a (0.99974 a at 50 Hz and
  4 kHz) and lags the sine by pi f / fs (2.25 degrees there), and it carries images at
  fs -+ f, k fs -+ f. It is exactly the input of the sampled (zero-order-hold) linear model,
  so the loop's linear response to it is the sampled process sensitivity at f. f must lie
  below the Nyquist frequency fs / 2.

`loop_disturbances` checks the settings and gives a `Disturbances`, or None when there are
none (the loop then runs as without this module, to the bit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import LoopError

MAINS_HZ = 50.0


@dataclass(frozen=True)
class Disturbances:
    """Encoder quantisation and a sinusoidal force at the actuators, per loop.

    quantum : (n_loops,) m or rad, or None (exact measurements)
    amplitude : (n_loops,) in the plant inputs' units (N, N m; V for an input a current-driven
        voice coil takes, see `loop_design.build_loop`), or None (no disturbance)
    frequency_hz : Hz
    """

    quantum: np.ndarray | None = None
    amplitude: np.ndarray | None = None
    frequency_hz: float = MAINS_HZ

    def measured(self, y) -> np.ndarray:
        """The positions the controller sees (m, rad) for the true ones `y` (n_loops,)."""
        y = np.asarray(y, float)
        if self.quantum is None:
            return y
        return self.quantum * np.round(y / self.quantum)

    def forces(self, k, fs: float) -> np.ndarray:
        """d_k (len(k), n_loops) at the sample indices `k` (a disturbance is set)."""
        k = np.asarray(k, float)
        return np.outer(np.sin(2.0 * np.pi * self.frequency_hz * k / fs), self.amplitude)

    def to_dict(self) -> dict:
        """The disturbances for JSON: "quantum" and "amplitude" as lists (or None), and
        "frequency_hz" (Hz)."""
        return {"quantum": None if self.quantum is None else self.quantum.tolist(),
                "amplitude": None if self.amplitude is None else self.amplitude.tolist(),
                "frequency_hz": self.frequency_hz}

    @classmethod
    def from_dict(cls, data: dict) -> Disturbances:
        """The disturbances that `to_dict` wrote as `data`."""
        return cls(*(None if data[key] is None else np.asarray(data[key], float)
                     for key in ("quantum", "amplitude")), float(data["frequency_hz"]))


def per_loop(value, n_loops: int, what: str, unit: str) -> np.ndarray:
    """`value` (a number, or one per loop) as an array (n_loops,) of positive finite numbers;
    LoopError naming `what` otherwise."""
    try:
        array = np.asarray(value, float).reshape(-1)
    except (TypeError, ValueError):
        raise LoopError(f"{what} must be a number ({unit}) or one per loop, got "
                        f"{value!r}") from None
    if array.size == 1:
        array = np.full(n_loops, array[0])
    if array.size != n_loops:
        raise LoopError(f"{what}: expected one value or {n_loops} (one per loop), got "
                        f"{array.size}")
    if not np.all(np.isfinite(array) & (array > 0)):
        raise LoopError(f"{what} must be positive and finite ({unit}), got {value!r}")
    return array


def loop_disturbances(n_loops: int, *, fs: float, quantum=None, amplitude=None,
                      frequency_hz: float = MAINS_HZ, units=("m", "N")) -> Disturbances | None:
    """The checked disturbances of a loop of `n_loops` loops sampled at `fs` Hz, or None.

    Parameters
    ----------
    quantum : float or sequence, optional
        The encoders' quantum (m, rad), one for every loop or one per loop.
    amplitude : float or sequence, optional
        The sinusoidal force's amplitude (N, N m), one for every loop or one per loop.
    frequency_hz : float
        Its frequency (Hz), 0 < f < fs / 2.
    units : (str, str)
        The loops' position and force units, for the messages.
    """
    position, force = units
    q = None if quantum is None else per_loop(quantum, n_loops, "the encoder quantum", position)
    a = None if amplitude is None else per_loop(amplitude, n_loops, "the disturbance amplitude",
                                                force)
    if a is not None:
        f = float(frequency_hz) if isinstance(frequency_hz, (int, float, np.floating)) \
            else np.nan
        if not (np.isfinite(f) and 0 < f < fs / 2):
            raise LoopError(f"the disturbance frequency must lie between 0 and the Nyquist "
                            f"frequency fs / 2 = {fs / 2:g} Hz (held samples cannot carry "
                            f"more), got {frequency_hz!r}")
    else:
        f = MAINS_HZ
    if q is None and a is None:
        return None
    return Disturbances(q, a, f)
