"""The modal feedforward's refusals say what to do: lowest modes of one frequency (the
tripod's x and y), and lowest modes the loops do not drive or see."""

import tomllib

import numpy as np
import pytest

from flexure.controllers import low_frequency_model
from flexure.controllers.feedback import LoopPair
from flexure.controllers.feedforward import refusal_message
from flexure.core import build_model, natural_frequencies, scene_path
from flexure.core.errors import FlexureError


def test_degenerate_lowest_modes_are_refused_with_what_to_do():
    """One loop on the tripod's x: its modes 1 and 2 (x and y, 120-degree symmetry) share a
    frequency, so "the lowest mode" is any combination of them; refused, always (not only
    when the eigensolver's basis happens to be singular for the loop)."""
    data = tomllib.loads(scene_path("wire_tripod").read_text())
    del data["inputs"]["Fy"], data["inputs"]["M"]
    model = build_model(data)
    hz = natural_frequencies(model, 2).frequencies_hz
    assert hz[1] == pytest.approx(hz[0], rel=1e-12)  # the premise: one frequency
    with pytest.raises(FlexureError) as refused:
        low_frequency_model(model)
    message = str(refused.value)
    assert "modes 1, 2 share one frequency (12.2596 Hz)" in message
    assert "Close loops on the lowest 2 modes" in message
    assert "--feedforward inverse" in message and "--no-feedforward" in message


def test_a_mode_the_loops_miss_names_the_modes_and_the_remedies():
    pairs = [LoopPair(0, 0, "F", "x")]
    model = build_model(tomllib.loads(scene_path("stage_planar_1dof").read_text()))
    message = refusal_message(model, pairs, np.array([10.6, 2128.9]), 1)
    assert "needs the 1 lowest mode(s) (10.6 Hz) driven and seen by the 1 loop(s) (F->x)" in (
        message)
    assert message.endswith("or use --feedforward inverse (the inverse of the model's own "
                            "linear dynamics), or --no-feedforward")


def test_the_three_loops_of_the_tripod_still_have_their_inverse():
    """Three loops invert all three modes: nothing past the last mode to be degenerate with."""
    model = build_model(tomllib.loads(scene_path("wire_tripod").read_text()))
    lf = low_frequency_model(model)
    assert lf.mass.shape == (3, 3)
    # the platform's mass on x and y (the wires' share on top): at least its 0.5 kg
    assert lf.mass[0, 0] >= 0.5 and lf.mass[1, 1] == pytest.approx(lf.mass[0, 0], rel=1e-9)
