"""Von Mises stresses along beams and trusses, from stress resultants.

For every element whose module defines `section_forces` (BEAM, PLBEAM, PLTRUSS) and whose
section has dimensions (A > 0), at both element ends:

    normal stress   s = |N| / A + |My'| / Wy' + |Mz'| / Wz'       (rectangle: at a corner)
                    s = |N| / A + sqrt(My'^2 + Mz'^2) / W          (circle: on the surface)
    shear stress    t = |T| / Wt                                   (Saint-Venant torsion)
    von Mises       s_vm = sqrt(s^2 + 3 t^2)

A PLBEAM has N and the in-plane bending moment alone, so s = |N| / A + |M| / W with
W = width height^2 / 6 (the largest of N/A +- M/W, at one face), and s_vm = s; a PLTRUSS
s = |N| / A. For a circle the largest s and t occur at the same surface point, so s_vm is the
largest over the section. For a rectangle the largest torsion shear (middle of the long sides)
and the largest normal stress (corners) are at different points: s_vm above is then an upper
bound, exact whenever the beam is not twisted and bent at once. Shear from transverse forces is left
out (the beam theory of the element has none: zero for slender beams). Beams given by their
stiffness only (no A) get NaN.

The stress resultants sigma (NE,) are those of every deformation: the constitutive ones of
released and DOF deformations plus the multipliers of the rigid ones (reaction forces), as
`StaticSolution.stress_resultants` holds them; `dynamic_stress_resultants` gives them along a
motion from the numpy `Mechanics` (the plain reference), `stress_engine` from the compiled
engine's evaluation of each state, which `stresses_along` takes by default. With kinematic
inputs both solve the accelerations of the DOFs proper with the inputs' own accelerations
given (which the caller passes: a state holds their positions and rates only), so that what
moves an input is a reaction of the structure, not a free motion of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..mechanics.actuators import port_values
from ..mechanics.ports import input_forces
from ..numerics.blas import blas_threads
from ..numerics.ties import best_first
from . import stress_engine

if TYPE_CHECKING:  # names for the annotations only
    from numpy.typing import ArrayLike

    from ..mechanics.mechanics import Mechanics
    from ..model import Model


@dataclass
class BeamStresses:
    """Von Mises stresses (Pa) at both ends of every beam with a section: names, (n, 2)."""

    names: list
    von_mises: np.ndarray  # (n, 2) Pa at p and q
    start_nodes: list  # the translational node at p of each element
    end_nodes: list  # the translational node at q
    lengths: np.ndarray  # (n,) m
    along: np.ndarray  # (n, POINTS) Pa at the fractions FRACTIONS of the length, p to q
    yield_stress: np.ndarray | None = None  # (n,) Pa, the sections' (inf: none given)

    def beyond_yield(self) -> list[str]:
        """Messages naming each element whose von Mises stress exceeds its section's yield
        stress (`yield_stress`), with both values (MPa); empty when none does or none is
        given.

        Returns
        -------
        list of str
            One message per element, in the scene's order.
        """
        if self.yield_stress is None:
            return []
        worst = np.max(self.along, axis=1, initial=0.0)
        return [f"{name}: von Mises stress {stress / 1e6:.4g} MPa is above its section's yield "
                f"stress {bound / 1e6:.4g} MPa"
                for name, stress, bound in zip(self.names, worst, self.yield_stress,
                                               strict=True) if stress > bound]

    def as_dict(self) -> dict[str, list[float]]:
        """The end stresses by element.

        Returns
        -------
        dict of str to list of float
            {element: [s_vm at p, s_vm at q]} in Pa.
        """
        return {name: row.tolist() for name, row in zip(self.names, self.von_mises, strict=True)}

    def maximum(self) -> tuple[str, str, float]:
        """The largest von Mises stress and where it is.

        Returns
        -------
        (str, str, float)
            The element, its end "p" or "q", and s_vm in Pa.
        """
        # the first in the scene's order among equals (two symmetric leaves; `ties.py`)
        flat = best_first(self.von_mises)
        i, j = divmod(int(flat), 2)
        return self.names[i], "pq"[j], float(self.von_mises[i, j])


FRACTIONS = np.linspace(0.0, 1.0, 11)


def von_mises(forces, props, fractions=(0.0, 1.0)):
    """s_vm (n, len(fractions)) in Pa from section_forces (dict of (n,), N and N m) and the
    section properties (A m^2, W m^3).

    At the ends (fractions 0 and 1) with the end moments; in between the bending moments are
    interpolated linearly (no distributed load on the beam), N and T are constant.
    """
    area = props["A"]
    circular = props.get("circular", 0.0) > 0.5
    zero = np.zeros_like(forces["N"])
    with np.errstate(divide="ignore", invalid="ignore"):
        axial = np.abs(forces["N"]) / area
        # planar elements have neither torsion nor out-of-plane bending; trusses no bending
        tau = np.abs(forces["T"]) / props["Wt"] if "T" in forces else zero
        result = []
        for xi in fractions:
            mz = (1.0 - xi) * forces.get("Mz_p", zero) + xi * forces.get("Mz_q", zero)
            if "My_p" in forces:
                my = (1.0 - xi) * forces["My_p"] + xi * forces["My_q"]
                bending = np.where(circular, np.hypot(my, mz) / props["Wy"],
                                   np.abs(my) / props["Wy"] + np.abs(mz) / props["Wz"])
            else:
                bending = np.abs(mz) / props["Wz"] if "Mz_p" in forces else zero
            result.append(np.sqrt((axial + bending) ** 2 + 3.0 * tau**2))
    stress = np.stack(result, axis=1)
    stress[~(area > 0)] = np.nan
    return stress


def beam_stresses(model: Model, x: np.ndarray, sigma: np.ndarray) -> BeamStresses:
    """Von Mises stresses at both ends of, and along, every beam and truss with a section.

    Parameters
    ----------
    model : Model
    x : ndarray (NX,)
        The nodal coordinates, m and rad (Euler parameters unitless).
    sigma : ndarray (NE,)
        The stress resultants of every deformation, N (`StaticSolution.stress_resultants`,
        `dynamic_stress_resultants`).

    Returns
    -------
    BeamStresses
        Von Mises stresses in Pa of the elements whose section has A > 0, with their end
        nodes and lengths (m).
    """
    names, stresses, starts, ends, lengths, along, yields = [], [], [], [], [], [], []
    for group in model.groups:
        forces_of = getattr(group.kind, "section_forces", None)
        if forces_of is None or not np.any(group.properties.get("A", 0.0) > 0):
            continue
        (e,) = group.kind.deformations(group.local(x), group.reference, order=0)
        forces = forces_of(e, sigma[group.deformation_index], group.reference)
        stress = von_mises(forces, group.properties)
        profile = von_mises(forces, group.properties, FRACTIONS)
        keep = group.properties["A"] > 0
        node_of = model.coordinate_node[group.coordinate_index[:, 0]].tolist()
        end_of = model.coordinate_node[
            group.coordinate_index[:, -group.kind.coordinates_per_element // 2]].tolist()
        for i in np.flatnonzero(keep):
            names.append(group.names[i])
            stresses.append(stress[i])
            starts.append(node_of[i])
            ends.append(end_of[i])
            lengths.append(group.reference["l0"][i])
            along.append(profile[i])
            yields.append(group.properties.get("yield_stress", np.full(len(keep), np.inf))[i])
    return BeamStresses(names, np.array(stresses).reshape(-1, 2), starts, ends,
                        np.array(lengths), np.array(along).reshape(-1, FRACTIONS.size),
                        np.array(yields, dtype=float))


def dynamic_stress_resultants(mechanics, config, qdot, qddot=None, input_force=None,
                              prescribed=None):
    """sigma (NE,) of every deformation in motion: constitutive plus the multipliers of

    r = f - M xddot - h(x, xdot) - De^T sigma_c,   xddot = DF qddot + (D2F qdot) qdot,

    with f the loads and gravity plus `input_force` ((NX,) N) and h the convective inertia
    force. qddot (NDOF,) defaults to the accelerations of the equations of motion,
    M_bar qddot = DF^T r; with `prescribed` = (k, u'') (positions in q of the kinematic
    inputs, their accelerations in m/s^2 or rad/s^2), those of the DOFs proper f with
    qddot_k = u'' given: M_bar_ff qddot_f = (DF^T r)_f - M_bar_fk u''.
    """
    xdot = config.DF @ qdot
    sigma_c = mechanics.constitutive_stress(config, config.De @ xdot)
    inertia = mechanics.inertia
    f = mechanics.external_force(config.x)
    if input_force is not None:
        f = f + input_force
    M = inertia.mass_matrix(config.x)
    r = (f - M @ mechanics.kinematics.convective_acceleration(config, qdot)
         - inertia.convective_force(config.x, xdot) - config.De.T @ sigma_c)
    if qddot is None:
        M_bar, Q = config.DF.T @ M @ config.DF, config.DF.T @ r
        if prescribed is None:
            qddot = np.linalg.solve(M_bar, Q)
        else:
            k, given = np.asarray(prescribed[0], dtype=int), np.asarray(prescribed[1], float)
            f = np.setdiff1d(np.arange(Q.size), k)
            qddot = np.zeros(Q.size)
            qddot[k] = given
            qddot[f] = np.linalg.solve(M_bar[np.ix_(f, f)], Q[f] - M_bar[np.ix_(f, k)] @ given)
    r = r - M @ (config.DF @ qddot)
    return mechanics.stress_resultants(config, r, sigma_c)


@blas_threads()
def stresses_along(model: Model, states: ArrayLike, *, inputs: ArrayLike | None = None,
                   prescribed_accelerations: ArrayLike | None = None,
                   mechanics: Mechanics | None = None,
                   compiled: bool | None = None) -> tuple[list[str], np.ndarray]:
    """Von Mises stresses along a trajectory; the accelerations follow from the equations of
    motion in each state.

    Parameters
    ----------
    model : Model
    states : array_like (n_times, 2 NDOF [+ n_coils])
        [q, qdot] as `SimulationResult` holds them (m, rad; m/s, rad/s), followed by the coil
        currents (A) of a model with voltage-driven actuators (zero when left out).
    inputs : array_like (n_times, n_inputs), optional
        The held inputs: N, N m for the scene's forces and moments, V for an actuator's
        drive signal (default zero).
    prescribed_accelerations : array_like (n_times, n_kinematic), optional
        A model with kinematic inputs: their accelerations u'' at each state, m/s^2 or
        rad/s^2, in the order of `Model.kinematic_inputs` (a `Simulator`'s
        `prescribed_values(t)[2]`); the states hold their positions and rates (on the path:
        `Simulator.on_path`). Required there, not taken otherwise.
    mechanics : Mechanics, optional
        The model's mechanics to reuse on the numpy path (default: a new one).
    compiled : bool, optional
        Evaluate each state through the compiled engine (True, where it takes the model:
        `stress_engine.supports`) or through the numpy `Mechanics` (False). Default: the
        engine where it takes the model (its packed model kept for the model's next calls).

    Returns
    -------
    names : list of str
        The beams with a section, as in `BeamStresses.names`.
    stresses : ndarray (n_times, n_beams, 2)
        Von Mises stresses at the ends p and q, Pa.

    Raises
    ------
    ConvergenceError
        The kinematics of a state do not converge.
    UsageError
        `prescribed_accelerations` missing for a model with kinematic inputs, given for
        one without, or not one row of n_kinematic per state.
    """
    states = np.asarray(states, float)
    uddot = _prescribed_accelerations(model, len(states), prescribed_accelerations)
    names, result = [], []
    for x, sigma in _states_resultants(model, states, inputs, uddot, mechanics, compiled):
        stresses = beam_stresses(model, x, sigma)
        names = stresses.names
        result.append(stresses.von_mises)
    return names, np.array(result)


def _prescribed_accelerations(model, count, given):
    """(count, n_kinematic) u'' of `stresses_along`, or None without kinematic inputs."""
    from ..errors import UsageError

    names = [port.name for port in model.kinematic_inputs]
    if not names:
        if given is not None:
            raise UsageError(f"stresses_along: {model.name!r} has no kinematic inputs; "
                             "prescribed_accelerations is for those")
        return None
    if given is None:
        raise UsageError(f"stresses_along: {model.name!r} has kinematic inputs "
                         f"({', '.join(names)}): give their accelerations at each state, "
                         "prescribed_accelerations (n_times, n_kinematic), m/s^2 or rad/s^2 "
                         "(a Simulator's prescribed_values(t)[2]); a state holds only their "
                         "positions and rates")
    uddot = np.asarray(given, dtype=float)
    if uddot.shape != (count, len(names)) or not np.all(np.isfinite(uddot)):
        raise UsageError(f"stresses_along: prescribed_accelerations of {model.name!r} must "
                         f"be {count} rows (one per state) of {len(names)} finite values "
                         f"({', '.join(names)}); got shape {uddot.shape}")
    return uddot


def _states_resultants(model, states, inputs, uddot, mechanics, compiled):
    """(x (NX,), sigma (NE,)) of each state, through the engine or numpy (`stresses_along`);
    uddot (n_times, n_kinematic) the kinematic inputs' accelerations, or None."""
    if compiled is not False and stress_engine.supports(model):
        evaluator = stress_engine.engine_stresses(model)
        evaluator.restart()
        for k, state in enumerate(states):
            yield evaluator.stress_resultants(
                state, None if inputs is None else np.asarray(inputs[k], float),
                None if uddot is None else uddot[k])
        return
    from ..mechanics.mechanics import Mechanics

    mech = mechanics or Mechanics(model)
    ndof = model.declared_dof_count
    x = model.initial_coordinates.copy()
    for k, state in enumerate(states):
        config = mech.kinematics.solve(state[:ndof], x)
        x = config.x
        force = np.zeros(model.nx)
        currents = state[2 * ndof:] if state.size > 2 * ndof else None
        if inputs is not None or model.actuators:  # a coil's current acts without inputs
            held = np.zeros(len(model.inputs)) if inputs is None else inputs[k]
            values = port_values(model, held, currents) if model.actuators else held
            # forces on their coordinates, moments by their orientation
            force = input_forces(model, x, values)
        prescribed = None if uddot is None else (model.prescribed_dofs, uddot[k])
        yield x, dynamic_stress_resultants(mech, config, state[ndof: 2 * ndof],
                                           input_force=force, prescribed=prescribed)


def _chains(stresses, fixed_nodes):
    """Beams joined end to end: lists of (row, reversed) along each chain, starting at a
    fixed node where there is one."""
    touching = {}
    for row, (a, b) in enumerate(zip(stresses.start_nodes, stresses.end_nodes, strict=True)):
        touching.setdefault(a, []).append(row)
        touching.setdefault(b, []).append(row)
    unused, chains = set(range(len(stresses.names))), []
    while unused:
        ends = [n for n, rows in touching.items() if len(rows) == 1 and rows[0] in unused]
        ends.sort(key=lambda n: (n not in fixed_nodes, n))
        node = ends[0] if ends else stresses.start_nodes[min(unused)]
        chain = []
        while True:
            rows = [r for r in touching[node] if r in unused]
            if not rows:
                break
            row = rows[0]
            unused.discard(row)
            flipped = stresses.start_nodes[row] != node
            chain.append((row, flipped))
            node = stresses.start_nodes[row] if flipped else stresses.end_nodes[row]
        chains.append(chain)
    return chains


def plot_beam_stresses(model, stresses, path, *, title=None):
    """Plot the von Mises stresses along every chain of beams to a PNG file (MPa over mm)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fixed_nodes = set(model.coordinate_node[model.fixed_coordinates].tolist())
    fig, ax = plt.subplots(figsize=(7, 4))
    for k, chain in enumerate(_chains(stresses, fixed_nodes)):
        s, xs, ys = 0.0, [], []
        for row, flipped in chain:
            values = stresses.along[row][::-1] if flipped else stresses.along[row]
            length = stresses.lengths[row]
            xs += list(1e3 * (s + length * FRACTIONS))
            ys += list(values / 1e6)
            s += length
        first, last = stresses.names[chain[0][0]], stresses.names[chain[-1][0]]
        label = first if first == last else f"{first} ... {last}"
        ax.plot(xs, ys, color=f"C{k}", label=label)
        ax.plot(xs[::FRACTIONS.size] + xs[FRACTIONS.size - 1::FRACTIONS.size],
                ys[::FRACTIONS.size] + ys[FRACTIONS.size - 1::FRACTIONS.size], "o",
                color=f"C{k}")
    ax.set_xlabel("distance along the beams from their first node [mm]")
    ax.set_ylabel("von Mises stress [MPa]")
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax.set_title(title or f"{model.name}: von Mises stresses (largest over the section)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
