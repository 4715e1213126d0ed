"""The per-DOF velocity tolerance that `examples/benchmarks/velocity_atol.py` measures against
the default (docs/benchmarks.md, session 36: measured, not kept): its velocities against a
plain numpy formula from the numpy `Mechanics`' mass and stiffness in the start
configuration, and its invariants."""

import numpy as np
import pytest

from examples.benchmarks.velocity_atol import per_dof_atol
from flexure.core import default_atol, load_scene
from flexure.core.mechanics.mechanics import Mechanics


def dense(matrix):
    return matrix.toarray() if hasattr(matrix, "toarray") else np.asarray(matrix)


@pytest.mark.parametrize("scene", ["stage_planar_3dof", "stage_spatial_19dof"])
def test_per_dof_velocities_are_the_positions_times_the_diagonal_rayleigh_frequency(scene):
    model = load_scene(scene)
    n, rtol = model.ndof, 1e-5
    old, new = default_atol(model, rtol), per_dof_atol(model, rtol)
    # numpy M0 and K0 in the unloaded start configuration (no stress: no geometric stiffness),
    # not the engine's Jacobian that the rule reads
    mechanics = Mechanics(model)
    start = mechanics.initial_configuration()
    M0 = dense(mechanics.mass_matrix(start))
    K0 = dense(mechanics.structural_stiffness(start))
    omega_ref = old[n] / old[0]  # the default's one frequency, rad/s
    expected = old[:n] * np.maximum(omega_ref, np.sqrt(np.diag(K0) / np.diag(M0)))
    # the engine's K0 (-M0 d qddot / d q) is the structure's to 8e-6 of its largest entry on
    # the spatial stage (1e-16 on the planar one), half that in its square root
    np.testing.assert_allclose(new[n:2 * n], expected, rtol=1e-5)
    # the positions are the default's; no velocity is tighter than the default's
    np.testing.assert_array_equal(new[:n], old[:n])
    assert np.all(new[n:2 * n] >= old[n:2 * n])
    # the lowest mode's frequency is at most the largest diagonal one (Rayleigh quotients)
    assert np.max(new[n:2 * n] / new[:n]) >= omega_ref * (1 - 1e-12)


def test_one_dof_has_the_default_tolerance():
    model = load_scene("stage_planar_1dof")  # one DOF: K0 / M0 is the lowest frequency
    np.testing.assert_allclose(per_dof_atol(model, 1e-6), default_atol(model, 1e-6),
                               rtol=1e-10)
