"""Outputs on elements (SPACAR's OUTE, OUTF) in an FMU: each an output variable in m or N,
updated after every step, in force-driven FMUs (stage_planar_3dof, stage_spatial_1dof) and
a displacement-driven one (the pushed chain: a truss's elongation moved). Checked in fmpy: the
model description validates and declares them; over a run on a variable grid the FMU's
values (constitutive stress resultants, a prescribed deformation's and rigid ones'
reactions) equal the in-process Simulator's given the same inputs. The simulation's own
checks: test_simulation_element_outputs.py."""

import numpy as np
import pytest
from element_output_scenes import pushed_chain, stage_planar, stage_spatial
from fmpy import read_model_description
from fmpy_slave import Slave

from flexure.core import Simulator, build_model, scene_toml
from flexure.fmu import build_scene_fmu, validate_fmu_file

STEPS = np.array([1e-3, 2.5e-3, 0.4e-3, 1.7e-3, 3e-3, 0.9e-3, 1e-3, 2e-3] * 3)  # s
TIMES = np.concatenate([[0.0], np.cumsum(STEPS)])
SCENES = {"stage": stage_planar, "spatial": stage_spatial, "pushed": pushed_chain}


@pytest.fixture(scope="module")
def element_fmus(tmp_path_factory):
    """{name: FMU path} of the two scenes, each built once."""
    folder = tmp_path_factory.mktemp("element_fmus")
    paths = {}
    for name, make in SCENES.items():
        scene = folder / f"{name}.toml"
        scene.write_text(scene_toml(make(), "a test of outputs on elements in an FMU"))
        paths[name] = build_scene_fmu(scene, folder / f"{name}.fmu")
    return paths


@pytest.mark.parametrize("name, outputs", [
    ("stage", ["x", "y", "e1_left", "e2_left", "N_left", "M2_left", "M3_right", "N_bar",
               "M2_bar"]),
    ("spatial", ["x", "y", "e5_left", "M5_left", "M6_left", "T_right", "e6_right", "N_left",
                 "T_left"]),
    ("pushed", ["x2", "push", "stretch", "eb", "fb", "L.effort"]),
])
def test_the_model_description_declares_them(element_fmus, name, outputs):
    """fmpy validates the FMU; each element output is a continuous output after the
    coordinate outputs, in m or N, described by its deformation."""
    path = element_fmus[name]
    assert validate_fmu_file(path) == []
    md = read_model_description(str(path))
    assert [v.name for v in md.modelVariables if v.causality == "output"] == outputs
    model = build_model(SCENES[name]())
    by_name = {v.name: v for v in md.modelVariables}
    for port in model.element_outputs:
        variable = by_name[port.name]
        assert (variable.unit, variable.variability) == (port.unit, "continuous")
        what = "deformation" if port.quantity == "deformation" else "stress resultant"
        assert variable.description == f"{what} of {model.deformation_names[port.deformation]}"


def inputs_at(name, k):
    """The input set before step k: a stage's force (N), varied; the pushed chain's
    elongation at the step's end (m), a smooth 1 mm move."""
    if name != "pushed":
        return [1.0 + 0.5 * np.sin(7.0 * k)]
    t = TIMES[k + 1]
    return [1e-3 * (1 - np.cos(np.pi * min(t / TIMES[-1], 1.0))) / 2]


@pytest.mark.parametrize("name", SCENES)
def test_the_fmu_gives_the_in_process_simulators_values(element_fmus, name):
    """On a variable grid, after every step, every output (those on elements too) equals
    the in-process Simulator's given the same inputs (the same method, esdirk at rtol
    1e-6): within 1e-9 of the largest of its unit over the run (measured 0: the same code).
    In the pushed chain the truss's force is minus its elongation's effort, in the FMU too."""
    model = build_model(SCENES[name]())
    slave = Slave(element_fmus[name])
    try:
        rows = []
        for k, (t, h) in enumerate(zip(TIMES[:-1], STEPS, strict=True)):
            slave.set(inputs_at(name, k))
            rows.append(slave.step(float(t), float(h)))
        fmu = np.array(rows)
    finally:
        slave.close()
    kinematic = bool(model.kinematic_inputs)
    sim = Simulator(model, method="esdirk", rtol=1e-6, stepwise_motion=kinematic)
    ours = []
    for k, t1 in enumerate(TIMES[1:]):
        if kinematic:
            sim.move_to(inputs_at(name, k), float(t1))
            ours.append([*sim.outputs(), *sim.efforts()])
        else:
            sim.set_inputs(inputs_at(name, k))
            sim.advance_to(float(t1))
            ours.append(sim.outputs())
    ours = np.array(ours)
    units = sim.output_units + ["N"] * len(model.kinematic_inputs)
    assert fmu.shape == ours.shape
    for column, unit in enumerate(units):
        scale = np.max(np.abs(ours[:, [u == unit for u in units]]))
        assert np.all(np.abs(fmu[:, column] - ours[:, column]) <= 1e-9 * scale), column
    if kinematic:
        push, effort = fmu[:, 1], fmu[:, -1]
        assert np.max(np.abs(push)) > 0.01
        assert np.all(np.abs(push + effort) <= 1e-12 * np.max(np.abs(push)))
