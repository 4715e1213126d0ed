"""The linearisation through the compiled engine (core/analysis/linear_engine.py) against the
numpy reference (`Mechanics`), which `linearize(..., compiled=False)` runs.

The scenes of tests/test_static_engine.py that the engine takes (every built-in scene, a
moment about a global axis with an actuator, a massless model), a kinematic input held, and
a pose under loads other than the scene's, are each solved once and linearised both ways.

Tolerances:
- M0, C0, K0 and K = K0 + G0 within 1e-10 of the largest entry of the numpy path's (G0 of
  K's): both sum the same products in another order (measured 3.4e-15 and below);
- the state space A, B, C, D (`state_space_matrices`, or `LinearModel.state_matrices`
  where the model declares no outputs) within 1e-10 of each matrix's largest entry, and
  the natural frequencies within 1e-9 relative: M0^-1 K carries the matrices' round-off times
  the conditioning of M0 (measured 2e-13 and below);
- where the frequencies span decades, the lowest carry the matrices' round-off delta
  (relative to the largest entry) amplified by (f_max / f)^2: within 1e-9 + delta
  (f_max / f)^2 relative on every model (a perturbation of K by delta |K| moves an
  eigenvalue lambda_i by at most about delta lambda_max, so f_i by delta (f_max / f_i)^2 /
  2), which adds to 1e-9 only there: the 500- to 800-DOF manipulators (outside the
  engine's window: asked for with compiled=True; 11.7 Hz to 5e5 Hz, (f_max / f)^2 ~ 2e9;
  measured 3.2e-8 on manipulator_e1's third mode, 1.9e-8 on manipulator's) and the
  26-BEAM cantilever (20.9 Hz to 4.7e5 Hz, 5e8; measured 3.4e-8, as the numpy path's own
  eigensolver round-off, eps (f_max / f)^2 = 1e-7, lets it be; delta 2.1e-13: its DOFs are
  deformations, whose DeF = De DF are nearly unit rows, and the tangent's K = DF^T (K_x DF)
  cancels the stiffness carried through the chain's lever arms in DF, where forming De DF
  first cancels before S: round-off larger by about |De| |DF|).
"""

import numpy as np
import pytest
from kinematic_scenes import chain
from test_static_engine import LARGE, SCENES

from flexure.core import build_model, load_scene
from flexure.core.analysis import linear_engine, static_engine
from flexure.core.analysis.linearization import linearize
from flexure.core.analysis.modal import natural_frequencies
from flexure.core.analysis.statespace import state_space_matrices
from flexure.core.analysis.statics import static_equilibrium
from flexure.core.engine import data as ed
from flexure.core.mechanics.mechanics import Mechanics
from flexure.core.mechanics.scales import dof_tolerances


def held_chain():
    """The spring-mass chain with its first node prescribed 2 mm from its place."""
    model = build_model(chain())
    return model, static_equilibrium(model, motions={"u": 0.102})


def loaded_pose():
    """The spatial stage under 20 times its scene's loads: the solution holds loads that
    are not the model's."""
    model = load_scene("stage_spatial_19dof")
    return model, static_equilibrium(model, loads=20.0 * model.loads)


def solved(name):
    """(model, its equilibrium under the scene's loads and 1 N on every input)."""
    if name == "chain, kinematic input held":
        return held_chain()
    if name == "spatial stage under 20 times its loads":
        return loaded_pose()
    model, inputs = SCENES[name]()
    return model, static_equilibrium(model, inputs=inputs)


TAKEN = [name for name in SCENES if "gravity" not in name]  # gravity: test_the_refused_models
TAKEN += ["chain, kinematic input held", "spatial stage under 20 times its loads"]


def largest(matrix):
    return float(np.max(np.abs(matrix), initial=0.0))


@pytest.mark.parametrize("name", [
    pytest.param(name, marks=pytest.mark.slow) if name in LARGE else name for name in TAKEN])
def test_engine_linearisation_matches_the_numpy_reference(name):
    model, solution = solved(name)
    mech = Mechanics(model)
    assert linear_engine.supports(model, mech)
    engine_path = linearize(model, solution, mechanics=mech, compiled=True)
    reference = linearize(model, solution, mechanics=mech, compiled=False)
    K_scale = largest(reference.K)
    for field, scale in (("M0", largest(reference.M0)), ("C0", largest(reference.C0)),
                         ("K0", largest(reference.K0)), ("G0", K_scale), ("K", K_scale)):
        error = largest(getattr(engine_path, field) - getattr(reference, field))
        assert error <= 1e-10 * scale, f"{name}: {field} differs by {error:.2e} of {scale:.2e}"
    if largest(reference.M0) == 0.0:  # massless: no dynamics
        return
    if model.inputs and model.outputs:
        matrices = zip(state_space_matrices(model, linear_model=engine_path),
                       state_space_matrices(model, linear_model=reference), strict=True)
    else:
        matrices = zip(engine_path.state_matrices()[:2], reference.state_matrices()[:2],
                       strict=True)
    for ours, theirs in matrices:
        assert largest(ours - theirs) <= 1e-10 * largest(theirs), name
    ours = natural_frequencies(model, linear_model=engine_path).frequencies_hz
    theirs = np.abs(natural_frequencies(model, linear_model=reference).frequencies_hz)
    # module docstring: the round-off delta of K and M0 moves f_i by about delta (f_max /
    # f_i)^2 / 2 relative (f_max / f_1 is 4e4 on the manipulators, 2.3e4 on the cantilever)
    delta = max(largest(engine_path.K - reference.K) / K_scale,
                largest(engine_path.M0 - reference.M0) / largest(reference.M0))
    rtol = 1e-9 + delta * (theirs.max() / theirs) ** 2
    assert np.all(np.abs(ours - theirs) <= rtol * theirs), name


@pytest.mark.parametrize("name", ["manipulator_control", "spatial beam, actuator and moment "
                                  "about z", "stage_spatial_19dof"])
def test_the_multipliers_are_those_of_the_loads(name):
    """The engine's tangent under the loads themselves (the statics' balance at the
    equilibrium: OP_ACCELERATIONS at qdot = 0, OP_TANGENT at qddot = 0, its multipliers
    J^-T r of the dynamic balance) is the linearisation's K, which the multipliers of the
    solution's stress resultants weigh (`linear_engine`): the dynamic balance's multipliers
    at the equilibrium are the static ones."""
    model, solution = solved(name)
    balance = static_engine.EngineBalance(model)
    balance.set_load(1.0, None, solution.port_values)
    Q, K = balance.residual_and_tangent(solution.config)
    lin = linearize(model, solution, compiled=True)
    assert largest(K - lin.K) <= 1e-10 * largest(lin.K)
    assert largest(lin.G0) > 1e-6 * largest(lin.K)  # the multipliers weigh something
    units = dof_tolerances(model, 1.0)
    assert largest(np.linalg.solve(K, Q) / units) <= 1e-10  # an equilibrium of those loads


def test_the_default_path_and_the_statics_left_as_they_were():
    """The default: the engine where the statics have packed it (a loaded equilibrium of a
    model in their window: the same matrices as compiled=True), numpy before (an unloaded
    one); the statics' packed model afterwards as the statics left it (no damping, its
    evaluation without M_bar), and its next solve the same."""
    model = load_scene("manipulator_control")
    mech = Mechanics(model)
    unloaded = static_equilibrium(model, mechanics=mech)  # one numpy Newton step
    assert not linear_engine.packed(model) and not linear_engine.preferred(model, mech)
    default, reference = (linearize(model, unloaded, mechanics=mech, compiled=compiled)
                          for compiled in (None, False))
    assert np.array_equal(default.K, reference.K) and not linear_engine.packed(model)
    inputs = np.ones(len(model.inputs))
    solution = static_equilibrium(model, inputs=inputs, mechanics=mech)
    assert linear_engine.packed(model) and linear_engine.preferred(model, mech)
    default, engine_path = (linearize(model, solution, mechanics=mech, compiled=compiled)
                            for compiled in (None, True))
    for field in ("M0", "C0", "K0", "G0"):
        assert np.array_equal(getattr(default, field), getattr(engine_path, field))
    assert largest(engine_path.C0) > 0.0
    dims = static_engine.engine_balance(model).data.int_array("dims")
    assert dims[ed.HAS_DAMPING] == 0
    assert dims[ed.STATIC] == 1  # its evaluation without M_bar again
    again = static_equilibrium(model, inputs=inputs, compiled=True)
    assert np.max(np.abs(again.q - solution.q) / dof_tolerances(model, 1.0)) <= 1e-10
    small, _ = held_chain()  # outside the window: 1 DOF, 2 free coordinates
    assert not linear_engine.preferred(small, Mechanics(small))


def test_the_refused_models():
    """Kinematic inputs with actuators (which the engine's packing refuses) take the numpy
    path, also when the engine is asked for, with the same answer. Gravity on a BEAM's
    consistent mass is in the engine's tangent (tests/test_gravity_stiffness.py)."""
    data = chain()
    data["inputs"]["F"] = {"node": "2", "coordinate": "x"}
    data["actuators"] = {"VCM": {"input": "F", "force_constant": 2.0, "drive": "current"}}
    model = build_model(data)
    assert not linear_engine.supports(model, Mechanics(model))
    solution = static_equilibrium(model, inputs={"F": 0.5})
    asked = linearize(model, solution, compiled=True)
    reference = linearize(model, solution, compiled=False)
    assert np.array_equal(asked.K, reference.K) and np.array_equal(asked.C0, reference.C0)
    # the held chain: node 2 on the 500 N/m spring, 0.25 kg, 0.2 N s/m
    assert abs(asked.K[0, 0] - 500.0) <= 1e-9 and abs(asked.M0[0, 0] - 0.25) <= 1e-15
    assert abs(asked.C0[0, 0] - 0.2) <= 1e-12
