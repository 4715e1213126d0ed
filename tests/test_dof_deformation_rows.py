"""`motion.qddot_of_solution` skips the walk over every element's deformations
(`deformation_rates.dof_deformation_accelerations`) where no DOF is a deformation (dims.nedof
= 0): the walk then writes nothing, so the accelerations are bit for bit those of the plain
path. Checked on the walk itself, at a state an evaluation left: with a sentinel (NaN) in
every entry of qddot, it writes exactly the DOF deformations' rows (NXDOF ..), and none
where there are none.
"""

import numpy as np
import pytest

from flexure.core import Simulator, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine.deformation_rates import dof_deformation_accelerations

# (scene, its number of DOF deformations): the loop plants (manipulator_control, the planar
# stage) have none; truss_1dof_e's one DOF is an elongation. The manipulator's Simulator takes
# seconds to build: the slow tier
SCENES = [pytest.param("manipulator_control", 0, marks=pytest.mark.slow),
          ("stage_planar_1dof", 0), ("truss_1dof_e", 1)]


def _evaluated(scene):
    """A Simulator of `scene` a few steps into a free motion from rest (its engine's slots
    hold an evaluation: x, xddot, De)."""
    sim = Simulator(load_scene(scene), method="esdirk2", rtol=1e-5)
    sim.advance_to(1e-4)
    return sim


@pytest.mark.parametrize(("scene", "nedof"), SCENES)
def test_the_walk_writes_only_the_dof_deformation_rows(scene, nedof):
    sim = _evaluated(scene)
    dims = sim.data.int_array("dims")
    assert dims[ed.NEDOF] == nedof
    n_xdof, ndof = int(dims[ed.NXDOF]), int(dims[ed.NDOF])
    xddot = sim.data.float_array("xddot").copy()
    quad = sim.data.float_array("g").copy()
    for moving in (False, True):
        qddot = np.full(ndof, np.nan)
        dof_deformation_accelerations(sim.data.address, xddot, quad, moving, qddot)
        # the DOF coordinates' rows are never the walk's: skipping it where nedof = 0 leaves
        # qddot as qddot_of_solution filled it, bit for bit
        assert np.all(np.isnan(qddot[:n_xdof]))
        assert np.all(np.isfinite(qddot[n_xdof:]))
        assert qddot.size - n_xdof == nedof
