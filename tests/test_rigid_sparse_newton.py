"""The ESDIRK's sparse Newton matrix on models with rigid clusters (`engine.newton_rigid`).

With clusters the Newton matrix's H = M + hg C_x + hg^2 K_x lives on the reduced free
coordinates z: the augmented system's mass block, each touching element's K_e and C_e
carried by T_e, the slaves' curvature contracted with the eliminated rows' forces. Checked
here:

- the solve against (I - hg J)^-1 of the dense path's J (the engine's OP_JACOBIAN, whose
  tangent forms the same terms in DOF space: `tangent`, `rigid_kernels.rigid_geometric`) at
  a moved, moving state with inputs, on manipulator_control (75 DOFs, spatial clusters, on
  the path by default), stage_planar_3dof (planar clusters), wire_tripod and
  stage_spatial_19dof (spatial clusters; the small ones with the path forced:
  SPARSE_NEWTON_FROM lowered, both matrices sparse), and manipulator_reduced (507 DOFs,
  slow);
- a 10 ms loop of manipulator_control on the sparse path (mass-form stages, the input
  response from a stage force's A) against the dense path's (slow);
- which models with clusters take the path, and that a moment input on a slave keeps a
  model off it.

The stage force, the force solve and the input response after a stage force with clusters:
tests/test_stage_force.py ("manipulator_clusters").
"""

import numpy as np
import pytest

from flexure.core import Mechanics, Simulator, load_scene
from flexure.core.engine import data as ed
from flexure.core.engine import engine, newton_packing
from flexure.core.engine.data import EngineData
from flexure.core.engine.operations import OP_NEWTON_JACOBIAN
from tests.compiled_loops import run_compiled_loop
from tests.test_engine import close
from tests.test_sparse_newton import newton_solve_beside_dense

# the scene, whether the path is forced (threshold lowered, both matrices sparse), the bound
# of the solve's error relative to the solution's size
MODELS = {"manipulator_control": (False, 1e-9), "stage_planar_3dof": (True, 1e-9),
          "wire_tripod": (True, 1e-9), "stage_spatial_19dof": (True, 1e-9)}
STEPS = (2e-8, 1e-5, 1e-3)  # hg (s): the Newton matrix near I and far from it


def packed(name, forced, monkeypatch):
    """(model, data) of the scene with its rigid clusters eliminated, on the sparse path."""
    model = load_scene(name)
    if forced:
        monkeypatch.setattr(newton_packing, "SPARSE_NEWTON_FROM", 0)
    data = EngineData(model, augmented=True, sparse=True if forced else None)
    dims = data.int_array("dims")
    assert dims[ed.NSLAVES] > 0 and dims[ed.NEWTON_SPARSE] == 1
    return model, data


def check_solve(name, forced, bound, monkeypatch):
    """The sparse solve against numpy's solve with the dense path's J at a state 1e-4 (m or
    rad) from the scene's DOFs with velocities 0.05 m/s (rad/s) and inputs of 1 N (N m),
    within bound x the solution's size; with J at rest the solution differs by more than
    1e-6 of its size, so the state's terms count."""
    model, data = packed(name, forced, monkeypatch)
    q0 = Mechanics(model).kinematics.dofs_of(model.initial_coordinates)
    n = q0.size
    rng = np.random.default_rng(7)
    q, qdot = q0 + 1e-4 * rng.standard_normal(n), 0.05 * rng.standard_normal(n)
    u = rng.standard_normal(len(model.inputs))
    q_ref = data.float_array("q_ref")
    rest = np.zeros(4 * n * n)
    assert engine.call(data, engine.OP_JACOBIAN, np.concatenate([q0 - q_ref, np.zeros(n)]),
                       rest) == ed.OK
    data.float_array("inputs")[:] = u
    y = np.concatenate([q - q_ref, qdot])
    J = np.zeros(4 * n * n)
    assert engine.call(data, engine.OP_JACOBIAN, y, J) == ed.OK
    J, rest = J.reshape(2 * n, 2 * n), rest.reshape(2 * n, 2 * n)
    assert engine.call(data, OP_NEWTON_JACOBIAN, y, np.zeros(1)) == ed.OK
    moved = False
    for hg in STEPS:
        r = rng.standard_normal(2 * n)
        v, expected = newton_solve_beside_dense(data, J, hg, r)
        size = np.max(np.abs(expected))
        close(v, expected, bound, scale=size)
        at_rest = np.linalg.solve(np.eye(2 * n) - hg * rest, r)
        moved = moved or np.max(np.abs(at_rest - expected)) > 1e-6 * size
    assert moved


@pytest.mark.parametrize("name", sorted(MODELS))
def test_the_sparse_newton_solve_with_clusters_is_the_dense_one(name, monkeypatch):
    """(I - hg J)^-1 r by the sparse path on z against the dense path's, to 1e-9 of the
    solution's size (measured: 8e-14 on manipulator_control, 4e-15 on stage_planar_3dof,
    3e-15 on wire_tripod, 3e-11 on stage_spatial_19dof, whose matrix mixes the units of q
    and qdot as the cantilever's does: tests/test_sparse_newton.py)."""
    forced, bound = MODELS[name]
    check_solve(name, forced, bound, monkeypatch)


@pytest.mark.slow
def test_the_reduced_manipulators_sparse_solve_is_the_dense_one(monkeypatch):
    """The same on manipulator_reduced (507 DOFs) to 1e-8 of the solution's size (measured
    2.4e-10: the dense J's M_bar^-1 [K C] at 507 DOFs carries its own round-off)."""
    check_solve("manipulator_reduced", False, 1e-8, monkeypatch)


def test_which_models_with_clusters_take_the_sparse_newton_matrix(monkeypatch):
    """manipulator_control (75 DOFs) by default; stage_planar_3dof (3 DOFs, below
    SPARSE_NEWTON_FROM) keeps the dense one, and forced it takes the path only with its
    augmented system factored sparse (H's mass block is assembled through that system's
    sparse map)."""
    assert EngineData(load_scene("manipulator_control")).int_array("dims")[
        ed.NEWTON_SPARSE] == 1
    stage = load_scene("stage_planar_3dof")
    assert EngineData(stage, augmented=True).int_array("dims")[ed.NEWTON_SPARSE] == 0
    monkeypatch.setattr(newton_packing, "SPARSE_NEWTON_FROM", 0)
    banded = EngineData(load_scene("stage_planar_3dof"), augmented=True,
                        sparse=False).int_array("dims")
    assert banded[ed.A_SPARSE] == 0 and banded[ed.NEWTON_SPARSE] == 0
    assert EngineData(load_scene("stage_planar_3dof"), augmented=True,
                      sparse=True).int_array("dims")[ed.NEWTON_SPARSE] == 1


@pytest.mark.slow
def test_the_manipulator_loop_on_the_sparse_path_tracks_as_on_the_dense_one(monkeypatch):
    """A 10 ms move of manipulator_control at 4 kHz (esdirk, rtol 1e-6, the compiled loop)
    with its clusters on the sparse Newton path (mass-form stages; the first stage after
    each input change takes the input response from a stage force's A) against the dense
    path (threshold raised): both solve each stage to the Newton tolerance, 0.05 of the
    step's tolerance, so the positions agree within 2 x 0.05 x rtol of the stroke per
    sample, bound 0.1 x samples x rtol x stroke (measured 3.3e-10 of the stroke against
    4e-6); the forces (the feedback of those positions) within 1e-5 of the largest
    (measured 2.1e-7)."""
    from flexure.controllers import build_loop

    model = load_scene("manipulator_control")
    controller, design = build_loop(model, stroke=1e-3, duration=0.01, settle=0.0025,
                                    fs=4000.0)
    runs = []
    for threshold in (newton_packing.SPARSE_NEWTON_FROM, 10**9):
        monkeypatch.setattr(newton_packing, "SPARSE_NEWTON_FROM", threshold)
        sim = Simulator(model, method="esdirk", rtol=1e-6)
        assert sim.data.int_array("dims")[ed.NEWTON_SPARSE] == int(threshold < 10**9)
        assert sim.data.int_array("dims")[ed.NSLAVES] > 0
        runs.append(run_compiled_loop(sim, controller, design))
    (t, position, force), (_, position_d, force_d) = runs
    stroke = np.ptp(position_d)
    assert stroke > 5e-4
    close(position, position_d, 0.1 * t.size * 1e-6, scale=stroke)
    close(force, force_d, 1e-5)



def test_a_moment_on_a_slave_keeps_the_dense_newton_matrix_and_moves_as_on_its_master(
        tmp_path, monkeypatch):
    """wire_tripod's moment input moved from the platform's rotation Pr (the master) to the
    top of wire 1, T1r (a slave of the rigid arm's cluster): a moment on a slave's Euler
    parameters would need T in its load stiffness, so with the path forced that model keeps
    the dense Newton matrix (`newton_packing._moment_on_slaves`) where the master's takes
    the sparse one. A rigid arm carries the moment whole, so both move alike: 20 ms under
    2 mN m by esdirk at rtol 1e-9 (the simulator packs both on the dense path by their
    size), the outputs within 1e-9 of the rotation's range (measured 5e-15: the models
    differ only in where the moment enters)."""
    from flexure.core import simulate
    from flexure.core.scene.building import scene_path

    monkeypatch.setattr(newton_packing, "SPARSE_NEWTON_FROM", 0)
    text = scene_path("wire_tripod").read_text()
    moved = text.replace('[inputs.M]\nnode = "Pr"', '[inputs.M]\nnode = "T1r"')
    assert moved != text
    on_slave = tmp_path / "wire_tripod_moment_on_t1r.toml"
    on_slave.write_text(moved)
    runs = []
    for model, sparse in ((load_scene("wire_tripod"), 1), (load_scene(on_slave), 0)):
        data = EngineData(model, augmented=True, sparse=True)
        assert data.int_array("dims")[ed.NSLAVES] > 0
        assert data.int_array("dims")[ed.NEWTON_SPARSE] == sparse
        runs.append(simulate(model, 0.02, inputs={"M": 2e-3}, method="esdirk", rtol=1e-9,
                             output_times=np.linspace(0.0, 0.02, 21)))
    master, slave = (run.output_array for run in runs)
    rotation = [k for k, name in enumerate(runs[0].output_names) if "rz" in name]
    assert rotation and np.ptp(master[:, rotation]) > 1e-6
    close(slave, master, 1e-9, scale=np.ptp(master[:, rotation]))
