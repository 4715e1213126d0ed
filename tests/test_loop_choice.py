"""Loops by choice (`flexure loop --loop INPUT:OUTPUT`, `colocated_pairs(model, loops)`): the
chosen pairs form the loops and the other inputs stay open; every mistake in one line."""

import tomllib

import pytest
from cli_runs import run

from flexure.controllers.feedback import ControlDesignError, colocated_pairs, design_feedback
from flexure.core import build_model, scene_path

TRIPOD = build_model(tomllib.loads(scene_path("wire_tripod").read_text()))


def test_the_chosen_pairs_form_the_loops_in_their_order():
    pairs = colocated_pairs(TRIPOD, ["Fy:y", "F:x"])
    assert [(p.input_name, p.output_name) for p in pairs] == [("Fy", "y"), ("F", "x")]
    assert [(p.input_index, p.output_index) for p in pairs] == [
        ([p.name for p in TRIPOD.inputs].index("Fy"), [p.name for p in TRIPOD.outputs].index("y")),
        ([p.name for p in TRIPOD.inputs].index("F"), [p.name for p in TRIPOD.outputs].index("x"))]
    # without a choice: every input with its colocated output, as before
    assert [(p.input_name, p.output_name) for p in colocated_pairs(TRIPOD)] == [
        ("F", "x"), ("Fy", "y"), ("M", "rz")]


def test_two_loops_of_three_are_designed_and_stable():
    design = design_feedback(TRIPOD, loops=["F:x", "Fy:y"])
    assert [p.input_name for p in design.pairs] == ["F", "Fy"]
    assert design.feedback.D.shape == (2, 2)  # errors of two loops to two forces
    assert design.phase_margin_deg > 30.0  # the PID's design margin (docs/closed-loop.md)


@pytest.mark.parametrize("loops, message", [
    (["F"], "--loop 'F': expected INPUT:OUTPUT"),
    (["F:"], "expected INPUT:OUTPUT"),
    (["G:x"], "--loop G:x: wire_tripod has no input 'G'; its inputs are F, Fy, M"),
    (["F:w"], "has no position output 'w'; its position outputs are x, y, z, rz"),
    (["F:x", "F:y"], "--loop F:y: F is in the loop F:x already"),
    (["F:x", "Fy:x"], "--loop Fy:x: x is in the loop F:x already"),
    ([], "expected at least one INPUT:OUTPUT pair"),
])
def test_a_bad_loop_says_what_is_wrong(loops, message):
    with pytest.raises(ControlDesignError, match=message.replace("(", r"\(")):
        colocated_pairs(TRIPOD, loops)


@pytest.mark.parametrize("argv, message", [
    (["--loop", "F:x"], "modes 1, 2 share one frequency (12.2596 Hz)"),
    (["--loop", "G:x"], "wire_tripod has no input 'G'"),
    (["--loop", "F:x", "--move", "P.x=1e-3"], "--loop: a --move path is planned"),
])
def test_the_command_refuses_in_one_line(capsys, tmp_path, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "loop", "wire_tripod", "--plant", "linear", "--no-plot", *argv)
    assert code == 2 and message in err, err


@pytest.mark.slow
def test_two_loops_track_with_the_third_input_open(capsys):
    """x moves 1 mm and y holds, through F and Fy; the moment M stays open. The modal
    feedforward of the two lowest modes (x and y, one frequency: both inside) on the linear
    plant leaves an error far below flexure loop's 0.1 % target."""
    import json

    code, out, err = run(capsys, "loop", "wire_tripod", "--loop", "F:x", "--loop", "Fy:y",
                         "--plant", "linear", "--duration", "0.2", "--no-plot", "--json")
    assert code == 0, err
    summary = json.loads(out)
    assert summary["loops"] == ["F -> x", "Fy -> y"]
    assert summary["error_ratio"] < 1e-5
