"""The third plant: the controller FMU and the scene FMU connected in libcosim (libcosimpy).

    scene FMU  --- x (m) --->  controller FMU        one such pair per loop, connected by
               <-- F (N) ----                        name (the manipulator: F1..F6, x1..x6)

libcosim's fixed-step algorithm steps both FMUs over each macro step [t_k, t_k+1] (h = 1 / fs,
an integer number of nanoseconds) after transferring the connected values: the controller
reads y_k, the plant gets the force the controller computed during the previous step. That is
the loop timing of loop_controller.py (one sample of computation delay), so the co-simulation
reproduces the in-process loop. The samples are read back with time-series observers: after
macro step k+1 the plant's output is y_k+1 and its input the force it held on [t_k, t_k+1).
"""

import hashlib
import tempfile
from pathlib import Path

import numpy as np

from flexure.core import SceneError, SimulationError, scene_path
from flexure.core.simulation.methods import LOOP_METHOD, LOOP_RTOL
from flexure.fmu import build_scene_fmu, bundle_name

from .controller_fmu import build_controller_fmu

NS = 1_000_000_000


def _scene_source(scene, model):
    if isinstance(scene, (str, Path)):
        return scene
    return model.source


def scene_fmu_path(scene, model, workdir, *, overrides=None):
    """Where `scene_fmu` keeps the scene's FMU: workdir / <digest> / <model name>.fmu, the
    digest of what the FMU is built from (the scene file's text, the overrides and the
    sources of the flexure it bundles), so that a kept workdir never hands a run the FMU of an
    edited scene, of other values or of another flexure (the FMU keeps the scene's name: its
    model identifier)."""
    source = _scene_source(scene, model)
    digest = hashlib.sha256()
    try:
        digest.update(scene_path(source).read_bytes())
    except (SceneError, OSError):  # not a file: the builder names what is wrong
        digest.update(str(source).encode())
    digest.update(repr(sorted((overrides or {}).items())).encode())
    digest.update(bundle_name().encode())
    return Path(workdir) / f"fmu_{digest.hexdigest()[:12]}" / f"{model.name}.fmu"


def scene_fmu(scene, model, workdir=None, *, overrides=None):
    """The scene's FMU in `workdir` (a new temporary folder if None), of the scene with
    `overrides` ({dotted scene key: value}) if given: built once, reused while the scene's
    file, the overrides and flexure's sources are those it was built from (`scene_fmu_path`)."""
    folder = Path(workdir) if workdir is not None else Path(
        tempfile.mkdtemp(prefix="flexure_loop_"))
    path = scene_fmu_path(scene, model, folder, overrides=overrides)
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        # run here, where this flexure stands in for the FMU's copy: no portable engine
        build_scene_fmu(_scene_source(scene, model), path, overrides=overrides, engine=False)
    return path


def step_nanoseconds(fs):
    """The macro step 1 / fs in integer nanoseconds; SimulationError if not exact."""
    step = int(round(NS / fs))
    if abs(step * fs - NS) > 1e-6 * NS:
        raise SimulationError(f"libcosim counts time in nanoseconds: 1 / fs = {1 / fs!r} s "
                              "is not a whole number of nanoseconds; choose fs dividing 1e9")
    return step


def run_cosimulation(model, scene, controller, design, *, method=LOOP_METHOD,
                     rtol=LOOP_RTOL,
                     workdir=None, progress=None, overrides=None):
    """Run the loop in libcosim; returns t, reference, position, force like simulate_loop.

    `progress`, if given, is called with the fraction done: the run is then advanced in
    (about 100) chunks of whole macro steps, which libcosim continues seamlessly.
    `overrides` ({dotted scene key: value}) are the scene's, for its FMU (`scene_fmu`).
    """
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    folder = Path(workdir) if workdir is not None else Path(
        tempfile.mkdtemp(prefix="flexure_loop_"))
    plant_path = scene_fmu(scene, model, folder, overrides=overrides)
    controller_path = build_controller_fmu(controller, design, model,
                                           folder / "flexure_controller.fmu")
    N, fs = controller.samples, controller.fs
    step = step_nanoseconds(fs)
    ex = CosimExecution.from_step_size(step_size=step)
    plant = ex.add_local_slave(CosimLocalSlave(fmu_path=str(plant_path), instance_name="plant"))
    ctrl = ex.add_local_slave(CosimLocalSlave(fmu_path=str(controller_path),
                                              instance_name="controller"))
    vr = _references(ex, {plant: plant_path, ctrl: controller_path},
                     {plant: ["integrator.rtol", "integrator.method"]
                      + [name for p in design.pairs for name in (p.input_name, p.output_name)],
                      ctrl: [name for p in design.pairs
                             for name in (p.input_name, p.output_name)]})
    if not ex.real_initial_value(plant, vr[(plant, "integrator.rtol")], float(rtol)):
        raise SimulationError("libcosim: cannot set the plant's integrator.rtol")
    if not ex.string_initial_value(plant, vr[(plant, "integrator.method")], method):
        raise SimulationError("libcosim: cannot set the plant's integrator.method")
    # each loop's ports connected by name: the plant's output (e.g. "x3") to the controller's
    # input of that name, the controller's output (e.g. "F3") to the plant's input
    for pair in design.pairs:
        out, inp = pair.output_name, pair.input_name
        if ex.connect_real_variables(plant, vr[(plant, out)], ctrl, vr[(ctrl, out)]) != 0 or \
                ex.connect_real_variables(ctrl, vr[(ctrl, inp)], plant, vr[(plant, inp)]) != 0:
            raise SimulationError(f"libcosim: cannot connect loop {inp} -> {out}")
    series = CosimObserver.create_time_series()
    ex.add_observer(observer=series)
    watched = [(plant, p.output_name) for p in design.pairs] + [
        (plant, p.input_name) for p in design.pairs]
    for slave, name in watched:
        series.start_time_series(slave, vr[(slave, name)], CosimVariableType.REAL)
    chunk = N if progress is None else max(1, N // 100)
    for done in range(chunk, N + chunk, chunk):
        if not ex.simulate_until(target_time=min(done, N) * step):
            # libcosim's own reason, which libcosimpy 0.0.6 offers from its _internal only
            from libcosimpy._internal import get_last_error_message

            raise SimulationError(f"libcosim stopped at t = "
                                  f"{ex.status().current_time / NS:.9g} s: "
                                  f"{get_last_error_message()}")
        if progress is not None:
            progress(min(done, N) / N)
    n = len(design.pairs)
    position = np.empty((N + 1, n))
    force = np.empty((N + 1, n))
    for i, pair in enumerate(design.pairs):
        position[0, i] = controller.offsets[i]
        _, steps, y = series.time_series_real_samples(
            plant, vr[(plant, pair.output_name)], from_step=1, sample_count=N)
        _, _, u = series.time_series_real_samples(
            plant, vr[(plant, pair.input_name)], from_step=1, sample_count=N)
        if len(y) != N or len(u) != N:
            raise SimulationError(f"libcosim: expected {N} samples, got {len(y)}")
        position[1:, i] = y
        force[:N, i] = u
        force[N, i] = u[-1]
    t = np.arange(N + 1) / fs
    return t, controller.reference[: N + 1].copy(), position, force


def _references(ex, paths, wanted):
    """{(slave, name): value reference} of the slaves' variables; SimulationError naming the
    FMU (`paths[slave]`) and the variable when one of `wanted[slave]` is missing."""
    vr = {(slave, v.name.decode()): v.reference
          for slave in paths for v in ex.slave_variables(slave)}
    for slave, names in wanted.items():
        for name in names:
            if (slave, name) not in vr:
                raise SimulationError(f"{paths[slave]}: the FMU has no variable {name!r} "
                                      f"(a loop connects it by name)")
    return vr
