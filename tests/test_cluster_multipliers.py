"""The multipliers of a packing with rigid clusters (core/engine/rigid.py) against the packing
without them, and the tangent they weigh against finite differences of the engine's qddot.

Why the kept rows' multipliers differ on one kind of row only: a slave's coordinates
x_s = S(z) are homogeneous quadratic in its master's Euler parameters lambda_m
(`rigid_bodies`), so off |lambda_m| = 1 the cluster is scaled by |lambda_m|^2 and its rigid
beams' deformations do not vanish: J_int T = alpha J_norm T, with J_norm the master's Euler
normalisation row (a kept row), alpha one number per eliminated row. The condensed balance
T^T r = (J_kept T)^T lam_kept + (J_int T)^T lam_int then gives the clustered packing

    lam_kept' = lam_kept + (J_kept T)^-T (J_int T)^T lam_int,

different only on the masters' normalisation rows (which absorb the eliminated rows'
reactions, a multiplier without physical meaning), and the same T^T J^T lam.

States: the loaded rest and a moving state (DOFs moved by 1e-4, velocities 0.05 random,
inputs random) as tests/test_rigid.py's. Tolerances, relative to the state's largest |sigma|:
1e-9 for the multipliers and their balance (measured 2e-14 on manipulator_control,
4e-15 on stage_spatial_19dof: round-off of the kinematics); J_int T off the normalisation
rows' span 1e-12 of its largest entry (measured 1e-16). The tangent K0 + G0 against
central differences of the engine's qddot at the loaded rest, as M_bar dqddot/dq + K0 + G0
relative to the largest |G0| (FD_SCENES).
"""

import numpy as np
import pytest

from flexure.core import Mechanics, load_scene
from flexure.core.analysis.linearization import linearize
from flexure.core.analysis.statics import static_equilibrium
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData
from flexure.core.mechanics.rigid_bodies import RigidLayout, find_clusters

RTOL = 1e-9


def multipliers(model, rigid, q, qdot, inputs):
    """(sigma (NE,) the tangent weighs the Hessians with (slot edot, N), its rows, its
    reduced free coordinates, x (NX,), K (NDOF, NDOF)) after OP_EVALUATE and OP_TANGENT at
    the evaluation's qddot."""
    data = EngineData(model, rigid=rigid)
    data.float_array("inputs")[:] = inputs
    assert engine.call(data, engine.OP_EVALUATE, q, qdot) == ed.OK
    assert engine.call(data, engine.OP_TANGENT, data.float_array("qddot").copy()) == ed.OK
    n = q.size
    return (data.float_array("edot").copy(), data.int_array("constraint_rows").copy(),
            data.int_array("free").copy(), data.float_array("x").copy(),
            data.float_array("stiffness").reshape(n, n).copy())


def states(model):
    """(label, q, qdot, inputs) of the loaded rest (1 N on each input) and a moving state."""
    inputs = {port.name: 1.0 for port in model.inputs}
    rest = static_equilibrium(model, inputs=inputs).config.q
    rng = np.random.default_rng(6)
    n = rest.size
    return [("rest", rest, np.zeros(n), np.ones(len(model.inputs))),
            ("moving", rest + 1e-4 * rng.standard_normal(n), 0.05 * rng.standard_normal(n),
             rng.standard_normal(len(model.inputs)))]


def normalisation_rows(model, layout, rows):
    """The kept rows that are the masters' Euler normalisations (a mask over rows)."""
    masters = set(layout.rotation[layout.rotation >= 0].tolist())
    mask = np.zeros(rows.size, dtype=bool)
    for group in model.groups:
        if group.kind.type_name != "EULER":
            continue
        for coords, defs in zip(group.coordinate_index, group.deformation_index, strict=True):
            if set(coords.tolist()) <= masters:
                mask |= np.isin(rows, defs)
    return mask


SCENES = ["stage_spatial_1dof", "stage_spatial_19dof",
          pytest.param("manipulator_control", marks=pytest.mark.slow)]


@pytest.mark.parametrize("name", SCENES)
def test_kept_multipliers_differ_by_the_eliminated_rows_on_the_normalisations(name):
    model = load_scene(name)
    clusters = find_clusters(model)
    layout = RigidLayout(model, clusters)
    removed = np.concatenate([model.groups[g].deformation_index[i]
                              for cluster in clusters for g, i in cluster.internal])
    mechanics = Mechanics(model)
    for label, q, qdot, inputs in states(model):
        ours, rows, z, x, K = multipliers(model, True, q, qdot, inputs)
        full, _, _, x_full, K_full = multipliers(model, False, q, qdot, inputs)
        scale = np.max(np.abs(full))
        assert np.max(np.abs(K - K_full)) <= 1e-12 * np.max(np.abs(K_full)), label
        De = mechanics.kinematics.configuration(q, x_full).De
        De = De.toarray() if hasattr(De, "toarray") else np.asarray(De)
        T = layout.transform(x_full, model.nx)
        units = np.eye(model.nx)[model.dof_coordinates]  # a DOF coordinate's row x = q
        J_kept = (np.vstack([De[rows], units]) @ T)[:, z]
        J_int = (De[removed] @ T)[:, z]
        norm = normalisation_rows(model, layout, rows)
        # J_int T lies in the span of the masters' normalisation rows (the radial direction)
        basis = J_kept[: rows.size][norm]
        coefficients = np.linalg.lstsq(basis.T, J_int.T, rcond=None)[0]
        assert np.max(np.abs(basis.T @ coefficients - J_int.T)) <= 1e-12 * np.max(
            np.abs(J_int)), label
        difference = ours[rows] - full[rows]
        expected = np.linalg.solve(J_kept.T, J_int.T @ full[removed])[: rows.size]
        assert np.max(np.abs(difference - expected)) <= RTOL * scale, label
        assert np.max(np.abs(difference[~norm])) <= RTOL * scale, label
        if label == "moving":  # the eliminated rows carry reactions: the difference shows
            assert np.max(np.abs(difference[norm])) > 1e3 * RTOL * scale
        # what the multipliers put on the reduced coordinates is the same
        J_rows = J_kept[: rows.size]
        assert np.max(np.abs(J_rows.T @ ours[rows] - (J_rows.T @ full[rows]
                                                        + J_int.T @ full[removed]))) <= (
            RTOL * scale), label


# the scene and its tolerance on |K0 + G0 + M_bar dqddot/dq| relative to the largest |G0|
# (central differences with h = 1e-7 on the DOFs; their h^2 truncation measured 6.3e-3 and
# 1.3e-4; leaving G0 out gives 1.0)
FD_SCENES = [("stage_spatial_19dof", 2e-2),
             pytest.param("manipulator_control", 1e-3, marks=pytest.mark.slow)]


@pytest.mark.parametrize(("name", "tolerance"), FD_SCENES)
def test_the_clustered_tangent_is_the_finite_differences_of_qddot(name, tolerance):
    """K0 + G0 of the clustered packing against central differences of its own qddot at
    the loaded rest (1 N on each input): M_bar dqddot/dq = -(K0 + G0) (module docstring)."""
    model = load_scene(name)
    solution = static_equilibrium(model, inputs={port.name: 1.0 for port in model.inputs})
    q, n, h = solution.config.q, model.ndof, 1e-7
    data = EngineData(model)
    data.float_array("inputs")[:] = 1.0
    assert engine.call(data, engine.OP_EVALUATE, q, np.zeros(n)) == ed.OK
    assert engine.call(data, engine.OP_TANGENT, data.float_array("qddot").copy()) == ed.OK
    M = data.float_array("mass").reshape(n, n).copy()
    K = data.float_array("stiffness").reshape(n, n).copy()
    differences = np.empty((n, n))
    for j in range(n):
        sides = []
        for sign in (1.0, -1.0):
            moved = q.copy()
            moved[j] += sign * h
            assert engine.call(data, engine.OP_EVALUATE, moved, np.zeros(n)) == ed.OK
            sides.append(data.float_array("qddot").copy())
        differences[:, j] = (sides[0] - sides[1]) / (2 * h)
    G0 = linearize(model, solution, compiled=True).G0
    assert np.max(np.abs(K + M @ differences)) <= tolerance * np.max(np.abs(G0))
