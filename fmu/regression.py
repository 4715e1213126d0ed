"""Regression tests of FMUs in the style of the FMI cross-check: `*_in.csv` and `*_ref.csv`.

An input file holds a column "time" (s) and one column per FMU input; a repeated time is a
step (the value after it holds from that time on). A reference file holds "time" and one
column per output, sampled every communication step. `check_fmu` simulates the FMU with fmpy
over the input file's time span on the reference's grid and compares every output:

    |y - y_ref| <= rtol * (max(y_ref) - min(y_ref)) + atol        at every sample

The defaults (rtol 1e-5 of the signal's range, atol 1e-8 in its unit: 10 nm on a position)
sit above what changes of the integrator's internal steps move at its default rtol of 1e-8
(measured across the simulator's revisions: up to 1.2e-8 m, allowed 6e-8 m on the stages'
5 mm stroke) and far below any change of the
physics worth noticing (measured over the example inputs: 1 % more mass on the truss moves x
by 6e-5 m, 1 % more bending damping in the stage's leaves by 1.5e-7 m; both are caught).

    flexure fmu check stage.fmu stage_in.csv stage_ref.csv            # the test
    flexure fmu check stage.fmu stage_in.csv stage_ref.csv --update   # (re)write the reference
"""

from pathlib import Path

import numpy as np

DEFAULT_INTERVAL = 1e-3  # s, the communication step of a new reference
DEFAULT_RTOL = 1e-5  # of each signal's range
DEFAULT_ATOL = 1e-8  # in the signal's unit (10 nm on a position)


def read_csv(path):
    """A cross-check CSV as a structured array (first column "time")."""
    from fmpy.util import read_csv as fmpy_read_csv

    return fmpy_read_csv(str(path))


def simulate(fmu, input_csv, *, output_interval=DEFAULT_INTERVAL, stop_time=None,
             start_values=None):
    """Simulate `fmu` with fmpy driven by `input_csv`; returns fmpy's result array.

    The stop time defaults to the last time of the input file.
    """
    from fmpy import simulate_fmu

    signals = read_csv(input_csv)
    if stop_time is None:
        stop_time = float(signals["time"][-1])
    return simulate_fmu(str(fmu), start_time=0.0, stop_time=stop_time,
                        output_interval=output_interval, input=signals,
                        start_values=start_values or {})


def write_reference(fmu, input_csv, reference_csv, *, output_interval=DEFAULT_INTERVAL):
    """Simulate and write the reference CSV (time and every output); returns its path."""
    from fmpy.util import write_csv

    result = simulate(fmu, input_csv, output_interval=output_interval)
    write_csv(str(reference_csv), result)
    return Path(reference_csv)


def compare(result, reference, *, rtol=DEFAULT_RTOL, atol=DEFAULT_ATOL):
    """Problems (a list of strings, empty when all pass) of `result` against `reference`."""
    problems = []
    if len(result) != len(reference) or not np.allclose(result["time"], reference["time"],
                                                        rtol=0, atol=1e-9):
        return [f"time grids differ: {len(result)} samples against {len(reference)} in the "
                "reference"]
    for name in reference.dtype.names[1:]:
        if name not in result.dtype.names:
            problems.append(f"{name}: no such output in the result")
            continue
        ref = np.asarray(reference[name], dtype=float)
        allowed = rtol * (ref.max() - ref.min()) + atol
        error = np.abs(np.asarray(result[name], dtype=float) - ref)
        worst = int(np.argmax(error))
        if not np.all(error <= allowed):
            problems.append(f"{name}: max |error| {error[worst]:.3g} at t = "
                            f"{reference['time'][worst]:.6g} s exceeds {allowed:.3g}")
    return problems


def check_fmu(fmu, input_csv, reference_csv, *, rtol=DEFAULT_RTOL, atol=DEFAULT_ATOL):
    """Simulate `fmu` on the reference's grid and compare; returns the list of problems."""
    reference = read_csv(reference_csv)
    interval = float(reference["time"][1] - reference["time"][0])
    result = simulate(fmu, input_csv, output_interval=interval,
                      stop_time=float(reference["time"][-1]))
    return compare(result, reference, rtol=rtol, atol=atol)
