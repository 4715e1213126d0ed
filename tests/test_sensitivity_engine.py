"""Design sensitivities through the compiled engine (core/analysis/sensitivity_engine.py)
against the numpy path, and the sweep's rule for taking it.

Tolerances. The values and the analytic derivatives come from one static solution per path,
each Newton's to 1e-11 of a DOF's unit: they agree to VALUES_RTOL = 1e-9 relative (measured
8.7e-12 on this CPU, 7.3e-11 on the second target, and the analytic derivatives identical).
A difference-scheme derivative of either path carries its own error estimate E
(`sensitivity`: Richardson's |D(h/2) - D(h)| / 3 plus 1e-12 of the values over h), and on
top of it the values' own agreement: values off by VALUES_RTOL |F| at each of the four
points move the extrapolated D = (4 D(h/2) - D(h)) / 3 by at most (8 / 3 + 1 / 3)
VALUES_RTOL |F| / h. So the two paths' derivatives must agree within E_numpy + E_engine +
3 VALUES_RTOL |F| / h. Measured on stage_spatial_19dof: 0.0045 of that bound on the
development CPU and 0.056 on the second target, where the estimates alone would not do (2.5
times them: the second frequency's slope by node 3's y differs by 3.3e-4 Hz/m, 3.3e-8 Hz
over h = 1e-4 m, 3e-10 of the frequency, the statics' tolerance); truss_1dof_x (one DOF, its
Newton ending on the same float) identical on both.
"""

import numpy as np
import pytest

from examples.benchmarks.spatial import spatial_cantilever
from flexure.core import load_scene, sensitivities
from flexure.core.analysis import sensitivity_engine, static_engine

VALUES_RTOL = 1e-9  # the two paths' values, relative (module docstring)


def both_paths(scene, keys):
    """(numpy's Sensitivities, the engine's) of `scene` for `keys`, six modes."""
    return tuple(sensitivities(load_scene(scene), keys, modes=6, compiled=compiled)
                 for compiled in (False, True))


@pytest.mark.parametrize("scene, keys", [
    ("stage_spatial_19dof", ["sections.leaf.height", "nodes.3.position[1]",
                             "sections.bar.rho_A"]),
    ("truss_1dof_x", ["sections.springs.EA", "nodes.2.position[0]"]),
])
def test_the_engine_and_numpy_derivatives_agree_within_their_error_estimates(scene, keys):
    numpy_path, engine_path = both_paths(scene, keys)
    assert numpy_path.quantities == engine_path.quantities
    np.testing.assert_array_equal(numpy_path.methods, engine_path.methods)
    np.testing.assert_allclose(engine_path.values, numpy_path.values, rtol=VALUES_RTOL,
                               atol=VALUES_RTOL * np.max(np.abs(numpy_path.values)))
    differenced = numpy_path.methods == "central difference"
    assert differenced.any()
    gap = np.abs(engine_path.derivatives - numpy_path.derivatives)
    with np.errstate(divide="ignore"):  # an analytic key's step is 0: not differenced
        values_term = 3.0 * VALUES_RTOL * np.outer(np.abs(numpy_path.values),
                                                   1.0 / numpy_path.steps)
    bound = numpy_path.errors + engine_path.errors + values_term
    assert np.all(gap[differenced] <= bound[differenced]), np.max(
        gap[differenced] / bound[differenced])
    analytic = ~differenced
    np.testing.assert_allclose(engine_path.derivatives[analytic],
                               numpy_path.derivatives[analytic], rtol=1e-9, atol=0.0)


def test_the_rule_takes_the_engine_from_its_work_on_models_it_fits():
    stage = load_scene("stage_spatial_19dof")  # 19 DOFs: work 20 per evaluation
    assert sensitivity_engine.sweep_evaluations(3) == 13
    assert sensitivity_engine.preferred(stage, 13)  # 260 >= 250
    assert not sensitivity_engine.preferred(stage, 12)  # 240
    truss = load_scene("truss_1dof_x")  # 1 DOF: work 2 per evaluation
    assert sensitivity_engine.preferred(truss, 125)
    assert not sensitivity_engine.preferred(truss, 124)
    large = spatial_cantilever(51)  # 306 DOFs, above what a sweep packs the engine for
    assert large.ndof > sensitivity_engine.SWEEP_MAX_DOFS
    assert not sensitivity_engine.preferred(large, 1000)
    assert sensitivity_engine.statics_path(large, 1000, None) is False


def test_an_explicit_path_is_kept_and_none_leaves_the_statics_their_own_rule():
    stage = load_scene("stage_spatial_19dof")
    assert sensitivity_engine.statics_path(stage, 1, True) is True
    assert sensitivity_engine.statics_path(stage, 1000, False) is False
    assert sensitivity_engine.statics_path(stage, 1, None) is None
    assert sensitivity_engine.statics_path(stage, 13, None) is True


@pytest.mark.parametrize("keys, engine", [
    (["sections.leaf.height", "sections.leaf.width", "nodes.3.position[1]"], True),
    (["sections.leaf.height", "sections.leaf.width"], False),
])
def test_a_sweep_by_default_packs_the_engine_where_the_rule_says(keys, engine):
    """The base model's statics pack the engine (`static_engine.live_balance`) only on the
    engine's path: three keys (13 evaluations, work 260) take it, two (9, 180) do not."""
    model = load_scene("stage_spatial_19dof")
    sensitivities(model, keys, modes=2)
    assert (static_engine.live_balance(model) is not None) is engine
