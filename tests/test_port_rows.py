"""The state space's input columns and output rows through the compiled engine (OP_PORT_ROWS,
core/engine/port_entries.py) against the numpy ports (`input_columns`, `output_rows`).

Every built-in scene with inputs and outputs that the engine linearises (the stages, the
truss, the wire tripod with its moment input and angle output, manipulator_control with its
three angle outputs, manipulator_control_vcm with its six voltage-driven coils), the wire
tripod with its platform's angular velocity and acceleration out too, the spatial beam with a
voice coil and a moment about z, and the spatial stage under loads other than its scene's,
each solved once (tests/test_linear_engine.py's `solved`) and linearised through the engine,
whose rows are those of its tangent's evaluation.

Tolerances:
- the rows b_j^T DF and d y / d q within 1e-12 of the largest entry of the numpy rows at the
  solution's x and DF: the same products in another order, on the engine's DF and x, which
  agree with the solution's to its kinematic tolerance of 1e-14 (measured 1e-15 and below);
- the state space with the engine's rows against the same state space with the numpy rows
  (the same M0, C0 and K, so that only the rows differ): A, B, C, D within 1e-12 of each
  matrix's largest entry, the poles within 1e-10 of the largest one's magnitude (A differs
  only in the coils' rows and columns, by round-off), and the frequency responses at the
  natural frequencies and between them within 1e-9 of their largest magnitude (at a
  resonance H carries A's round-off times the damping's inverse, about 1e3 here).
"""

import dataclasses

import numpy as np
import pytest
from kinematic_scenes import chain, scene
from test_linear_engine import solved

from flexure.core import build_model
from flexure.core.analysis import linear_engine
from flexure.core.analysis.linearization import linearize
from flexure.core.analysis.statespace import state_space_matrices
from flexure.core.analysis.statics import static_equilibrium
from flexure.core.mechanics.mechanics import Mechanics
from flexure.core.mechanics.ports import input_columns, output_rows

NAMES = ["stage_planar_1dof", "stage_planar_3dof", "stage_spatial_1dof", "stage_spatial_19dof",
         "truss_1dof_e", "truss_1dof_x", "wire_tripod", "manipulator_control",
         "manipulator_control_vcm", "spatial beam, actuator and moment about z",
         "spatial stage under 20 times its loads", "wire_tripod, angular rates"]


def largest(matrix):
    return float(np.max(np.abs(matrix), initial=0.0))


def tripod_rates():
    """wire_tripod with the angular velocity and acceleration about z of its platform out too
    (no built-in scene has a rate about a global axis: its row is 2 E_k DF_l), 1 N on every
    input."""
    data = scene("wire_tripod")
    data["scene"]["name"] = "wire_tripod_rates"
    for name, quantity in (("wz", "velocity"), ("az", "acceleration")):
        data["outputs"][name] = {"node": "Pr", "coordinate": "rz", "quantity": quantity}
    model = build_model(data)
    return model, static_equilibrium(model, inputs=np.ones(len(model.inputs)))


def both_ways(name):
    """(model, the linearisation through the engine, the numpy rows at its solution)."""
    model, solution = tripod_rates() if name == "wire_tripod, angular rates" else solved(name)
    mech = Mechanics(model)
    assert linear_engine.supports(model, mech), name
    lin = linearize(model, solution, mechanics=mech, compiled=True)
    assert lin.input_rows is not None and lin.output_rows is not None, name  # the engine's
    x, DF = solution.config.x, lin.DF
    return model, lin, (input_columns(model, x).T @ DF, output_rows(model, x, DF))


@pytest.mark.parametrize("name", NAMES)
def test_the_engine_rows_are_the_numpy_ports(name):
    model, lin, (inputs, outputs) = both_ways(name)
    assert lin.input_rows.shape == (len(model.inputs), lin.M0.shape[0])
    assert lin.output_rows.shape == (len(model.outputs), lin.M0.shape[0])
    for ours, theirs, what in ((lin.input_rows, inputs, "inputs"),
                               (lin.output_rows, outputs, "outputs")):
        scale = largest(theirs)
        assert scale > 0.0, name
        error = largest(ours - theirs)
        assert error <= 1e-12 * scale, f"{name}: {what} differ by {error:.2e} of {scale:.2e}"


def test_the_engine_rows_with_a_kinematic_input_held():
    """The spring-mass chain with node 1 prescribed 2 mm from its place, a force on node 2 and
    node 1's position out: the engine's rows on the DOFs proper (the prescribed one's column
    dropped, as the matrices'), the force's column the unit on 2.x, node 1's row zero."""
    data = chain()
    data["inputs"]["F"] = {"node": "2", "coordinate": "x"}
    data["outputs"]["x1"] = {"node": "1", "coordinate": "x"}
    model = build_model(data)
    solution = static_equilibrium(model, motions={"u": 0.102})
    lin = linearize(model, solution, compiled=True)
    assert lin.input_rows is not None  # the engine's
    np.testing.assert_allclose(lin.input_rows, [[1.0]], rtol=0.0, atol=1e-14)
    np.testing.assert_allclose(lin.output_rows, [[1.0], [1.0], [0.0]], rtol=0.0, atol=1e-14)


def response(A, B, C, D, omega):
    """H(j omega) = C (j omega I - A)^-1 B + D, by a dense solve."""
    return C @ np.linalg.solve(1j * omega * np.eye(A.shape[0]) - A, B) + D


@pytest.mark.parametrize("name", ["stage_planar_3dof", "stage_spatial_19dof",
                                  "wire_tripod, angular rates", "manipulator_control",
                                  "manipulator_control_vcm",
                                  "spatial beam, actuator and moment about z"])
def test_the_state_space_with_the_engine_rows(name):
    model, lin, (inputs, outputs) = both_ways(name)
    numpy_rows = dataclasses.replace(lin, input_rows=inputs, output_rows=outputs)
    ours = state_space_matrices(model, linear_model=lin)[:4]
    theirs = state_space_matrices(model, linear_model=numpy_rows)[:4]
    for a, b, what in zip(ours, theirs, "ABCD", strict=True):
        assert largest(a - b) <= 1e-12 * largest(b), f"{name}: {what}"
    A, B, C, D = ours
    poles = np.sort_complex(np.linalg.eigvals(A))
    reference = np.sort_complex(np.linalg.eigvals(theirs[0]))
    assert largest(poles - reference) <= 1e-10 * largest(reference), name
    # at the natural frequencies (the poles' imaginary parts) and half-way between them
    omegas = np.unique(np.abs(reference.imag[reference.imag > 0.0]))
    omegas = np.concatenate([omegas, np.sqrt(omegas[1:] * omegas[:-1]), [1e-3 * omegas[0]]])
    H = np.array([response(A, B, C, D, w) for w in omegas])
    H_ref = np.array([response(*theirs, w) for w in omegas])
    assert largest(H - H_ref) <= 1e-9 * largest(H_ref), name
