"""Design sweeps: a scene evaluated over a grid of parameter values, serially or on Dask.

    points = grid([parse_parameter("sections.leaf.height=0.3e-3:0.8e-3:6"),
                   parse_parameter("nodes.3.mass=0,0.1,0.2")])
    rows = run_sweep(data, points, analyses=("static", "modes"), workers=2)

A parameter is a dotted scene key (an override, `flexure.core.scene.overrides`) with its values; the
grid is the Cartesian product of the parameters' values, the first parameter varying slowest.
Each point is one call of `evaluate_point`, a plain function of the scene dictionary and the
point's overrides that returns the point's quantities: the serial run calls it in this process,
the Dask run on the workers of a dask.distributed cluster (a LocalCluster of processes, one
thread each, or an existing scheduler). Both give the same numbers, bit for bit: the same
function on the same inputs, with flexure's BLAS calls on one thread in either case
(`flexure.core.numerics.blas`). A point that fails (a value the scene validation refuses, a static
equilibrium that does not converge) gives its reason in `status` and never stops the sweep.

The quantities (columns after the parameters, SI units):

- static: `static.NAME [m]` (or `[rad]`), the displacement of each output's coordinate at the
  static equilibrium under the scene's loads;
- modes: `mode.1 [Hz]` ... `mode.N [Hz]`, the lowest N natural frequencies there (blank past
  the model's DOF count);
- buckling: `buckling.1 [-]`, the first load factor of the reference load (blank if none);
- stress: `stress.max [Pa]`, the largest von Mises stress at the equilibrium (blank without
  sections that have dimensions);
- with a `stroke.NODE.AXIS` parameter, the analyses run at the equilibrium the inputs hold
  at that stroke, and the point gains the inputs' forces and the stiffness the stroke meets
  (`flexure.core.sweep.stroke`);
- simulate, loop, and any other registered analysis: the columns it declares
  (`flexure.core.sweep.analyses`: a step response here; the closed loop registered by
  flexure.controllers), with its options in `settings` {analysis: {option: value}}.

A row keeps what was computed before a failure. Dask is imported only when a sweep runs on it.
"""

import gc
import math
import os
from dataclasses import replace

import numpy as np

from ..errors import FlexureError, UsageError
from ..scene.overrides import parse_value
from . import analyses as registry
from .stroke import split_strokes, stroke_columns, stroke_point

__all__ = ["ANALYSES", "analysis_names", "columns", "evaluate_point", "grid",
           "parse_parameter", "run_sweep"]

# on the static equilibrium (or a stroke's, `stroke`); the others registered
ANALYSES = ("static", "modes", "buckling", "stress")
AT_A_STROKE = ("static", "modes", "stress")  # the analyses that run at a stroke's equilibrium
DEFAULT_MODES = 6
# the significant digits of a value of START:STOP:N, so that 0.3e-3:0.8e-3:6 gives 0.0004 and not
# linspace's 0.00039999999999999996 (a value the table and a user's --set both write plainly)
DIGITS = 15
CONNECT_TIMEOUT = "10s"  # to reach a --scheduler before the sweep is given up
# the most points one sweep runs: each is a full analysis (0.1 s to minutes), so 1e5 is
# already hours, while a grid of 1e8 would only fill the memory (3.4 GB) before the first
MAX_POINTS = 100_000


def parse_parameter(text: str) -> tuple[str, list]:
    """(KEY, values) of "KEY=START:STOP:N" (N values, linearly spaced, both ends included) or
    "KEY=V1,V2,..." (each a TOML value: 0.3e-3, 2, PLTRUSS); ValueError saying what is wrong."""
    key, sep, spec = text.partition("=")
    key, spec = key.strip(), spec.strip()
    if not sep or not key or not spec:
        raise ValueError(f"expected KEY=START:STOP:N or KEY=V1,V2,... with a dotted scene key, "
                         f"got {text!r}")
    if ":" in spec and "," not in spec and not spec.startswith(("[", '"', "'")):
        return key, _linear(text, spec)
    values = [parse_value(part.strip()) for part in spec.split(",")]
    for value in values:
        if values.count(value) > 1:
            raise ValueError(f"{text!r}: {value!r} is listed {values.count(value)} times; list "
                             "each value once")
    return key, values


def _linear(text, spec):
    parts = spec.split(":")
    expected = f"{text!r}: expected START:STOP:N (two finite numbers and a count >= 2)"
    if len(parts) != 3:
        raise ValueError(expected)
    try:
        start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise ValueError(expected) from None
    if not (math.isfinite(start) and math.isfinite(stop)) or count < 2:
        raise ValueError(expected)
    if count > MAX_POINTS:
        raise ValueError(f"{text!r}: {count} values, more than a sweep runs ({MAX_POINTS}): "
                         "each is a full analysis")
    if start == stop:
        raise ValueError(f"{text!r}: START and STOP are equal; give a single value as KEY=V")
    return [float(f"{v:.{DIGITS}g}") for v in np.linspace(start, stop, count)]


def grid(parameters) -> list[dict]:
    """The points of the Cartesian product of `parameters` [(key, values)]: one
    {key: value} per point, the first parameter varying slowest; UsageError for more than
    MAX_POINTS, before any is made."""
    size = math.prod(len(values) for _, values in parameters)
    if size > MAX_POINTS:
        counts = " x ".join(str(len(values)) for _, values in parameters)
        raise UsageError(f"--param: a grid of {counts} = {size} points, more than a sweep runs "
                         f"({MAX_POINTS}): each is a full analysis; sweep fewer values")
    points = [{}]
    for key, values in parameters:
        points = [{**point, key: value} for point in points for value in values]
    return points


def analysis_names() -> tuple[str, ...]:
    """Every analysis a sweep can run: ANALYSES, then the registered ones (simulate, loop...)."""
    return ANALYSES + tuple(name for name in registry.available() if name not in ANALYSES)


def columns(model, analyses, modes=DEFAULT_MODES, settings=None, strokes=(),
            stroke_inputs=None) -> list[str]:
    """The quantity columns of a sweep of `model`'s scene (see the module's docstring); a
    UsageError for an unknown analysis or options that do not fit the scene. `strokes` the
    stroke targets ("3.x") swept, `stroke_inputs` the inputs that drive them."""
    names = []
    if strokes:
        others = [name for name in analyses if name not in AT_A_STROKE]
        if others:
            raise UsageError(f"--param stroke.{strokes[0]}: the analyses at a stroke are "
                             f"{', '.join(AT_A_STROKE)}; not {', '.join(others)}")
        names += stroke_columns(model, list(strokes), stroke_inputs)
    if "static" in analyses:
        names += [f"static.{port.name} [{_unit(model, port)}]" for port in model.outputs]
    if "modes" in analyses:
        names += [f"mode.{i} [Hz]" for i in range(1, modes + 1)]
    if "buckling" in analyses:
        names.append("buckling.1 [-]")
    if "stress" in analyses:
        names.append("stress.max [Pa]")
    for name in analyses:
        if name not in ANALYSES:
            analysis = registry.find(name)
            names += analysis.columns(model, registry.option_values(
                analysis, (settings or {}).get(name)))
    return names


def _unit(model, port):
    """m for a translational coordinate, rad for a rotational one or an angle about a global
    axis (whatever the output reports, position or velocity: the column is the coordinate's
    displacement, or the angle's change)."""
    if port.about_axis:
        return "rad"
    axis = model.coordinate_names[port.coordinate].rsplit(".", 1)[1]
    return "m" if axis in ("x", "y", "z") else "rad"


def evaluate_point(scene: dict, overrides: dict, *, analyses=("static", "modes"),
                   modes: int = DEFAULT_MODES, source: str = "<dict>",
                   default_name: str = "scene", settings: dict | None = None,
                   stroke_inputs: list | None = None) -> dict:
    """The quantities of one grid point: {column: value} (floats, SI units) and "status".

    `scene` is the scene dictionary, `overrides` the point's {dotted key: value} (its
    parameters and any fixed overrides); `source` and `default_name` as for `build_model`;
    `settings` {analysis: {option: value}} the options of the registered analyses;
    `stroke_inputs` the inputs that drive the point's `stroke.*` targets (default: the
    scene's). "status" is "ok", or the one-line reason the point failed, without the name of
    the scene file every row shares (the columns computed before it are kept). This is the function
    each Dask task runs; it raises nothing.
    """
    from ..analysis.linearization import linearize
    from ..analysis.modal import buckling_load_factors, natural_frequencies
    from ..analysis.statics import static_equilibrium
    from ..analysis.stresses import beam_stresses
    from ..mechanics.mechanics import Mechanics
    from ..mechanics.ports import output_value
    from ..scene.building import build_model

    row = {}
    overrides, strokes = split_strokes(overrides)
    try:
        model = build_model(scene, overrides=overrides, source=source,
                            default_name=default_name)
        if strokes or any(name in analyses for name in AT_A_STROKE):
            mechanics = Mechanics(model)
            if strokes:
                solution, found, _ = stroke_point(model, strokes, stroke_inputs, mechanics)
                row.update(found)
            else:
                solution = static_equilibrium(model, mechanics=mechanics)
            if "stress" in analyses:
                stresses = beam_stresses(model, solution.x, solution.stress_resultants)
                if stresses.names:
                    row["stress.max [Pa]"] = stresses.maximum()[2]
            if "static" in analyses:
                for port, name in zip(model.outputs, columns(model, ("static",)), strict=True):
                    if port.about_axis:  # the angle's change, whatever the quantity
                        angle = replace(port, quantity="position")
                        row[name] = (output_value(model, angle, solution.x)
                                     - output_value(model, angle, model.initial_coordinates))
                        continue
                    row[name] = float(solution.x[port.coordinate]
                                      - model.initial_coordinates[port.coordinate])
            if "modes" in analyses:
                found = natural_frequencies(
                    model, modes, linear_model=linearize(model, solution, mechanics=mechanics))
                for i, frequency in enumerate(found.frequencies_hz, start=1):
                    row[f"mode.{i} [Hz]"] = float(frequency)
        if "buckling" in analyses:
            factors = buckling_load_factors(model, 1)
            if factors.size:
                row["buckling.1 [-]"] = float(factors[0])
        for name in analyses:
            if name not in ANALYSES:
                analysis = registry.find(name)
                row.update(analysis.evaluate(model, registry.option_values(
                    analysis, (settings or {}).get(name))))
    except FlexureError as error:
        # every row is of the same scene file: its name would only hide the reason
        row["status"] = _one_line(str(error).removeprefix(f"{source}: "))
    # A sweep of hours must not lose its other points to one that trips over something
    # unforeseen: the point reports the exception (its type names the kind of failure).
    except Exception as error:  # noqa: BLE001
        row["status"] = _one_line(f"{type(error).__name__}: {error}")
    else:
        row["status"] = "ok"
    return row


def _one_line(text):
    return " ".join(text.split())


def run_sweep(scene: dict, points, *, overrides=None, analyses=("static", "modes"),
              modes: int = DEFAULT_MODES, source: str = "<dict>", default_name: str = "scene",
              workers: int | None = None, scheduler: str | None = None,
              on_row=None, settings: dict | None = None,
              stroke_inputs: list | None = None) -> list[dict]:
    """Evaluate `evaluate_point` at each of `points` ({key: value}); the rows in their order.

    Parameters
    ----------
    scene : dict
        The scene dictionary (as `parse_toml` gives it); `overrides` are set at every point
        before the point's own values.
    workers : int, optional
        0: in this process, one point after the other. Otherwise the points run on a
        dask.distributed LocalCluster of this many processes, one thread each (default: one
        per core this process may use), or, with `scheduler` (an address such as
        "tcp://host:8786"), on that cluster's workers (flexure must be installed there).
    on_row : callable, optional
        Called with (index of the point, its row) as each point finishes, in the order they
        finish (to save rows as they come, and report progress).
    settings : dict, optional
        {analysis: {option: value}}: the options of registered analyses such as "simulate"
        (`flexure.core.sweep.analyses`); their defaults otherwise.
    stroke_inputs : list of str, optional
        The inputs that drive the `stroke.*` parameters (default: the scene's inputs).
    """
    tasks = [{**(overrides or {}), **point} for point in points]
    options = {"analyses": tuple(analyses), "modes": modes, "source": source,
               "default_name": default_name, "stroke_inputs": stroke_inputs,
               "settings": {name: dict(values) for name, values in (settings or {}).items()}}
    rows = [None] * len(tasks)

    def done(index, row):
        rows[index] = row
        if on_row is not None:
            on_row(index, row)

    if workers == 0 and scheduler is None:
        for index, task in enumerate(tasks):
            done(index, evaluate_point(scene, task, **options))
    else:
        _run_on_dask(scene, tasks, options, workers, scheduler, done)
    return rows


def default_workers() -> int:
    """The cores this process may run on (the LocalCluster's default process count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _connect(Client, scheduler):
    """A Client of the scheduler at `scheduler`, or a UsageError saying why there is none."""
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError, TypeError) as error:
        failure = (f"--scheduler {scheduler}: cannot connect: "
                   f"{_one_line(str(error)) or type(error).__name__}")
    # The Client that failed to start is left in a reference cycle, and its __del__ stops
    # its IO loop under distributed's one class-wide LoopRunner lock. Collected by chance
    # later, say while the next Client's start holds that lock, it deadlocks the process;
    # collected here, with the traceback that held it gone, it closes while nothing does.
    gc.collect()
    raise UsageError(failure)


def _run_on_dask(scene, tasks, options, workers, scheduler, done):
    """Run the tasks on a dask.distributed cluster, calling done(index, row) as each ends."""
    import logging

    from distributed import Client, LocalCluster, as_completed

    if scheduler is not None:
        client = _connect(Client, scheduler)
        cluster = None
    else:
        # processes, not threads: an analysis of a small model spends most of its time in
        # Python and in numba kernels that hold the GIL; one thread each, as flexure's BLAS
        # calls use one (flexure.core.numerics.blas)
        # no dashboard, and the scheduler's HTTP server (health, metrics) on a free port:
        # two sweeps at once on one machine would both ask for 8787
        cluster = LocalCluster(n_workers=workers or default_workers(), threads_per_worker=1,
                               processes=True, dashboard_address=None,
                               scheduler_kwargs={"dashboard_address": ":0"},
                               silence_logs=logging.ERROR)
        try:
            client = Client(cluster)
        except BaseException:  # its worker processes would outlive the sweep
            cluster.close()
            raise
    try:
        [shared] = client.scatter([scene], broadcast=True)  # sent once, not with every task
        futures = client.map(evaluate_point, [shared] * len(tasks), tasks, pure=False,
                             **options)
        index = {future.key: i for i, future in enumerate(futures)}
        for future in as_completed(futures):
            try:
                row = future.result()
            except Exception as error:  # noqa: BLE001 -- a lost worker; the others go on
                row = {"status": _one_line(f"dask: {type(error).__name__}: {error}")}
            done(index[future.key], row)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
