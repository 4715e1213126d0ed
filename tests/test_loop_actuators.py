"""The loop through voice coils: the feedforward becomes drive signals (V) through the coil's
equations, and the loop still tracks within 0.1 % of the stroke."""

import tomllib

import numpy as np
import pytest

from flexure.controllers.feedback import colocated_pairs
from flexure.controllers.feedforward import drive_signals
from flexure.controllers.runner import run_loop
from flexure.core import build_model, scene_path

KM, R, L = 5.0, 2.0, 1e-3  # N/A, ohm, H: a coil with a 0.5 ms time constant


def stage(**actuator):
    """stage_planar_1dof with its force F driven by a voice coil."""
    data = tomllib.loads(scene_path("stage_planar_1dof").read_text())
    keys = {"input": "F", "force_constant": KM, "resistance": R, "inductance": L}
    data["actuators"] = {"VCM": keys | actuator}
    return build_model(data, source="stage_planar_1dof + VCM")


@pytest.mark.parametrize("drive", ["voltage", "current"])
def test_the_loop_tracks_through_the_coil(drive):
    result = run_loop(stage(drive=drive, amplifier_gain=2.0), stroke=1e-3, duration=1.0)
    assert result.summary()["error_ratio"] < 1e-3
    # the drive signal, not the force: about F R / (Km G) or F / (Km G)
    force = result.feedforward[:, 0]
    assert np.max(np.abs(force)) < 0.2  # V: the stage needs about 1.5 N at 1 mm


def test_the_drive_signals_are_the_coils_equations():
    model = stage(amplifier_gain=2.0)
    pairs = colocated_pairs(model)
    fs = 1000.0
    t = np.arange(6) / fs
    forces = np.sin(3.0 * t)[:, None]  # N
    reference = (1e-3 * t**2)[:, None]  # m
    u = drive_signals(model, pairs, forces, reference, fs)[:, 0]
    i = forces[:, 0] / KM
    v = np.append(np.diff(reference[:, 0]) * fs, 0.0)
    expected = (R * i + L * np.gradient(i, 1.0 / fs) + KM * v) / 2.0
    np.testing.assert_allclose(u, expected, rtol=1e-14)
    current = drive_signals(stage(drive="current", amplifier_gain=2.0), pairs, forces,
                            reference, fs)[:, 0]
    np.testing.assert_allclose(current, forces[:, 0] / (KM * 2.0), rtol=1e-14)


@pytest.mark.parametrize("drive", ["voltage", "current"])
def test_the_low_frequency_plant_takes_the_coils_equations(drive):
    """On the 1-DOF stage the low-frequency model is the whole linear model (M0, C0, K), so
    with the coil's equations added it has the scene's state space's poles and DC gain: the
    voltage-driven coil's current a third state (its pole near -R / L, the back-EMF's
    Km^2 / R damping the mode), a current-driven coil the gain Km G."""
    import control

    from flexure.controllers.feedforward import low_frequency_model, low_frequency_plant
    from flexure.core import state_space

    model = stage(drive=drive, amplifier_gain=2.0)
    pairs = colocated_pairs(model)
    plant = low_frequency_plant(low_frequency_model(model), model, pairs)
    full = state_space(model)[pairs[0].output_index, pairs[0].input_index]
    states = 3 if drive == "voltage" else 2
    assert plant.nstates == states and full.nstates == states
    np.testing.assert_allclose(np.sort_complex(control.poles(plant)),
                               np.sort_complex(control.poles(full)), rtol=1e-9)
    assert control.dcgain(plant) == pytest.approx(control.dcgain(full), rel=1e-9)
    k = 945.0  # N/m, the stage's spring (closed-loop.md)
    gain = KM * 2.0 / R if drive == "voltage" else KM * 2.0  # N per V at rest
    assert control.dcgain(plant) == pytest.approx(gain / k, rel=1e-2)
