"""The quantities whose design sensitivities `sensitivity` gives, evaluated on one model.

One evaluation runs the full analysis of a model (static equilibrium, linearisation, modes,
buckling, compliance, state space) and lists its quantities as one vector with a name and
a unit each, in this order:

    frequency k (Hz)              the lowest natural frequencies, as `natural_frequencies`
    buckling factor k (1)         the smallest load factors, as `buckling_load_factors`
    output NAME (m, rad)          the position outputs at the static equilibrium
    compliance NODE a/b           the entries of `compliance(model, NODE).matrix`
    largest von Mises (Pa)        the largest of `beam_stresses(...)` at the equilibrium
    DC gain IN->OUT               G(0) = D - C A^-1 B of `state_space_matrices`

Besides the values it keeps what the analytic derivatives and the mode tracking need: the
equilibrium and its `Mechanics`, the linearisation, lambda = omega^2 and the mass-normalised
mode shapes (every mode, so that a mode crossing the last one asked for is still found), the
buckling shapes, the compliance rows H DF, and the DC displacement of the DOFs per input.

Mode tracking (`track`): the modes of a perturbed model are matched to the base model's by
the modal assurance criterion weighted with the base mass matrix (the DOFs mix m and rad, so
the plain MAC would depend on the units),

    MAC(phi_i, psi_j) = (phi_i^T M0 psi_j)^2 / ((phi_i^T M0 phi_i) (psi_j^T M0 psi_j)),

each base mode in turn (lowest first) taking the perturbed mode of largest MAC not taken
yet; equal MACs (within `ties.TIE_RTOL`) go to the first in the perturbed model's order, the
project's tie rule (`core/numerics/ties.py`). Buckling shapes are matched the same way with
K0 as the weight.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg

from ..errors import ConvergenceError, FlexureError
from ..mechanics.mechanics import Mechanics
from ..mechanics.motions import held
from ..numerics.ties import best_first
from .compliance import compliance, measure_rows
from .linearization import linearize
from .statics import static_equilibrium

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model
    from .linearization import LinearModel
    from .statics import StaticSolution


@dataclass(frozen=True)
class Request:
    """Which quantities to evaluate: `modes` the lowest frequencies (0: none), `buckling`
    the smallest load factors (0: none), `outputs` the position outputs and `stress` the
    largest von Mises stress at the equilibrium, `compliance_nodes` the nodes whose
    compliance matrix to give, `dc_gains` the state space's DC gains."""

    modes: int = 6
    buckling: int = 0
    outputs: bool = True
    stress: bool = True
    compliance_nodes: tuple = ()
    dc_gains: bool = True


@dataclass
class Evaluation:
    """The quantities of one model (module docstring) and what their derivatives need."""

    names: list = field(default_factory=list)
    units: list = field(default_factory=list)
    kinds: list = field(default_factory=list)  # "frequency", "buckling", "output", ...
    values: list = field(default_factory=list)
    mechanics: Mechanics | None = None
    solution: StaticSolution | None = None
    linear_model: LinearModel | None = None
    eigenvalues: np.ndarray | None = None  # every lambda = omega^2, (rad/s)^2, ascending
    shapes: np.ndarray | None = None  # (NDOF, NDOF) mass-normalised
    buckling_factors: np.ndarray | None = None  # every positive factor, ascending
    buckling_shapes: np.ndarray | None = None
    buckling_weight: np.ndarray | None = None  # K0 under the reference load
    output_rows: np.ndarray | None = None  # (n_outputs, NDOF) d y / d q
    compliance_rows: list = field(default_factory=list)  # [(H DF (n, NDOF), zero mask (n,))]
    dc_rows: np.ndarray | None = None  # (n_outputs, NDOF) position rows of C
    dc_displacements: np.ndarray | None = None  # (NDOF, n_inputs) DC dq per input

    def add(self, name, unit, kind, value):
        self.names.append(name)
        self.units.append(unit)
        self.kinds.append(kind)
        self.values.append(float(value))


def evaluate(model: Model, request: Request, *, compiled: bool | None = None) -> Evaluation:
    """The quantities of `request` on `model` (module docstring), at the static equilibrium
    under the scene's loads. Quantities the model cannot have are left out: frequencies
    without DOFs, outputs without position outputs, the stress without sections that have
    dimensions, DC gains without inputs and outputs.

    `compiled` is the statics' path (`static_equilibrium`'s: None its own rule); where they
    packed the engine (a loaded model) the linearisation takes it too, at the cost of two
    operations on that packed model (`linear_engine`), and where it is False numpy."""
    from ..mechanics.ports import output_rows, output_value
    from .statespace import state_space_matrices
    from .stresses import beam_stresses

    found = Evaluation()
    mech = Mechanics(model)
    solution = static_equilibrium(model, mechanics=mech, compiled=compiled)
    lin = linearize(model, solution, mechanics=mech, compiled=_linear_path(model, compiled))
    found.mechanics, found.solution, found.linear_model = mech, solution, lin
    n = lin.M0.shape[0]
    if request.modes and n:
        try:
            eigenvalues, shapes = scipy.linalg.eigh(lin.K, lin.M0)
        except np.linalg.LinAlgError:
            raise ConvergenceError(f"{model.source}: the reduced mass matrix of {model.name!r} "
                                   "is not positive definite: no frequencies") from None
        found.eigenvalues, found.shapes = eigenvalues, shapes
        for k in range(min(request.modes, n)):
            found.add(f"frequency {k + 1}", "Hz", "frequency", frequency_hz(eigenvalues[k]))
    if request.buckling:
        factors, shapes, weight = buckling_modes(model, compiled=compiled)
        found.buckling_factors, found.buckling_shapes = factors, shapes
        found.buckling_weight = weight
        for k in range(min(request.buckling, factors.size)):
            found.add(f"buckling factor {k + 1}", "1", "buckling", factors[k])
    positions = [port for port in model.outputs if port.quantity == "position"]
    if request.outputs and positions:
        found.output_rows = output_rows(model, solution.x, lin.DF, positions)
        for port in positions:
            found.add(f"output {port.name}", port.unit, "output",
                      output_value(model, port, solution.x))
    for node in request.compliance_nodes:
        result = compliance(model, node, linear_model=lin)
        H = measure_rows(model, node, solution.x)[0]
        found.compliance_rows.append((H @ lin.DF, np.isin(result.coordinates,
                                                          result.unreachable)))
        for a, row in enumerate(result.matrix):
            for b, value in enumerate(row):
                found.add(f"compliance {node} {result.coordinates[a]}/{result.coordinates[b]}",
                          result.units[a][b], "compliance", value)
    if request.stress:
        stresses = beam_stresses(model, solution.x, solution.stress_resultants)
        if stresses.names:
            element, end, value = stresses.maximum()
            found.add(f"largest von Mises (at {element} {end})", "Pa", "stress", value)
    if request.dc_gains and model.inputs and model.outputs and n:
        A, B, C, D = state_space_matrices(model, linear_model=lin)
        try:
            state = -np.linalg.solve(A, B)  # the DC state per input, z = -A^-1 B
        except np.linalg.LinAlgError:
            raise FlexureError(f"{model.source}: the state space of {model.name!r} has a pole "
                               "at zero (a mechanism or a free coil): no DC gain") from None
        found.dc_rows, found.dc_displacements = C[:, :n], state[:n]
        gains = C @ state + D
        for j, port_in in enumerate(model.inputs):
            for i, port_out in enumerate(model.outputs):
                found.add(f"DC gain {port_in.name}->{port_out.name}",
                          f"{port_out.unit}/{port_in.unit}", "dc_gain", gains[i, j])
    found.values = np.array(found.values, dtype=float)
    return found


def _linear_path(model, compiled):
    """The linearisation's `compiled` after statics on the path `compiled` (`evaluate`)."""
    from . import linear_engine

    if compiled is None:
        return None
    return bool(compiled) and linear_engine.packed(model)


def frequency_hz(eigenvalue):
    """f = sign(lambda) sqrt(|lambda|) / (2 pi), Hz, as `natural_frequencies` gives it (a
    negative frequency marks a divergent mode)."""
    return np.sign(eigenvalue) * np.sqrt(np.abs(eigenvalue)) / (2.0 * np.pi)


def buckling_modes(model: Model, *, compiled: bool | None = None,
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(factors, shapes (NDOF, k), K0) of `buckling_load_factors`'s problem: the positive
    load factors of eig(-K0, G0) under the reference load, ascending, with their shapes
    (K0-normalised), solved as there as -G0 phi = (1 / lambda) K0 phi; `compiled` the
    statics' path (`evaluate`)."""
    loads = model.buckling_loads if model.buckling_loads is not None else model.loads
    mech = Mechanics(model)
    solution = static_equilibrium(model, loads=loads, mechanics=mech, compiled=compiled)
    K0 = held(model, mech.structural_stiffness(solution.config))  # kinematic inputs held
    G0 = held(model, mech.geometric_stiffness(solution.config, solution.stress_resultants))
    try:
        inverse, shapes = scipy.linalg.eigh(-G0, K0)
    except np.linalg.LinAlgError:
        raise ConvergenceError(f"{model.source}: the structural stiffness K0 of "
                               f"{model.name!r} is singular: no buckling analysis") from None
    scale = np.max(np.abs(inverse), initial=0.0)
    positive = np.flatnonzero(inverse > 1e-12 * scale) if scale > 0 else np.arange(0)
    order = positive[np.argsort(1.0 / inverse[positive], kind="stable")]
    return 1.0 / inverse[order], shapes[:, order], K0


def mac(base: np.ndarray, other: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """The weighted modal assurance criterion (n_base, n_other) between the columns of
    `base` and `other` (module docstring); 1 for the same shape, 0 for orthogonal ones."""
    cross = base.T @ weight @ other
    own = np.einsum("ij,ik,kj->j", base, weight, base)
    others = np.einsum("ij,ik,kj->j", other, weight, other)
    return cross**2 / np.outer(own, others)


def track(base: np.ndarray, other: np.ndarray, weight: np.ndarray) -> tuple[list, list]:
    """For each column of `base` (in order) the column of `other` it continues into, and the
    MAC of that match (module docstring: the largest MAC not taken yet, ties to the first)."""
    table = mac(base, other, weight)
    taken = np.zeros(other.shape[1], dtype=bool)
    chosen, values = [], []
    for row in table:
        j = best_first(np.where(taken, np.nan, row))
        taken[j] = True
        chosen.append(j)
        values.append(float(row[j]))
    return chosen, values


def tracked_values(base: Evaluation, other: Evaluation) -> tuple[np.ndarray, float]:
    """The values of `other` in the order of `base`'s quantities, its modes and buckling
    shapes matched to `base`'s by MAC (`track`); and the smallest MAC of those matches (1
    when there were none). FlexureError when `other` lacks a quantity of `base`."""
    values = np.full(len(base.names), np.nan)
    position = {name: k for k, name in enumerate(other.names)}
    worst = 1.0
    frequencies = [k for k, kind in enumerate(base.kinds) if kind == "frequency"]
    if frequencies:
        match, macs = track(base.shapes[:, :len(frequencies)], other.shapes,
                            base.linear_model.M0)
        values[frequencies] = frequency_hz(other.eigenvalues[match])
        worst = min(worst, *macs)
    buckling = [k for k, kind in enumerate(base.kinds) if kind == "buckling"]
    if buckling:
        if other.buckling_factors.size < len(buckling):
            raise FlexureError(f"a perturbed model has {other.buckling_factors.size} buckling "
                               f"factors, the base model {len(buckling)}")
        match, macs = track(base.buckling_shapes[:, :len(buckling)], other.buckling_shapes,
                            base.buckling_weight)
        values[buckling] = other.buckling_factors[match]
        worst = min(worst, *macs)
    for k, (name, kind) in enumerate(zip(base.names, base.kinds, strict=True)):
        if kind in ("frequency", "buckling"):
            continue
        if kind == "stress":  # the largest stress wherever it is now
            name = next((n for n in other.names if n.startswith("largest von Mises")), name)
        if name not in position:
            raise FlexureError(f"a perturbed model has no {name!r}")
        values[k] = other.values[position[name]]
    return values, worst
