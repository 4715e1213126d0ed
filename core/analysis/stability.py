"""Whether a static equilibrium is stable: the tangent stiffness on the DOFs.

Newton's method converges to any root of the generalised force Q(q) = 0, stable or not: past
a buckling load (the planar stage's leaves at 100 N against their 78.75 N), or after a
snap-through (the stage lying flat under a sideways load), it returns an equilibrium that
the mechanism cannot rest in. Its natural frequencies then come out imaginary (flexure
prints such a frequency negative) and its stresses belong to no real state. An equilibrium is
unstable when the tangent stiffness K = K0 + G0 (+ the load stiffness of follower loads) on
the DOFs has a negative eigenvalue: a direction in which the potential energy decreases.

Eigenvalues of the symmetric part of K below -NEGATIVE_RTOL times its largest magnitude
count as negative: a singular K (a kinematic DOF with no stiffness) gives round-off values of
either sign about 1e-16 of the largest, which are no instability.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..numerics.blas import blas_threads

if TYPE_CHECKING:  # names for the annotations only
    from ..mechanics.mechanics import Mechanics
    from ..model import Model
    from .statics import StaticSolution

NEGATIVE_RTOL = 1e-9


@blas_threads()
def negative_stiffness(K: np.ndarray) -> tuple[int, float, float]:
    """(count, lowest, largest magnitude) of the eigenvalues of the symmetric part of the
    tangent stiffness `K` (NDOF x NDOF; N/m, N m/rad and mixed, as the DOFs' units) that
    are negative beyond NEGATIVE_RTOL of the largest magnitude."""
    K = np.asarray(K, dtype=float)
    if K.size == 0:
        return 0, 0.0, 0.0
    eigenvalues = np.linalg.eigvalsh(0.5 * (K + K.T))
    largest = float(np.max(np.abs(eigenvalues)))
    count = int(np.sum(eigenvalues < -NEGATIVE_RTOL * largest))
    return count, float(eigenvalues[0]), largest


@blas_threads()
def clearly_stable(K: np.ndarray) -> bool:
    """Whether the tangent stiffness `K` (NDOF x NDOF) has no eigenvalue below
    -NEGATIVE_RTOL times its largest magnitude, shown by one Cholesky factorisation.

    With tau = NEGATIVE_RTOL max|K_ii| (at most NEGATIVE_RTOL times the largest eigenvalue
    magnitude of the symmetric part: |K_ii| <= max|lambda|), K_s + tau I factors exactly when
    every eigenvalue of K_s lies above -tau: then none lies below the threshold of
    `negative_stiffness`. False means "not shown" (a K close to the threshold, or unstable):
    the eigenvalues decide. At 816 DOFs 0.02 s against 1.6 s for the eigenvalues, with one
    BLAS thread (`blas_threads`, as every function here): outside it OpenBLAS's two threads
    made this one factorisation 0.8 to 1.1 s of CPU of `flexure analyze manipulator` on the
    loaded 2-core machine.
    """
    K = np.asarray(K, dtype=float)
    if K.size == 0:
        return True
    symmetric = 0.5 * (K + K.T)
    tau = NEGATIVE_RTOL * float(np.max(np.abs(np.diag(symmetric))))
    if not (tau > 0.0 and np.all(np.isfinite(symmetric))):
        return False
    try:
        np.linalg.cholesky(symmetric + tau * np.eye(K.shape[0]))
    except np.linalg.LinAlgError:
        return False
    return True


@blas_threads()
def tangent_stiffness(model: Model, solution: StaticSolution,
                      mechanics: Mechanics | None = None) -> np.ndarray:
    """K0 + G0 (NDOF x NDOF) at a static equilibrium, with the loads that hold it (the
    matrix of the equilibrium's last Newton step)."""
    from ..mechanics.mechanics import Mechanics
    from ..mechanics.motions import held

    mech = mechanics or Mechanics(model)
    config = solution.config
    return held(model, mech.structural_stiffness(config) + mech.geometric_stiffness(
        config, solution.stress_resultants, solution.load_factor, inputs=solution.port_values))


@blas_threads()
def instability_warnings(K: np.ndarray, *, frequencies_hz=None, descriptions=None) -> list[str]:
    """The warning that an equilibrium with tangent stiffness `K` is unstable (empty when it
    is not), naming the modes whose frequency is imaginary (negative in `frequencies_hz`,
    Hz, with their `descriptions`) when the modes are known."""
    if clearly_stable(K):  # the usual case, without the eigenvalues
        return []
    count, lowest, largest = negative_stiffness(K)
    if count == 0:
        return []
    modes = ""
    if frequencies_hz is not None:
        imaginary = [i for i, f in enumerate(frequencies_hz) if f < 0.0]
        named = [f"mode {i + 1} ({frequencies_hz[i]:.4g} Hz"
                 + (f": {descriptions[i]}" if descriptions is not None else "") + ")"
                 for i in imaginary[:3]]
        if named:
            modes = (f"; imaginary frequencies (shown negative): {', '.join(named)}"
                     + (" ..." if len(imaginary) > 3 else ""))
    return [f"unstable equilibrium: the tangent stiffness K0 + G0 has {count} negative "
            f"eigenvalue{'s' * (count > 1)} (lowest {lowest:.4g}, against {largest:.4g} at "
            f"most; SI units of the DOFs){modes}. The load is past a buckling or "
            "snap-through load: the mechanism cannot rest here, and the stresses and "
            "frequencies of this state are no result"]
