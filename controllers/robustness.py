"""Robust stability of decentralised loops on a plant with its parasitic modes.

A design (feedback.py) sets each loop's gain on one model; `check_robustness` closes the same
discrete loops around another (the model with its parasitic modes, the chapter's 237-DOF
analogue) and reports, for the loop gain L(z) = P_zoh(z) z^-d C(z) (n x n, C diagonal):

- per loop, the gain, phase and modulus margins with the other loops open (L_kk) and with the
  other loops closed: the return ratio of loop k when the others act,
      L~_k = L_kk - L_ko (I + L_oo)^-1 L_ok        (o: every loop but k);
- the peak of the sensitivity, max over frequency of the largest singular value of
  S = (I + L)^-1 (its inverse is the MIMO modulus margin), and where it occurs;
- the closed-loop poles of all loops closed together (stable: all inside the unit circle).

Frequency responses come from one eigendecomposition of the sampled plant
(`frequency_response`), on a grid dense around the cross-over and across the half-power band
of every plant pole, so a narrow parasitic peak is not stepped over. Units: rad/s, Hz,
degrees; margins as ratios.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexure.core import blas_threads

from .errors import LoopError
from .lti import LinearSystem, delay, series, unity_feedback_poles, zoh


def frequency_response(sys, omega, *, eigen=None):
    """The response (n_out, n_in, len(omega)) of a discrete state space at z = exp(j w dt).

    Through the eigendecomposition A = V diag(lambda) V^-1, once:
    H(z) = (C V) diag(1 / (z - lambda)) (V^-1 B) + D, so each frequency costs O(n) per
    channel instead of a solve of (z I - A), O(n^3): a second instead of ten minutes for the
    manipulator's 1014-state plant over the 10 000 frequencies of a margin grid. Stiff,
    overdamped modes sample to a cluster of poles at z = 0 whose eigenvectors are nearly
    parallel (V's condition number 1e8 on that plant), yet the sum over the cluster, which
    is all |z| = 1 sees of it, stays accurate; so the result is checked against direct solves
    at three frequencies (to 1e-8 of the largest response) and the solves are used throughout
    only where that fails (a defective A, such as a chain of delays). `eigen`, the
    (eigenvalues, V) of A when the caller has them already, spares a second decomposition.
    """
    system = LinearSystem.of(sys)
    A, B, C, D = system.A, system.B, system.C, system.D
    z = np.exp(1j * np.asarray(omega, float) * system.dt)
    if A.size == 0:
        return np.repeat(D[:, :, None].astype(complex), z.size, axis=2)

    def solved(zk):
        try:
            return system.response(zk)
        except np.linalg.LinAlgError:  # z on a pole to round-off: nothing to evaluate there
            raise LoopError(
                f"the sampled plant's frequency response is singular at z = {zk:.17g}: at the "
                f"sample rate {1.0 / system.dt:g} Hz its poles lie within round-off of z = 1 "
                "(a sample rate far above the plant's dynamics); lower the sample rate"
            ) from None

    eigenvalues, V = np.linalg.eig(A) if eigen is None else eigen
    try:
        left, right = C @ V, np.linalg.solve(V, B)
    except np.linalg.LinAlgError:
        left = None
    if left is not None:
        # H_ij(z_f) = sum_n W_fn left_in right_nj: one product (len(z), n) @ (n, i j)
        residues = (left.T[:, :, None] * right[:, None, :]).reshape(A.shape[0], -1)
        weights = 1.0 / (z[:, None] - eigenvalues[None, :])  # (len(z), n)
        response = np.moveaxis((weights @ residues).reshape(z.size, *D.shape), 0, 2)
        response += D[:, :, None]
        probes = np.unique([0, z.size // 2, z.size - 1])
        direct = np.stack([solved(z[k]) for k in probes], axis=2)
        if np.all(np.isfinite(response)) and np.max(np.abs(response[:, :, probes] - direct)) \
                <= 1e-8 * max(np.max(np.abs(direct)), np.finfo(float).tiny):
            return response
    return np.stack([solved(zk) for zk in z], axis=2)


def margin_grid(crossover, dt, poles, *, damping_below=0.1):
    """Frequencies (rad/s) up to the Nyquist frequency for the margins of a discrete loop:
    logarithmic, dense around the cross-over, and across the half-power band of every lightly
    damped pole (damping ratio below `damping_below`) of the plant, `poles` (z). A more damped
    pole's peak is broad enough for the logarithmic grid (3000 points, 0.3 % apart), and a
    plant with hundreds of modes would otherwise get a grid of hundreds of thousands."""
    nyquist = np.pi / dt
    parts = [np.geomspace(crossover * 1e-3, nyquist * 0.999999, 3000),
             np.linspace(crossover * 0.5, crossover * 2.0, 501)]
    for z in np.atleast_1d(poles):
        if abs(z) == 0:
            continue
        s = np.log(complex(z)) / dt
        w, width = abs(s.imag), max(abs(s.real), 1e-6 * abs(s))
        if 0 < w < nyquist and width < damping_below * abs(s):
            parts.append(np.clip(w + width * np.linspace(-20, 20, 201), w * 0.5, nyquist))
    return np.unique(np.concatenate(parts))


def siso_margins(response, omega, *, with_crossover: bool = False):
    """Gain margin, phase margin (deg) and modulus margin of a discrete SISO loop gain given
    by its response on `omega` (rad/s), the sampled loop's (its sample period is in the
    response already); `with_crossover` adds the gain cross-over (rad/s) where the phase
    margin is taken (nan if |L| never crosses 1).

    python-control's 'frd' method (`control.stability_margins` of an interpolating FRD), on
    the same interpolant: the not-a-knot cubic spline through the response (spline.py; the
    interpolant of FITPACK's interpolating splprep, which python-control fits to the real
    and imaginary parts), refined where the grid shows a crossing of the negative real axis,
    a crossing of |L| = 1 or a local minimum of |1 + L|. python-control refines them with
    Brent's root finder and minimiser; here each is a root of a polynomial of the spline's
    piece on that interval (Im L, |L|^2 - 1, the derivative of |1 + L|^2): exact on the
    interpolant, with numpy alone. tests/test_robustness.py checks the two agree.
    """
    from .spline import cubic_pieces, roots_within

    L, w = np.asarray(response, complex), np.asarray(omega, float)
    pieces = cubic_pieces(w, L)
    h = np.diff(w)

    def first_root(polynomial_of, index, keep=lambda i, t: True):
        """On each interval of `index`, its first root of the polynomial `polynomial_of(c)`
        of the piece's coefficients c (that `keep` accepts), as a frequency (rad/s)."""
        found = []
        for i in index:
            roots = [t for t in roots_within(polynomial_of(pieces[i]), h[i]) if keep(i, t)]
            if roots:
                found.append(w[i] + roots[0])
        return np.array(found)

    def at(x):
        i = int(np.clip(np.searchsorted(w, x, side="right") - 1, 0, h.size - 1))
        return complex(np.polyval(pieces[i], x - w[i]))

    def squared(c):  # |c(t)|^2, a real polynomial of twice the degree
        return np.polymul(c.real, c.real) + np.polymul(c.imag, c.imag)

    # where L crosses the negative real axis (Im L changes sign, Re L < 0), and |L| crosses 1
    (index,) = np.nonzero(np.diff(np.sign(np.angle(-L))))
    w_180 = first_root(lambda c: c.imag, index[L.real[index] <= 0],
                       lambda i, t: np.polyval(pieces[i], t).real <= 0)
    (index,) = np.nonzero(np.diff(np.sign(np.abs(L) - 1.0)))
    w_c = first_root(lambda c: np.polysub(squared(c), [1.0]), index)
    # the local minima of |1 + L| on the grid, each refined on the two pieces around it
    distance = np.abs(L + 1.0)
    (index,) = np.nonzero(np.diff(np.sign(np.diff(distance))) > 0)
    w_s = []
    for i in index:
        candidates = [w[i + 1]]
        for j in (i, i + 1):
            shifted = pieces[j] + np.array([0, 0, 0, 1.0])  # 1 + L
            candidates += [w[j] + t for t in roots_within(np.polyder(squared(shifted)), h[j])]
        w_s.append(min(candidates, key=lambda x: abs(at(x) + 1.0)))
    w_s = np.array(w_s)

    with np.errstate(divide="ignore"):  # |L| = 0 gives an infinite margin
        gm_all = 1.0 / np.abs([at(x) for x in w_180]) if w_180.size else np.zeros(0)
    pm_all = np.array([np.remainder(np.angle(at(x), deg=True), 360.0) - 180.0 for x in w_c])
    sm_all = np.array([abs(at(x) + 1.0) for x in w_s])
    # python-control's choice: the gain margin nearest 1 (in log), the smallest |phase
    # margin| and its cross-over, the smallest modulus margin
    if gm_all.size and not np.isinf(gm_all).all():
        with np.errstate(divide="ignore"):
            gm = float(gm_all[np.argmin(np.abs(np.log(gm_all)))])
    else:
        gm = math.inf
    if pm_all.size:
        k = int(np.argmin(np.abs(pm_all)))
        pm, crossover = float(pm_all[k]), float(w_c[k])
    else:
        pm, crossover = math.inf, math.nan
    sm = float(sm_all.min()) if sm_all.size else math.inf
    if with_crossover:
        return gm, pm, sm, crossover
    return gm, pm, sm


def loop_response(plant_d, controller, delay_samples, omega, *, eigen=None):
    """L(e^(j w dt)) = P(z) z^-d C(z), (n, n, len(omega)), for the sampled plant and the
    diagonal discrete controller."""
    P = frequency_response(plant_d, omega, eigen=eigen)
    K = frequency_response(controller, omega)
    z = np.exp(1j * omega * plant_d.dt)
    return np.einsum("ijf,jkf->ikf", P, K) * z ** (-delay_samples)


def others_closed(L, k):
    """The return ratio of loop k with every other loop closed, over the frequencies."""
    n = L.shape[0]
    if n == 1:
        return L[0, 0]
    o = [i for i in range(n) if i != k]
    Loo = np.moveaxis(L[np.ix_(o, o)], 2, 0)  # (F, n-1, n-1)
    Lko = np.moveaxis(L[np.ix_([k], o)], 2, 0)  # (F, 1, n-1)
    Lok = np.moveaxis(L[np.ix_(o, [k])], 2, 0)  # (F, n-1, 1)
    eye = np.eye(n - 1)
    return L[k, k] - (Lko @ np.linalg.solve(eye + Loo, Lok))[:, 0, 0]


def delay_block(n, samples, dt):
    """z^-samples on each of n channels: a discrete `LinearSystem` (n inputs, n outputs;
    ValueError for a negative number of samples)."""
    return delay(n, samples, dt)


@dataclass(frozen=True)
class Robustness:
    """The closed loops' margins, sensitivity peak and poles on one plant."""

    plant: str
    states: int
    loops: list  # the loops' names "F1 -> x1"
    open_margins: np.ndarray  # (n_loops, 3): gain margin, phase margin (deg), modulus margin
    closed_margins: np.ndarray  # (n_loops, 3), the other loops closed
    sensitivity_peak: float  # max over w of the largest singular value of (I + L)^-1
    peak_frequency_hz: float
    closed_loop_poles: np.ndarray
    crossovers_rad_s: np.ndarray | None = None  # (n_loops,) each loop's, the others open

    @property
    def spectral_radius(self) -> float:
        """The largest closed-loop pole magnitude (< 1: stable)."""
        return float(np.max(np.abs(self.closed_loop_poles)))

    @property
    def stable(self) -> bool:
        return self.spectral_radius < 1.0

    def summary(self) -> dict:
        """The numbers a report prints (JSON-able)."""
        def rows(margins):
            return [{"loop": name, "gain_margin": gm, "phase_margin_deg": pm,
                     "modulus_margin": sm}
                    for name, (gm, pm, sm) in zip(self.loops, margins.tolist(), strict=True)]
        return {"plant": self.plant, "states": self.states, "stable": self.stable,
                "closed_loop_spectral_radius": self.spectral_radius,
                "sensitivity_peak": self.sensitivity_peak,
                "sensitivity_peak_hz": self.peak_frequency_hz,
                "others_open": rows(self.open_margins),
                "others_closed": rows(self.closed_margins)}


@blas_threads()
def check_robustness(design, plant, *, name: str = "") -> Robustness:
    """Close `design`'s discrete loops around `plant` and report their robustness.

    Parameters
    ----------
    design : FeedbackDesign
        The loops (their controller, sample rate and delay).
    plant : control.StateSpace or LinearSystem
        From the loops' inputs (N) to their outputs (m), in the loops' order: continuous
        (e.g. ``state_space(model)[outputs, inputs]``), sampled here with a zero-order hold,
        or already sampled so at the loops' period 1 / fs (the designer has it: sampling a
        large plant is a matrix exponential of its size).
    name : str
        What the plant is, for the report.

    Returns
    -------
    Robustness

    Raises
    ------
    ValueError
        A discrete plant at another sample period.
    """
    dt = 1.0 / design.sample_rate_hz
    plant = LinearSystem.of(plant)
    if not plant.discrete:
        plant_d = zoh(plant, dt)
    elif plant.dt is not True and math.isclose(plant.dt, dt, rel_tol=1e-12):
        plant_d = plant
    else:
        raise ValueError(f"a discrete plant needs the loops' sample period {dt:.9g} s, got "
                         f"{plant.dt}")
    n = len(design.pairs)
    # one eigendecomposition of the plant: its poles place the grid, its modes the response
    eigen = np.linalg.eig(plant_d.A) if plant_d.states else None
    omega = margin_grid(design.crossover_rad_s, dt, eigen[0] if eigen is not None else np.zeros(0))
    L = loop_response(plant_d, design.feedback, design.delay_samples, omega, eigen=eigen)
    open_m = np.array([siso_margins(L[k, k], omega, with_crossover=True)
                       for k in range(n)])
    open_m, crossovers = open_m[:, :3], open_m[:, 3]
    closed_m = open_m if n == 1 else np.array(
        [siso_margins(others_closed(L, k), omega) for k in range(n)])
    S = np.linalg.inv(np.eye(n)[None] + np.moveaxis(L, 2, 0))
    peaks = np.linalg.svd(S, compute_uv=False)[:, 0]
    delays = delay_block(n, design.delay_samples, dt)
    poles = unity_feedback_poles(series(design.feedback, delays, plant_d))
    return Robustness(
        plant=name, states=int(plant_d.states),
        loops=[f"{p.input_name} -> {p.output_name}" for p in design.pairs],
        open_margins=open_m, closed_margins=closed_m,
        sensitivity_peak=float(peaks.max()),
        peak_frequency_hz=float(omega[np.argmax(peaks)] / (2 * np.pi)),
        closed_loop_poles=poles, crossovers_rad_s=crossovers)
