"""The engine's kinematics after chord iterations: the solution's deformations are of its x.

Warm-started from the last solution, `kinematics.solve_kinematics` predicts x to first order
and, when the prediction's constraint residual is not within the tolerance, takes chord
steps with the kept factors of J, evaluating each iterate's e together with De (the
solution's order) so that the iterate it stops at needs no evaluation of its own. Checked
here, for DOFs moved by about a loop's step (1e-6 m or rad, which the prediction does not
solve) from a solution: the kinematics solves the constraints (the engine's own test, then
the plain elements' e at its x), and slot e and slot De equal the plain elements' e and De
(each element kind's own numpy formulas) at the engine's x to round-off (e within 1e-14
of the largest coordinate, De within 1e-13 of its largest entry), on
manipulator_control with its rigid clusters (the elements inside a cluster are not
evaluated, and not compared) and on the planar stage.
"""

import numpy as np
import pytest

from flexure.core import Mechanics, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine
from flexure.core.engine.data import EngineData

STEP = 1e-6  # m or rad: the DOFs' move between two solutions


def group_rows(data, gp):
    """(e's model indices (n, k), slot De's view of group gp (n, k, m))."""
    group = data.model.groups[gp]
    n, m = group.coordinate_index.shape
    k = group.deformation_index.shape[1]
    row = data.int_array("groups").reshape(data.int_array("dims")[ed.NGROUPS], -1)[gp]
    start = row[ed.G_DE_OFFSET]
    return group.deformation_index, data.float_array("De")[start: start + n * k * m].reshape(
        n, k, m)


@pytest.mark.parametrize("name", [
    pytest.param("manipulator_control", marks=pytest.mark.slow),  # 2.5 s: its packing
    "stage_planar_1dof"])
def test_deformations_at_a_chord_solution_are_of_its_coordinates(name):
    model = load_scene(name)
    data = EngineData(model, augmented=True)
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    q = q0 + STEP * np.random.default_rng(3).standard_normal(q0.size)
    for dofs in (q0, q):  # the second from the first's solution
        assert engine.call(data, engine.OP_KINEMATICS, dofs) == ed.OK
    x = data.float_array("x").copy()
    np.testing.assert_allclose(Mechanics(model).kinematics.dofs_of(x), q, rtol=0, atol=1e-13)
    internal = data.rigid.internal_elements if data.rigid is not None else set()
    e_engine = data.float_array("e")
    compared = 0
    for gp, group in enumerate(model.groups):
        if group.deformation_index.shape[1] == 0:
            continue
        e, De = group.kind.deformations(group.local(x), group.reference, order=1)
        defs, De_engine = group_rows(data, gp)
        keep = np.array([(gp, i) not in internal for i in range(defs.shape[0])])
        # e: differences of coordinates, to their round-off (a stale e, of the DOFs STEP
        # away, would be off by about STEP)
        assert np.max(np.abs(e_engine[defs[keep]] - e[keep]), initial=0.0) <= 1e-14 * np.max(
            np.abs(x))
        scale = np.max(np.abs(De[keep]), initial=0.0)
        assert np.max(np.abs(De_engine[keep] - De[keep]), initial=0.0) <= 1e-13 * scale
        compared += int(keep.sum())
    assert compared > 0
