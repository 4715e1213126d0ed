"""The default absolute tolerances of the integrators, from rtol and the model's scales."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SimulationError
from ..live_models import PerLiveModel
from ..mechanics.ports import input_direction
from ..numerics.blas import blas_threads

if TYPE_CHECKING:  # names for the annotations only
    from ..engine.data import EngineData
    from ..model import Model

# the smallest motion, as a fraction of the model's length scale, that rtol controls
MOTION_FRACTION = 1e-3
# model (and whether its packing has rigid clusters) -> (L, omega, the coil currents' scales
# before rtol): what `default_atol` derives from the model alone, kept while the model lives.
# Why: a dense first-order Jacobian and an eigenproblem at the start, 0.08 s of CPU on
# manipulator_reduced (507 DOFs) for every Simulator, a loop's timed one after `prepare`'s
# throwaway one too (docs/benchmarks.md, session 41, loopcost)
_SCALES = PerLiveModel()


@blas_threads()
def default_atol(model: Model, rtol: float, data: EngineData | None = None) -> np.ndarray:
    """Per-state absolute tolerance (2 NDOF + coil currents,) from rtol and the model's scales.

    The integrator's state is the deviation from the start configuration, and its local
    error test is |err_i| <= rtol |y_i| + atol_i: rtol controls the error of a motion
    larger than atol_i / rtol, atol the error of smaller ones. The default makes rtol the
    controlling tolerance for any motion larger than `MOTION_FRACTION` (1e-3) of the model's
    length scale L (0.1 mm on a 0.1 m leaf spring; flexure strokes are 1e-3 L to 0.1 L):
    lengths rtol 1e-3 L (m), rotations rtol 1e-3 (rad). Velocities: those times a reference
    angular frequency, the lowest natural frequency of the initial configuration (or
    sqrt(g / L) for a structure that only gravity holds, or 1 rad/s), the velocity of that
    smallest motion in the slowest mode. Coil currents (A, of voltage-driven actuators): rtol
    times the current whose steady force Km i moves the actuated coordinate by that smallest
    motion, through the static compliance c = b^T DF K0^-1 DF^T b of the port (b its unit
    generalised force, `ports.input_direction`) in the initial configuration (where K0 is
    singular, through M0 times the reference frequency squared). M0 and K0 (the tangent
    stiffness: the structure's and the geometric stiffness of gravity's load) come from the
    engine, as the integrator's own do.

    Parameters
    ----------
    model : Model
    rtol : float
        The integrator's relative tolerance.
    data : EngineData, optional
        The model packed for the engine (a Simulator's): whether its packing has the rigid
        clusters picks the packing that evaluates the start configuration (`model_scales`,
        on a packing of its own; `data` is not evaluated). Default: with them.

    Returns
    -------
    ndarray (2 NDOF + n_coils,)
        atol per state: m or rad on the DOF deviations, m/s or rad/s on the velocities, A on
        the coil currents.
    """
    L, omega, scales = model_scales(model, True if data is None else data.rigid.enabled)
    names = model.dof_names
    position = MOTION_FRACTION * np.array([rtol if name.endswith(".phi") else rtol * L
                                           for name in names])
    currents = [rtol * scale for scale in scales]
    return np.concatenate([position, position * omega, currents])


def model_scales(model: Model, rigid: bool = True) -> tuple[float, float, tuple]:
    """(L, omega, the coil currents' scales) of `default_atol` before rtol: the length scale
    (m), the reference angular frequency (rad/s) and per coil actuator the current (A) whose
    steady force moves its port by MOTION_FRACTION of its scale. Evaluated at the start
    configuration on a packing of its own (with or without the rigid clusters, `rigid`: the
    two evaluate M0 and K0 to round-off, not to the bit) once per live model, then kept
    (`live_models`). Never on a Simulator's packed model: the evaluation leaves kept factors
    there that its integration would start from (the sparse path refines with them), so a
    Simulator's numbers would depend on whether the scales were kept before.

    Parameters
    ----------
    model : Model
    rigid : bool
        Whether the packing evaluated has the rigid clusters (`EngineData(rigid=)`).
    """
    from ..engine.data import EngineData
    from ..mechanics.kinematics import length_scale

    known = _SCALES.get(model, bool(rigid))
    if known is not None:
        return known
    L = length_scale(model)
    x, DF, M0, K0 = initial_matrices(model, EngineData(model, rigid=rigid))
    omega = reference_frequency(model, M0, K0, L)
    # a tuple: the kept value is handed to every caller, and none may change it for the next
    scales = tuple(_current_scale(model, actuator, x, DF, M0, K0, omega, L)
                   for actuator in model.coil_actuators)
    return _SCALES.put(model, (L, omega, scales), bool(rigid))


def initial_matrices(model, data):
    """(x (NX,), DF (NX, NDOF), M0 and K0 (NDOF, NDOF)) in the start configuration, at rest
    and with the inputs at zero, by the engine (`data`, or the model packed here) as the
    integrators evaluate it: M0 the reduced mass matrix, K0 = -M0 times the first-order
    Jacobian's block d qddot / d q (the structure's stiffness and the geometric stiffness of
    what loads it there, gravity)."""
    from ..engine import data as ed
    from ..engine import engine
    from ..engine.data import EngineData
    from ..engine.status import status_message
    from .start import scene_dofs, solve_start

    data = EngineData(model) if data is None else data
    n, size = model.declared_dof_count, 2 * model.declared_dof_count + len(model.coil_actuators)
    q0 = scene_dofs(model, data)
    status = solve_start(model, data, q0)
    data.float_array("q_ref")[:] = q0
    jacobian = np.zeros(size * size)
    if status == ed.OK:
        status = engine.call(data, engine.OP_JACOBIAN, np.zeros(size), jacobian)
    if status != ed.OK:
        hint = ""
        if status == ed.SINGULAR_MASS and model.kinematic_inputs:
            # the prescribed form solves with the mass matrix of every DOF, the moved ones' too
            names = ", ".join(port.name for port in model.kinematic_inputs)
            hint = (f"; the kinematic inputs ({names}) are DOFs of the mass matrix too: what "
                    "each moves needs a mass of its own (nodes.NAME.mass, or an element's)")
        raise SimulationError(f"{model.source}: the start configuration could not be "
                              "evaluated for the default tolerances: "
                              f"{status_message(status)}{hint}")
    nx = data.int_array("dims")[ed.NX]
    M0 = data.float_array("mass")[:n * n].reshape(n, n).copy()
    K0 = -M0 @ jacobian.reshape(size, size)[n:2 * n, :n]
    return (data.float_array("x")[:nx].copy(),
            data.float_array("DF")[:nx * n].reshape(nx, n).copy(), M0, K0)


def _current_scale(model, actuator, x, DF, M0, K0, omega, L):
    """The coil current (A) whose steady force moves the actuated port by MOTION_FRACTION of
    its scale (L on a translation, 1 rad on an angle or about a global axis)."""
    port = model.inputs[actuator.input]
    row = input_direction(model, port, x) @ DF  # the port per DOF
    translation = not port.about_axis and port.coordinate in model.translations
    motion = MOTION_FRACTION * (L if translation else 1.0)
    compliance = 0.0
    for stiffness in (K0, M0 * omega ** 2):
        try:
            compliance = float(row @ np.linalg.solve(stiffness, row))
        except np.linalg.LinAlgError:
            continue
        if np.isfinite(compliance) and compliance > 0.0:
            break
    if not (np.isfinite(compliance) and compliance > 0.0):
        return 1.0  # the port does not move with the DOFs: no motion sets a scale
    return motion / (compliance * actuator.force_constant)


def reference_frequency(model, M0, K0, L):
    """The lowest positive natural frequency (rad/s) of K0 and M0: the eigenvalues of
    C^-1 K0 C^-T (C C^T = M0, Cholesky; K0 symmetrised); sqrt(g / L) under gravity or 1 rad/s
    where M0 is not positive definite or no frequency is positive."""
    try:
        C = np.linalg.cholesky(M0)
        A = np.linalg.solve(C, np.linalg.solve(C, 0.5 * (K0 + K0.T)).T)
        eig = np.linalg.eigvalsh(0.5 * (A + A.T))
        positive = eig[eig > 1e-9 * max(1.0, np.max(np.abs(eig)))]
        if positive.size:
            return float(np.sqrt(positive.min()))
    except np.linalg.LinAlgError:
        pass
    g = np.linalg.norm(model.gravity)
    return float(np.sqrt(g / L)) if g > 0 else 1.0


def atol_vector(model, rtol, atol, size, data=None):
    """The absolute tolerances (size,: the integrator's states, 2 NDOF plus the coil
    currents): `default_atol` for None, a number for every state, or one per state; a
    SimulationError for anything not positive and finite."""
    if atol is None:
        return default_atol(model, rtol, data)
    a = np.array(atol, dtype=float).reshape(-1)
    if a.size == 1:
        a = np.full(size, a[0])
    if a.size != size or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise SimulationError(f"atol: expected a positive number or {size} positive "
                              f"values, got {atol!r}")
    return a
