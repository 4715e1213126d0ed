"""The statics tangent K0 + G0 (`Mechanics.tangent_stiffness`) is the exact Jacobian of the
static residual, away from equilibrium (core/mechanics/mechanics.py, core/analysis/statics.py).

Newton's method in `static_equilibrium` converges quadratically only if the tangent it
solves with is -dQ/dq, where Q(q) = DF^T (f - De^T sigma_c) at x = F(q): out of equilibrium
that takes the multipliers of the rigid and DOF-deformation rows in the geometric stiffness
(the dependent coordinates' second-order kinematics), the load stiffness of gravity on element
mass and of moments about global axes, and an actuator's port value. Each scene is moved to a
configuration well away from equilibrium (random DOFs, loads and inputs held), and the
tangent is checked against central differences of Q, both in the dense and the sparse
assembly (`Mechanics.sparse`).

Tolerance: every entry of U K U (U the DOFs' units, L in m or 1 rad, so that every entry is in
N m) within 1e-6 of the largest, with steps of 1e-5 units: the central difference's
truncation is O(h^2) (4e-8 on the manipulator, whose Q is the most nonlinear: 4e-6 with
steps of 1e-4, 3e-10 with 1e-6) and the kinematics' convergence (1e-12 of a unit) puts
about 1e-12 / 1e-5 = 1e-7 of noise on it. The structural stiffness K0 alone misses by more than a
hundred times that at these configurations, so the check sees the geometric terms.
"""

import numpy as np
import pytest
from test_actuators_rotation import force_coil_scene
from test_rotation_ports import cantilever

from flexure.core import build_model, load_scene
from flexure.core.mechanics.actuators import steady_port_values
from flexure.core.mechanics.mechanics import Mechanics
from flexure.core.mechanics.scales import dof_tolerances

STEP = 1e-5  # units of each DOF: m through the length scale, rad through 1
TOLERANCE = 1e-6  # of the largest entry of U K U


def cantilever_with_gravity():
    """The spatial BEAM cantilever of test_rotation_ports (distributed mass, a rigid body on
    its tip) under gravity, with moments about the three global axes held on its tip."""
    data = cantilever()
    data["scene"]["gravity"] = [0.0, -9.81, -3.0]
    return build_model(data), np.array([0.3, -0.2, 0.5]), 2e-2  # N m


def coil_and_moment():
    """The cantilever with a voice-coil actuator driving the force on 3.y (its drive signal
    in V held, so its force at rest acts) and the moment about the global z axis."""
    model = build_model(force_coil_scene())
    return model, steady_port_values(model, np.array([2.0, 0.4])), 2e-2


def builtin(name, size=2e-2):
    """A built-in scene with forces of 10 N on its coordinate inputs, if it has any."""
    model = load_scene(name)
    return model, (np.full(len(model.inputs), 10.0) if model.inputs else None), size


SCENES = {
    "spatial beam, moments about global axes, gravity": cantilever_with_gravity,
    "spatial beam, actuator and moment about z": coil_and_moment,
    "spatial stage, rigid bodies and dependent nodes": lambda: builtin("stage_spatial_19dof"),
    "planar stage": lambda: builtin("stage_planar_3dof"),
    "wire tripod": lambda: builtin("wire_tripod"),
    # the manipulator's 75-DOF control model (784 free coordinates: the sparse assembly);
    # 2e-2 units at random would take it beyond its reach
    "manipulator": lambda: builtin("manipulator_control", 2e-3),
}
DENSE_TOO = [name for name in SCENES if name != "manipulator"]  # the small ones, both ways


def away_from_equilibrium(model, mech, seed, size):
    """A configuration with every DOF moved by `size` units at random from the scene's."""
    start = mech.initial_configuration()
    units = dof_tolerances(model, 1.0)  # m or rad per unit
    rng = np.random.default_rng(seed)
    q = start.q + size * units * rng.standard_normal(start.q.size)
    return mech.kinematics.solve(q, start.x), units


def tangent_and_differences(model, values, size, sparse):
    """(U K U, U K_fd U, U K0 U, Q) at a configuration `size` units from the scene's."""
    mech = Mechanics(model, sparse=sparse)
    kin = mech.kinematics
    config, units = away_from_equilibrium(model, mech, 3, size)

    def residual(q):
        return mech.static_balance(kin.solve(q, config.x), 1.0, None, values)[0]

    Q, _, sigma = mech.static_balance(config, 1.0, None, values)
    K0 = mech.structural_stiffness(config)
    K = mech.tangent_stiffness(config, sigma, 1.0, inputs=values)  # what Newton solves with
    separate = K0 + mech.geometric_stiffness(config, sigma, 1.0, inputs=values)
    np.testing.assert_allclose(K, separate, rtol=0, atol=1e-12 * np.max(np.abs(separate)))
    differences = np.empty_like(K)
    for j in range(units.size):
        h = np.zeros(units.size)
        h[j] = STEP * units[j]
        differences[:, j] = -(residual(config.q + h) - residual(config.q - h)) / (2 * h[j])
    U = np.diag(units)
    return U @ K @ U, U @ differences @ U, U @ K0 @ U, Q


@pytest.mark.parametrize(("name", "sparse"), [
    *((name, sparse) for name in DENSE_TOO for sparse in (False, True)),
    pytest.param("manipulator", None, marks=pytest.mark.slow)])  # 816 DOFs: 1.6 s
def test_the_statics_tangent_is_the_jacobian_of_the_residual(name, sparse):
    model, values, size = SCENES[name]()
    K, differences, K0, Q = tangent_and_differences(model, values, size, sparse)
    assert np.max(np.abs(Q)) > 0.0  # out of equilibrium
    largest = np.max(np.abs(differences))
    error = np.max(np.abs(K - differences))
    assert error <= TOLERANCE * largest, (
        f"{name}: tangent off by {error / largest:.2e} of its largest entry "
        f"(expected <= {TOLERANCE:g})")
    # the geometric terms are visible at this configuration: without them the check fails
    assert np.max(np.abs(K0 - differences)) > 1e2 * TOLERANCE * largest
