"""The FMU of a scene with a voice-coil actuator under fmpy: its drive input (V) and coil
current output (A), stepped against the in-process Simulator bit for bit, states included."""

import tomllib

import numpy as np
from fmpy import read_model_description
from fmpy_slave import Slave

from flexure.core import Simulator, build_model, scene_path, scene_toml
from flexure.fmu import build_scene_fmu
from flexure.fmu.scene_slave import DEFAULT_RTOL, METHODS

KM, R, L = 2.0, 2.0, 0.01  # N/A, ohm, H


def actuated_scene(path):
    """truss_1dof_x, its input F the drive of a saturating voltage amplifier (gain 2, 1.5 V),
    written to `path`; the Model."""
    data = tomllib.loads(scene_path("truss_1dof_x").read_text())
    data["scene"]["name"] = "truss_vcm"
    data["nodes"]["2"].pop("force")
    data["actuators"] = {"VCM1": {"input": "F", "force_constant": KM, "resistance": R,
                                  "inductance": L, "amplifier_gain": 2.0, "saturation": 1.5}}
    path.write_text(scene_toml(data))
    return build_model(data)


def test_the_fmu_steps_the_drive_signal_as_the_simulator_does_bit_for_bit(tmp_path):
    model = actuated_scene(tmp_path / "truss_vcm.toml")
    fmu = build_scene_fmu(tmp_path / "truss_vcm.toml", tmp_path / "truss_vcm.fmu",
                          tunable=["actuators.VCM1.resistance"])
    md = read_model_description(str(fmu))
    variables = {v.name: v for v in md.modelVariables}
    assert (variables["F"].causality, variables["F"].unit) == ("input", "V")
    assert "drive signal of actuator VCM1 (voltage amplifier)" in variables["F"].description
    assert (variables["VCM1.current"].causality, variables["VCM1.current"].unit) == (
        "output", "A")
    assert variables["actuators.VCM1.resistance"].unit == "Ohm"
    volt = next(u for u in md.unitDefinitions if u.name == "V").baseUnit
    assert (volt.kg, volt.m, volt.s, volt.A) == (1, 2, -3, -1)
    refs = [variables[name].valueReference for name in ("x", "VCM1.current")]
    slave = Slave(fmu)
    try:
        sim = Simulator(model, method=METHODS[0], rtol=DEFAULT_RTOL)
        sim.reset()
        h = 2e-3
        drives = [0.3, 0.3, 1.2, 1.2, -0.4, 0.0, 0.9, 0.9, 0.9, 0.1] * 2

        def run(start, stop):
            rows = []
            for k in range(start, stop):
                slave.fmu.setReal([variables["F"].valueReference], [drives[k]])
                slave.fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
                rows.append(slave.fmu.getReal(refs))
            return np.array(rows)

        half = len(drives) // 2
        first = run(0, half)
        state = slave.fmu.getFMUstate()
        rest = run(half, len(drives))
        expected = []
        for k, u in enumerate(drives):
            if k == half:
                sim.get_state()  # as the FMU's: taking a state marks a restart point
            sim.set_inputs([u])
            sim.advance_to(k * h + h)  # the FMU's t + h
            expected.append([sim.outputs()[0], sim.currents[0]])
        assert np.array_equal(np.vstack([first, rest]), np.array(expected))
        assert np.max(np.abs(rest[:, 1])) > 0.5  # amperes: the coil carries current
        slave.fmu.setFMUstate(state)
        assert np.array_equal(run(half, len(drives)), rest)  # the current restored too
        slave.fmu.freeFMUstate(state)
    finally:
        slave.close()
