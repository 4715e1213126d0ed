"""The closed loop as a sweep analysis: `flexure sweep SCENE --analyses loop`.

`LOOP` is registered in the entry-point group "flexure.sweep_analyses" (pyproject.toml), so
that flexure.core's sweep finds it by name without importing controllers
(`flexure.core.sweep.analyses` says why). At each point it runs `run_loop` on the
point's model, in process (on the nonlinear model, or with `--loop-plant linear` on its
linearisation, stepped exactly: far faster on a large model), with the options below, and
reports (the moving loop's units: m and N, or rad and N m on a planar angle):

- `loop.error_ratio [-]`: max |r - y| over the samples divided by the stroke (the target of
  `flexure loop` is 0.001);
- `loop.max_abs_error [m]`: max |r - y|;
- `loop.max_abs_force [N]`: the largest force (feedback plus feedforward);
- `loop.phase_margin [deg]`: of the feedback designed for that point;
- `loop.wall_time [s]`: the run's wall time, the one column that differs between two runs of
  the same sweep.
"""

from flexure.core.sweep.analyses import (
    SweepAnalysis,
    SweepOption,
    nonnegative,
    positive,
)


def _units(model):
    """(position unit, force unit) of the first colocated loop, or m and N."""
    from .feedback import ControlDesignError, colocated_pairs

    try:
        pair = colocated_pairs(model)[0]
    except (ControlDesignError, IndexError):
        return "m", "N"
    # "N.m", the scene's spelling of a moment's unit, as the loop's summary writes it: "N m"
    return (model.outputs[pair.output_index].unit,
            model.inputs[pair.input_index].unit.replace(".", " "))


def in_process_plant(text):
    """"inprocess" or "linear", the plants a sweep point runs in its own process; ValueError
    otherwise."""
    if text not in ("inprocess", "linear"):
        raise ValueError(f"expected inprocess or linear, got {text!r}")
    return text


def _columns(model, options):
    position, force = _units(model)
    return ["loop.error_ratio [-]", f"loop.max_abs_error [{position}]",
            f"loop.max_abs_force [{force}]", "loop.phase_margin [deg]", "loop.wall_time [s]"]


def _evaluate(model, options):
    from .runner import run_loop

    result = run_loop(model, stroke=options["stroke"], duration=options["duration"],
                      settle=options["settle"], fs=options["fs"],
                      crossover=options["crossover"], plant=options["plant"])
    summary = result.summary()
    names = _columns(model, options)
    values = [summary["error_ratio"], summary["max_abs_error"], summary["max_abs_force"],
              summary["phase_margin_deg"], summary["wall_time_s"]]
    return {name: float(value) for name, value in zip(names, values, strict=True)}


LOOP = SweepAnalysis(
    name="loop", columns=_columns, evaluate=_evaluate,
    options=(
        SweepOption("stroke", 1e-3, positive, "stroke of the move, m (rad on an angle)", "S"),
        SweepOption("duration", 1.0, positive, "duration of the move (s)", "T"),
        SweepOption("settle", 0.25, nonnegative, "time simulated after the move (s)", "T"),
        SweepOption("fs", 4000.0, positive, "sample rate of the controller (Hz)", "HZ"),
        SweepOption("crossover", 300.0, positive, "cross-over of the feedback (rad/s)",
                    "RAD_S"),
        SweepOption("plant", "inprocess", in_process_plant,
                    "inprocess (the nonlinear model) or linear (its linearisation)", "PLANT"),
    ))
