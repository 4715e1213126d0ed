"""Compiling before a timed run: `prepare` compiles, or loads from the on-disk cache, what a
Simulator of a model and its compiled sampled loop run, so that the first call's latency stays
out of a measurement."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from ..engine.data import EngineData
from .sampled_loop import run_sampled_loop
from .simulator import Simulator

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model


def prepare(model: Model, *, loop_method: str | None = None) -> float:
    """Compile, or load from the on-disk cache, the compiled code a Simulator of `model` runs
    (the engine, the model's element kernels, the SUNDIALS callbacks); returns the time it
    took (s). With loop_method (a METHODS name) also the integrator and the compiled sampled
    loop (`run_sampled_loop`) of that method, by running one sample of it on a throwaway
    simulator. The first use on a machine compiles (about a minute); later ones load the cache
    (well under a second). A Simulator does this itself; call it first to keep the latency
    out of a timed run.

    Parameters
    ----------
    model : Model
    loop_method : str, optional
        A METHODS name whose integrator and compiled sampled loop to prepare as well (only
        for a model with inputs and a position output).

    Returns
    -------
    float
        The time it took, s.
    """
    start = time.perf_counter()
    EngineData(model)
    if loop_method is not None and model.inputs and any(
            port.quantity == "position" for port in model.outputs):
        output = next(j for j, port in enumerate(model.outputs) if port.quantity == "position")
        zero = np.zeros((1, 1))
        # kinematic inputs held where they start: the compiled code does not depend on
        # their path
        with Simulator(model, method=loop_method,
                       stepwise_motion=bool(model.kinematic_inputs)) as sim:
            run_sampled_loop(sim, fs=1e4, samples=1, reference=zero, feedforward=zero,
                             controller=(zero, zero, zero, zero), loop_inputs=[0],
                             loop_outputs=[output])
    return time.perf_counter() - start


__all__ = ["prepare"]
