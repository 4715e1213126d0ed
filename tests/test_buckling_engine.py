"""Buckling load factors through the compiled engine (`buckling_load_factors(...,
compiled=True)`: K0 from the engine's DeF and S, G0 from its tangent at the equilibrium)
against the numpy reference (`compiled=False`), and against Euler's load of a column.

Tolerances:
- the load factors within 1e-8 relative: K0 and K0 + G0 agree to round-off of |K|
  (tests/test_linear_engine.py), and G0 = K - K0 carries that round-off, which a factor
  lambda_i feels relative to G0's eigenvalue 1 / lambda_i: measured 4e-13 on the smallest
  factors, 2.4e-9 on stage_planar_3dof's second (96000 times its first) and 5e-10 on
  stage_spatial_19dof's (its equilibria of the two paths agree within 1e-10 of a DOF's unit);
- Euler's load of a clamped-guided column 4 pi^2 E I / L^2, within 1e-3 on 8 Hermite BEAMs,
  the error falling as h^4 (measured 5.1e-4 on 8 elements, 3.1e-5 on 16).
"""

import numpy as np
import pytest
from test_beam_torsion import LENGTH, STRIP, E, strip

from flexure.core import build_model, load_scene
from flexure.core.analysis import linear_engine, static_engine
from flexure.core.analysis.modal import buckling_load_factors
from flexure.core.mechanics.mechanics import Mechanics

# every built-in scene with a [buckling] section or loads (none of them in the statics'
# window: asked for with compiled=True)
LOADED = ["stage_planar_1dof", "stage_planar_3dof", "stage_spatial_1dof", "wire_tripod",
          "stage_spatial_19dof", "truss_1dof_e", "truss_1dof_x"]
RTOL = 1e-8


@pytest.mark.parametrize("name", LOADED)
def test_the_engine_buckles_the_scenes_as_numpy_does(name):
    model = load_scene(name)
    assert linear_engine.supports(model, Mechanics(model))
    plain = buckling_load_factors(model, compiled=False)
    engine = buckling_load_factors(model, compiled=True)
    assert engine.shape == plain.shape
    np.testing.assert_allclose(engine, plain, rtol=RTOL)


def test_the_engine_is_the_default_where_the_statics_solve_through_it():
    """manipulator_control (784 free coordinates, 75 DOFs: in the statics' window) under
    a compressive 1 N on its first translational DOF's coordinate: the statics pack the
    engine, and the buckling takes it by default."""
    model = load_scene("manipulator_control")
    assert static_engine.preferred(model)
    loads = np.zeros(model.nx)
    loads[model.dof_coordinates[0]] = -1.0
    default = buckling_load_factors(model, 3, loads=loads)
    assert linear_engine.preferred(model, Mechanics(model))  # packed: the engine path ran
    plain = buckling_load_factors(model, 3, loads=loads, compiled=False)
    assert default.size == plain.size == 3
    np.testing.assert_allclose(default, plain, rtol=RTOL)


def test_a_clamped_column_buckles_at_eulers_load_through_the_engine():
    """The strip of tests/test_beam_torsion.py under 1 N of compression, clamped at one end
    and guided at the other: 4 pi^2 E Iz / L^2 (18.7 N), on 8 and 16 BEAMs."""
    euler = 4 * np.pi**2 * E * STRIP["Iz"] / LENGTH**2
    errors = []
    for elements in (8, 16):
        model = build_model(strip(elements, tension=-1.0))
        (factor,) = buckling_load_factors(model, 1, compiled=True)
        np.testing.assert_allclose(factor, buckling_load_factors(model, 1, compiled=False),
                                   rtol=RTOL)
        errors.append(factor / euler - 1.0)
    assert 0.0 < errors[0] < 1e-3
    assert 12.0 < errors[0] / errors[1] < 20.0  # h^4: 16
