"""State-space models of the declared inputs and outputs, as python-control objects
(`state_space`) or as their plain matrices (`state_space_matrices`), and the static gain
(`static_gain`).

With the state [dq, dq'] (deviations from the configuration of the linear model):

    A = [[0, I], [-M0^-1 K, -M0^-1 C0]]     B = [[0], [M0^-1 DF^T b]]
    C = [[DF_y, 0]] for positions, [[0, DF_y]] for velocities,  D = 0;
    C = DF_y [-M0^-1 K, -M0^-1 C0],  D = DF_y M0^-1 DF^T b for accelerations

where b holds a unit force on the coordinate of each input (SPACAR's INPUTF) and DF_y the rows
of DF of each output coordinate (OUTX). A port about a global axis of a 3-D rotational node
is nonlinear in the coordinates; linearised at the configuration x of the linear model, its b
column is the moment's generalised force 2 E_k(lambda)^T and its C row (d y / d lambda) DF_l:
the rotation-vector component's gradient for an angle, 2 E_k for an angular velocity
(`flexure.core.mechanics.ports`), and 2 E_k for an angular acceleration, whose convective
term (quadratic in dq') has no linear part. An acceleration output's row is DF_y times the
lower rows of A and B: an accelerometer has a feedthrough D. Units: inputs N (N m), outputs
m, m/s, m/s2 (rad, rad/s, rad/s2); each output's quantity and order are
`flexure.core.mechanics.output_quantities`'. The columns DF^T b and the rows DF_y are the
linear model's (`LinearModel.port_rows`: the compiled engine's where it linearised the model,
else the numpy ports').
An input a voice-coil actuator drives is its drive signal (V), and a voltage-driven coil adds
its current (A) to the state, [dq, dq', di] (`LinearModel.state_matrices`, with the same b
columns of the ports): the transfer from the drive signal to a position then shows the
back-EMF damping and the coil's pole near -R/L.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SceneError
from ..mechanics.output_quantities import output_order
from ..numerics.blas import blas_threads
from ..numerics.ties import TIE_RTOL
from .linearization import linearize

if TYPE_CHECKING:  # names for the annotations only
    import control
    from numpy.typing import ArrayLike

    from ..model import Model
    from .linearization import LinearModel


@blas_threads()
def state_space(model: Model, *, linear_model: LinearModel | None = None) -> control.StateSpace:
    """The linearised model as a control.StateSpace with named inputs, outputs and states.

    Parameters
    ----------
    model : Model
        With [inputs] and [outputs].
    linear_model : LinearModel, optional
        The linearisation to use (default: at the static equilibrium under the scene's
        loads).

    Returns
    -------
    control.StateSpace
        States [dq, dq'] (m, rad; m/s, rad/s), plus the coil currents (A) of voltage-driven
        actuators; inputs N, N m (V for an actuator's drive signal); outputs m, rad, m/s,
        rad/s, m/s2, rad/s2; D = 0 but for acceleration outputs.

    Raises
    ------
    SceneError
        The model declares no inputs or no outputs.
    """
    import control  # 0.5 s to import (scipy.signal, matplotlib): only where it is used

    A, B, C, D, states = _matrices(model, linear_model)
    return control.ss(
        A, B, C, D,
        inputs=[p.name for p in model.inputs],
        outputs=[p.name for p in model.outputs],
        states=states,
        name=model.name,
    )


@blas_threads()
def state_space_matrices(model: Model, *, linear_model: LinearModel | None = None,
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The matrices A, B, C, D of `state_space(model)`, as numpy arrays, without importing
    python-control (a second of a command's start-up that needs no more than the matrices).

    Parameters
    ----------
    model : Model
        With [inputs] and [outputs].
    linear_model : LinearModel, optional
        The linearisation to use (default: at the static equilibrium under the scene's
        loads).

    Returns
    -------
    (A, B, C, D) : tuple of ndarray
        (n, n), (n, n_inputs), (n_outputs, n), (n_outputs, n_inputs) for the continuous
        system x' = A x + B u, y = C x + D u; the states, inputs and outputs (and their
        units) those of `state_space`.

    Raises
    ------
    SceneError
        The model declares no inputs or no outputs.
    """
    return _matrices(model, linear_model)[:4]


@blas_threads()
def static_gain(model: Model, *, linear_model: LinearModel | None = None) -> np.ndarray:
    """The static gain D - C A^-1 B of `state_space(model)`: the outputs' deviations per unit
    input at rest (the compliance from forces to positions, m/N).

    Without actuators, A [u; v] = B gives v = 0 and K u = -DF^T b, so the gain is
    C_pos K^-1 DF^T b (C_pos the outputs' rows on dq; a velocity output's gain is 0): one
    solve of the NDOF tangent K instead of A's three solves of M0 and one of the 2 NDOF A
    (7 ms against 70 ms of CPU with one BLAS thread on the 507-DOF manipulator_reduced; the
    two agree to 1e-10 of the largest gain there, A's solve carrying cond(A)). A
    voltage-driven actuator adds its coil's current to the state: then the gain is
    D - C A^-1 B itself.

    Parameters
    ----------
    model : Model
        With [inputs] and [outputs].
    linear_model : LinearModel, optional
        The linearisation to use (default: at the static equilibrium under the scene's
        loads).

    Returns
    -------
    ndarray (n_outputs, n_inputs)
        Output units per input unit: m/N, rad/(N m) (m/V where an actuator's drive signal is
        the input); 0 for a velocity output.

    Raises
    ------
    SceneError
        The model declares no inputs or no outputs.
    numpy.linalg.LinAlgError
        The tangent stiffness is singular (a mechanism: no static gain).
    """
    if model.actuators or not model.inputs or not model.outputs:
        A, B, C, D, _ = _matrices(model, linear_model)  # or its SceneError
        return D - C @ np.linalg.solve(A, B)
    lin = linear_model or linearize(model)
    forces, rows = lin.port_rows()
    positions = np.array([output_order(port) == 0 for port in model.outputs])
    gain = np.zeros((len(model.outputs), len(model.inputs)))
    gain[positions] = rows[positions] @ np.linalg.solve(lin.K, forces.T)
    return gain


def _matrices(model, linear_model):
    """A, B, C, D and the states' names of the model's state space (module docstring)."""
    if not model.inputs or not model.outputs:
        raise SceneError(
            f"{model.source}: a state-space model needs [inputs] and [outputs]; "
            f"{model.name!r} declares {len(model.inputs)} input(s), {len(model.outputs)} output(s)"
        )
    lin = linear_model or linearize(model)
    n = lin.M0.shape[0]
    forces, rows = lin.port_rows()  # the engine's where it linearised, else numpy's
    if model.actuators:
        A, B, states = lin.state_matrices()
    else:  # the force and moment inputs alone: the same numbers, as they have been computed
        M_inv_K = np.linalg.solve(lin.M0, lin.K)
        M_inv_C = np.linalg.solve(lin.M0, lin.C0)
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-M_inv_K, -M_inv_C]])
        B = np.vstack([np.zeros((n, forces.shape[0])), np.linalg.solve(lin.M0, forces.T)])
        dofs = model.free_dof_names  # the DOFs proper: kinematic inputs are held
        states = [f"{d}" for d in dofs] + [f"{d}_dot" for d in dofs]
    C = np.zeros((len(model.outputs), A.shape[0]))
    D = np.zeros((len(model.outputs), len(model.inputs)))
    for row, port in enumerate(model.outputs):
        order = output_order(port)
        if order < 2:  # dq or dq', a block of the state
            C[row, order * n:(order + 1) * n] = rows[row]
        else:  # dq'' = A[n:2n] z + B[n:2n] du: an accelerometer feeds the inputs through
            C[row] = rows[row] @ A[n: 2 * n]
            D[row] = rows[row] @ B[n: 2 * n]
    return A, B, C, D, states


@blas_threads()
def principal_gains(model: Model, frequencies_hz: ArrayLike, *,
                    linear_model: LinearModel | None = None) -> np.ndarray:
    """The singular values of the transfer matrix G(j w) = C (j w I - A)^-1 B of
    `state_space(model)`: the principal gains whose peaks are the natural frequencies the
    inputs excite and the outputs see (the chapter's Fig. 3.5).

    Evaluated through the eigenvectors of A, G(j w) = (C V) diag(1 / (j w - lambda))
    (V^-1 B), O(n) per frequency instead of a 2 NDOF solve, unless V is ill-conditioned
    (cond > 1e8: defective or nearly so), where each frequency solves (j w I - A) X = B.

    Parameters
    ----------
    model : Model
        With [inputs] and [outputs].
    frequencies_hz : array_like
        The frequencies, Hz, finite and >= 0.
    linear_model : LinearModel, optional
        The linearisation to use (default: at the static equilibrium under the scene's
        loads).

    Returns
    -------
    ndarray (n_frequencies, min(n_outputs, n_inputs))
        The singular values, largest first at each frequency, in output units per input
        unit (m/N, rad/(N m), m/(s N), ...).

    Raises
    ------
    SceneError
        The model declares no inputs or no outputs.
    ValueError
        A frequency is negative or not finite.
    """
    A, B, C, D = state_space_matrices(model, linear_model=linear_model)
    omega = 2.0 * np.pi * np.asarray(frequencies_hz, dtype=float).reshape(-1)
    if not np.all(np.isfinite(omega)) or np.any(omega < 0.0):
        raise ValueError("principal_gains: expected finite frequencies >= 0 (Hz)")
    eigenvalues, V = np.linalg.eig(A)
    gains = np.empty((omega.size, min(C.shape[0], B.shape[1])))
    if np.linalg.cond(V) < 1e8:
        left, right = C @ V, np.linalg.solve(V, B)
        for k, w in enumerate(omega):
            G = (left / (1j * w - eigenvalues)) @ right + D
            gains[k] = np.linalg.svd(G, compute_uv=False)
    else:
        identity = np.eye(A.shape[0])
        for k, w in enumerate(omega):
            G = C @ np.linalg.solve(1j * w * identity - A, B) + D
            gains[k] = np.linalg.svd(G, compute_uv=False)
    return gains


def plot_principal_gains(model, frequencies_hz, gains, path, *, natural_hz=()):
    """Plot the principal gains (`principal_gains`) against frequency, log-log, to `path`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    unit = "m/N" if all(p.quantity == "position" and p.unit == "m" for p in model.outputs) and all(
        p.unit == "N" for p in model.inputs) else "output / input"
    figure, axes = plt.subplots(figsize=(7.0, 4.2))
    for i in range(gains.shape[1]):
        axes.loglog(frequencies_hz, gains[:, i], label=f"sigma {i + 1}")
    for f in natural_hz:
        axes.axvline(f, color="0.8", linewidth=0.8, zorder=0)
    axes.set_xlabel("frequency (Hz)")
    axes.set_ylabel(f"singular value ({unit})")
    axes.set_title(f"{model.name}: principal gains from {_names(model.inputs)} to "
                   f"{_names(model.outputs)}", fontsize=10)
    axes.grid(True, which="both", linewidth=0.3)
    if gains.shape[1] > 1:
        axes.legend()
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def _names(ports):
    """Port names for a title: all of up to three, else the first and the last."""
    names = [p.name for p in ports]
    return ", ".join(names) if len(names) <= 3 else f"{names[0]} ... {names[-1]}"


def frequency_grid(natural_hz, points=400, *, band=None):
    """Log-spaced frequencies (Hz) from a tenth of the lowest natural frequency to ten times
    the highest, or across `band` (f_min, f_max) Hz when given, with the natural frequencies
    in that range themselves added (so the peaks are hit). A repeated natural frequency (the
    manipulator's three legs' modes at 444.86 Hz) is added once: its copies differ by
    round-off, which would decide per CPU how many points the grid has, so a frequency
    within `ties.TIE_RTOL` of the one below it is the same peak."""
    natural = np.sort([f for f in natural_hz if f > 0.0]).astype(float)
    if natural.size:
        apart = natural[1:] > natural[:-1] * (1.0 + TIE_RTOL)
        natural = natural[np.concatenate([[True], apart])]
    if band is not None:
        low, high = band
        natural = natural[(natural >= low) & (natural <= high)]
    elif natural.size == 0:
        return np.logspace(-1, 4, points)
    else:
        low, high = natural.min() / 10.0, natural.max() * 10.0
    grid = np.logspace(np.log10(low), np.log10(high), points)
    return np.unique(np.concatenate([grid, natural]))
