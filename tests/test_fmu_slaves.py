"""The slave script docs/fmu.md exports as its example: examples/fmu_slaves/pi_controller.py,
built with `build_slave_fmu` and stepped by fmpy against the discrete PI law it states."""

from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy_slave import Slave

from flexure.fmu import build_slave_fmu

SCRIPT = Path(__file__).parents[1] / "examples" / "fmu_slaves" / "pi_controller.py"
H = 1e-3  # s


@pytest.fixture(scope="module")
def controller(tmp_path_factory):
    fmu = build_slave_fmu(SCRIPT, tmp_path_factory.mktemp("slave") / "pi_controller.fmu")
    description = read_model_description(str(fmu))
    folder = extract(str(fmu), unzipdir=str(fmu.parent / "unzipped"))
    instance = FMU2Slave(guid=description.guid, unzipDirectory=folder,
                         modelIdentifier=description.coSimulation.modelIdentifier,
                         instanceName="pi")
    instance.instantiate()
    yield description, instance
    instance.freeInstance()


def test_the_pi_controller_fmu_follows_its_law(controller):
    description, fmu = controller
    units = {v.name: v.unit for v in description.modelVariables}
    assert units == {"x": "m", "reference": "m", "F": "N", "kp": "N/m", "ki": "N/(m.s)"}
    vr = {v.name: v.valueReference for v in description.modelVariables}
    kp, ki, error = 500.0, 3e4, 2e-4  # N/m, N/(m s), m
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["kp"], vr["ki"]], [kp, ki])
    fmu.exitInitializationMode()
    for k in range(1, 4):
        fmu.setReal([vr["x"], vr["reference"]], [0.1 - error, 0.1])
        fmu.doStep(currentCommunicationPoint=(k - 1) * H, communicationStepSize=H)
        force = fmu.getReal([vr["F"]])[0]
        assert force == pytest.approx(kp * error + ki * k * H * error, rel=1e-12)


def test_a_negative_gain_is_refused_and_named(tmp_path):
    """The script's check_value refuses kp < 0: the set is logged naming it, and the next
    doStep is discarded (the error state), as for flexure's own slaves."""
    fmu = build_slave_fmu(SCRIPT, tmp_path / "pi_controller.fmu")
    with pytest.raises(Exception, match="fmi2DoStep"):
        slave = Slave(fmu, parameters={"kp": -1.0})
        slave.step(0.0, H)
    assert any("kp = -1.0: expected a gain >= 0" in message for _, message in slave.logs)
    slave.close()
