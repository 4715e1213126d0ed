"""The start of a simulation: the DOFs of the scene's configuration, and the engine's
kinematics solved there."""

import numpy as np

from ..engine import engine


def scene_dofs(model, data):
    """The DOFs (NDOF,: m, rad) of the scene's configuration: its coordinates that are DOFs
    and the deformations that are, computed by the engine (`data`, an `EngineData` of
    `model`; its DEFORMATIONS operation is compiled and run only for a model with a
    deformation among its DOFs)."""
    x0 = model.initial_coordinates
    if model.dof_deformations.size == 0:  # the deformations are not needed: not computed
        return np.asarray(x0[model.dof_coordinates], dtype=float)
    engine.call(data, engine.OP_DEFORMATIONS, np.ascontiguousarray(x0, float), s=0)
    e0 = data.float_array("e")
    return np.concatenate([x0[model.dof_coordinates], e0[model.dof_deformations]])


def start_kinematics(data, x):
    """The next kinematic solution of `data` starts with full Newton from x (NX,)."""
    data.restart_kinematics(x)


def solve_start(model, data, q):
    """Solve the kinematics at the DOFs q from the scene's coordinates (x = F(q) and DF in
    `data`); the engine's status."""
    start_kinematics(data, model.initial_coordinates)
    return engine.call(data, engine.OP_KINEMATICS, np.ascontiguousarray(q, float))
