"""The linearisation through the sparse Newton matrix's packing (core/analysis/linear_sparse.py)
against the numpy reference (`linearize(..., compiled=False)`), on models whose statics step
sparse (from `static_engine.SPARSE_STEP_FROM` = 240 DOFs).

Tolerances (as tests/test_linear_engine.py's, whose module docstring derives them):
- M0, C0, K0, G0 and K within 1e-10 of the largest entry of the numpy path's (G0 of K's):
  the same products summed in another order (measured 2e-16 to 4e-15);
- the state space A, B, C, D within 1e-9 of each matrix's largest entry: A = -M0^-1 K
  carries the matrices' round-off times the conditioning of M0, large on the cantilever,
  whose DOFs are deformations (measured 1.6e-10 there);
- the natural frequencies within 1e-9 + delta (f_max / f_i)^2 relative, delta the matrices'
  measured round-off relative to their largest entries: where the frequencies span decades
  the lowest carry delta amplified so (the 816-DOF manipulator's first mode 6e-8, f_max / f_1
  = 4.2e4); 1e-9 flat on the modes where delta (f_max / f_i)^2 < 1e-10 (its seventh to
  tenth within 2.5e-10).
"""

import dataclasses

import numpy as np
import pytest

from examples.benchmarks.spatial import cantilever_spec
from flexure.core import build_model, load_scene
from flexure.core.analysis import linear_engine, static_engine
from flexure.core.analysis.linearization import linearize
from flexure.core.analysis.modal import natural_frequencies
from flexure.core.analysis.statespace import state_space_matrices
from flexure.core.analysis.statics import static_equilibrium
from flexure.core.errors import ConvergenceError
from flexure.core.mechanics.mechanics import Mechanics

BEAMS = 48  # 288 DOFs: the statics step sparse


def cantilever():
    """The spatial strip of 48 BEAMs, 1 N down at the tip, a force input along y at the tip
    and the tip's y as output; (model, its equilibrium under 0.5 N on the input)."""
    spec = cantilever_spec(BEAMS, name="cantilever_288")
    tip = str(BEAMS)
    spec["nodes"][tip]["force"] = [0.0, 0.0, -1.0]
    spec["inputs"] = {"F": {"node": tip, "coordinate": "y"}}
    spec["outputs"] = {"tip": {"node": tip, "coordinate": "y"}}
    model = build_model(spec)
    return model, static_equilibrium(model, inputs=np.array([0.5]))


def manipulator(name):
    """A built-in manipulator with 1 N on every input and its equilibrium."""
    model = load_scene(name)
    return model, static_equilibrium(model, inputs=np.ones(len(model.inputs)))


def largest(matrix):
    return float(np.max(np.abs(matrix), initial=0.0))


CASES = {"cantilever 288 DOFs": cantilever,
         "manipulator_reduced": lambda: manipulator("manipulator_reduced"),
         "manipulator": lambda: manipulator("manipulator")}


@pytest.mark.parametrize("name", [
    pytest.param(name, marks=pytest.mark.slow) if name.startswith("manipulator") else name
    for name in CASES])
def test_the_sparse_linearisation_matches_the_numpy_reference(name):
    model, solution = CASES[name]()
    mech = Mechanics(model)
    balance = static_engine.engine_balance(model)
    assert balance.sparse and not balance.packed_dense
    assert linear_engine.preferred(model, mech)  # the default: the engine, on this packing
    ours = linearize(model, solution, mechanics=mech)
    assert not balance.packed_dense  # the reduced form was not packed for it
    assert ours.input_rows is not None  # the rows from OP_PORT_ROWS
    reference = linearize(model, solution, mechanics=mech, compiled=False)
    K_scale = largest(reference.K)
    for field, scale in (("M0", largest(reference.M0)), ("C0", largest(reference.C0)),
                         ("K0", largest(reference.K0)), ("G0", K_scale), ("K", K_scale)):
        error = largest(getattr(ours, field) - getattr(reference, field))
        assert error <= 1e-10 * scale, f"{name}: {field} differs by {error:.2e} of {scale:.2e}"
    assert largest(reference.G0) > 1e-8 * K_scale  # the multipliers weigh something
    for mine, theirs in zip(ours.port_rows(), reference.port_rows(), strict=True):
        assert largest(mine - theirs) <= 1e-10 * largest(theirs), name
    for mine, theirs in zip(state_space_matrices(model, linear_model=ours),
                            state_space_matrices(model, linear_model=reference), strict=True):
        assert largest(mine - theirs) <= 1e-9 * largest(theirs), name
    f_ours = natural_frequencies(model, linear_model=ours).frequencies_hz
    f_ref = np.abs(natural_frequencies(model, linear_model=reference).frequencies_hz)
    delta = max(largest(ours.K - reference.K) / K_scale,
                largest(ours.M0 - reference.M0) / largest(reference.M0))
    amplified = delta * (f_ref.max() / f_ref) ** 2
    assert np.all(np.abs(f_ours - f_ref) <= (1e-9 + amplified) * f_ref), name
    plain = amplified < 1e-10  # where the round-off is not amplified: 1e-9 flat
    assert plain.any()
    assert np.all(np.abs(f_ours - f_ref)[plain] <= 1e-9 * f_ref[plain]), name


def test_buckling_and_compiled_true_take_the_sparse_packing():
    """compiled=True on a model the statics step sparse reads the same packing (no reduced
    form packed), and gives the default's matrices to the bit."""
    model, solution = cantilever()
    mech = Mechanics(model)
    asked = linearize(model, solution, mechanics=mech, compiled=True)
    default = linearize(model, solution, mechanics=mech)
    for field in ("M0", "C0", "K0", "G0"):
        assert np.array_equal(getattr(asked, field), getattr(default, field))
    assert not static_engine.engine_balance(model).packed_dense


def test_an_unsolvable_configuration_is_a_convergence_error():
    """DOFs at which the engine cannot evaluate the model (not finite) raise
    ConvergenceError naming the model."""
    model, solution = cantilever()
    mech = Mechanics(model)
    config = dataclasses.replace(solution.config, q=np.full(model.ndof, np.nan))
    broken = dataclasses.replace(solution, config=config)
    with pytest.raises(ConvergenceError, match="cantilever_288"):
        linear_engine.engine_matrices(model, broken, mech)
