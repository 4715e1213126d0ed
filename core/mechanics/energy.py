"""The mechanical energy of a state, from the plain-numpy reference path.

    E = 1/2 qdot^T M_bar qdot + 1/2 e_s^T S e_s - (f + B u)^T x - V_g          (J)

with x = F(q) the coordinates of the DOFs q (`Kinematics.solve`), M_bar = DF^T M(x) DF the
reduced mass (`assembly.Inertia.mass_matrix`), e_s and S the stressed deformations and their
stiffness (`Mechanics`), f the constant nodal loads (N, N m), u the inputs (N, N m) on their
coordinates, and V_g the work of gravity: g . x_a m_a on the translations of every lumped mass
plus (Mp g_p) . p(x) on the position points p of every element mass. The load and gravity
terms are work potentials: the energy is defined up to a constant, so only its changes mean
something. Damping is not part of it; without damping, inputs and time-varying loads the
equations of motion conserve it (examples/energy_drift.py, tests/test_simulation.py).

This is the independent check of the compiled engine (`flexure.core.engine.engine`), so it uses
none of it; it costs a Newton solve of the kinematics per call (about a millisecond).
"""

import numpy as np

from ..errors import FlexureError
from ..numerics.blas import blas_threads
from .assembly import Inertia
from .mechanics import Mechanics


@blas_threads()
def mechanical_energy(model, q, qdot, u=None, *, x_start=None):
    """Kinetic plus potential energy (J) of the state (q, qdot) of `model`.

    Parameters
    ----------
    model : Model
    q, qdot : arrays (NDOF,)
        DOFs (m, rad) and their velocities (m/s, rad/s).
    u : array (n_inputs,), optional
        Held forces (N, N m) on the inputs' coordinates; their work potential -u . x_input is
        included. For an input a voice-coil actuator drives, its force
        (`flexure.core.mechanics.actuators.port_values`), not its drive signal. A moment
        input about a global axis has none (FlexureError unless it is zero).
    x_start : array (NX,), optional
        Start of the kinematics' Newton iterations (default: the scene's coordinates).
    """
    mechanics = Mechanics(model)
    kinematics, inertia = mechanics.kinematics, mechanics.inertia
    q = np.asarray(q, dtype=float)
    qdot = np.asarray(qdot, dtype=float)
    start = model.initial_coordinates if x_start is None else x_start
    config = kinematics.solve(q, np.array(start, dtype=float))
    x, DF = config.x, config.DF
    reduced_mass = DF.T @ inertia.mass_matrix(x) @ DF
    e_s = config.e[mechanics.stressed]
    energy = 0.5 * qdot @ reduced_mass @ qdot + 0.5 * e_s @ mechanics.S @ e_s
    force = np.array(model.loads, dtype=float)
    if u is not None:
        for port, value in zip(model.inputs, np.atleast_1d(u), strict=True):
            if port.about_axis:
                if value != 0.0:
                    raise FlexureError(
                        f"{model.source}: mechanical energy: the moment input {port.name!r} "
                        f"({value:g} N m) has no work potential: a moment about an axis fixed "
                        "in space is not conservative in 3-D; give it zero")
                continue
            force[port.coordinate] += value
    energy -= force @ x
    return float(energy - gravity_work(model, x, inertia))


def gravity_work(model, x, inertia=None):
    """V_g (J): the work potential of gravity at coordinates x (NX,), up to a constant."""
    g = np.asarray(model.gravity, dtype=float)
    if not np.any(g):
        return 0.0
    inertia = inertia or Inertia(model)
    axes = "xyz"[: model.dimension]
    work = 0.0
    for i in model.translations:  # lumped masses on translations
        work += model.lumped_mass[i] * g[axes.index(model.coordinate_axis[i])] * x[i]
    for group, Mp in inertia.groups:  # element masses on their position points
        g_points = np.concatenate([g if kind == "position" else np.zeros_like(g)
                                   for kind in group.kind.inertia_point_kinds])
        (p,) = group.kind.inertia_points(group.local(x), group.reference, order=0)
        work += np.einsum("npr,r,np->", Mp, g_points, p)
    return float(work)


__all__ = ["mechanical_energy", "gravity_work"]
