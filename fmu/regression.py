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

import zipfile
from pathlib import Path

import numpy as np

from flexure.core.cli import atomic_output
from flexure.core.errors import FlexureError

DEFAULT_INTERVAL = 1e-3  # s, the communication step of a new reference
DEFAULT_RTOL = 1e-5  # of each signal's range
DEFAULT_ATOL = 1e-8  # in the signal's unit (10 nm on a position)


class FMUCheckError(FlexureError, ValueError):
    """An FMU or a cross-check CSV that cannot be used, or a simulation that failed."""


def read_csv(path, *, min_rows=1, steps_allowed=True):
    """A cross-check CSV as a structured array (first column "time"), validated.

    Raises FMUCheckError naming the file, the row or the column when it is not a header
    line "time,NAME,..." over at least `min_rows` rows of finite numbers with times that never
    decrease (or, without `steps_allowed`, strictly increase).
    """
    from fmpy.util import read_csv as fmpy_read_csv

    expected = 'a header line "time,NAME,..." and rows of numbers'
    try:
        signals = fmpy_read_csv(str(path))
    except OSError as error:
        raise FMUCheckError(f"{path}: cannot read: {error.strerror}") from None
    except UnicodeDecodeError as error:
        raise FMUCheckError(f"{path}: not UTF-8 text ({error.reason} at byte {error.start}); "
                            f"expected {expected}") from None
    except IndexError:  # fmpy reads the header line and the first row unchecked
        raise FMUCheckError(f"{path}: expected {expected}; the file has no rows of samples"
                            ) from None
    except (ValueError, TypeError) as error:
        raise FMUCheckError(f"{path}: expected {expected}: {error or type(error).__name__}"
                            ) from None
    names = signals.dtype.names or ()
    if not names or names[0] != "time":
        raise FMUCheckError(f"{path}: expected the first column \"time\", got "
                            f"{names[0] if names else 'no columns'!r}")
    signals = np.atleast_1d(signals)
    if len(signals) < min_rows:
        raise FMUCheckError(f"{path}: expected at least {min_rows} rows of samples, got "
                            f"{len(signals)}")
    for name in names:
        if signals.dtype[name].shape:
            raise FMUCheckError(f"{path}: column {name!r}: expected one number per cell")
        bad = np.flatnonzero(~np.isfinite(signals[name]))
        if bad.size:
            raise FMUCheckError(f"{path}: column {name!r}, row {bad[0] + 2}: expected a finite "
                                f"number, got {signals[name][bad[0]]}")
    times = signals["time"]
    back = np.flatnonzero(np.diff(times) < 0 if steps_allowed else np.diff(times) <= 0)
    if back.size:
        raise FMUCheckError(f"{path}: row {back[0] + 3}: time {times[back[0] + 1]:g} s after "
                            f"{times[back[0]]:g} s; expected times that "
                            f"{'never decrease' if steps_allowed else 'increase'}")
    if times[0] < 0:
        raise FMUCheckError(f"{path}: expected times from 0 s, got {times[0]:g} s")
    return signals


def model_description(fmu):
    """fmpy's model description of `fmu`; FMUCheckError if it is not a readable FMU."""
    from fmpy import read_model_description

    if not zipfile.is_zipfile(fmu):
        raise FMUCheckError(f"{fmu}: not an FMU (not a zip archive)")
    try:
        return read_model_description(str(fmu))
    except Exception as error:  # fmpy raises plain Exceptions, KeyError, XML errors, ...
        raise FMUCheckError(f"{fmu}: not a valid FMU: {type(error).__name__}: {error}"
                            ) from None


def check_inputs(fmu, input_csv, signals):
    """FMUCheckError unless every column of the input file is an input of the FMU."""
    description = model_description(fmu)
    inputs = [v.name for v in description.modelVariables if v.causality == "input"]
    for name in signals.dtype.names[1:]:
        if name not in inputs:
            raise FMUCheckError(f"{input_csv}: column {name!r} is not an input of {fmu} "
                                f"(its inputs: {', '.join(inputs) or 'none'})")


def simulate(fmu, input_csv, *, output_interval=DEFAULT_INTERVAL, stop_time=None,
             start_values=None):
    """Simulate `fmu` with fmpy driven by `input_csv`; returns fmpy's result array.

    The stop time defaults to the last time of the input file.
    """
    from fmpy import simulate_fmu

    signals = read_csv(input_csv)
    check_inputs(fmu, input_csv, signals)
    if stop_time is None:
        stop_time = float(signals["time"][-1])
    if not stop_time > 0:
        raise FMUCheckError(f"{input_csv}: the samples span no time (last time {stop_time:g} "
                            "s); expected a last time > 0")
    try:
        return simulate_fmu(str(fmu), start_time=0.0, stop_time=stop_time,
                            output_interval=output_interval, input=signals,
                            start_values=start_values or {})
    except Exception as error:  # fmpy reports a failed FMI call as a plain Exception
        raise FMUCheckError(f"{fmu}: the simulation failed: {type(error).__name__}: "
                            f"{error}") from None


def write_reference(fmu: str | Path, input_csv: str | Path, reference_csv: str | Path, *,
                    output_interval: float = DEFAULT_INTERVAL) -> Path:
    """Simulate the FMU on an input file and write the reference CSV (time and every output).

    Parameters
    ----------
    fmu : str or Path
        The .fmu file.
    input_csv : str or Path
        "time" (s) and one column per FMU input, in its unit (module docstring).
    reference_csv : str or Path
        The file to write, atomically (a failed write leaves the old one as it was).
    output_interval : float
        The communication step, s.

    Returns
    -------
    Path
        `reference_csv`.

    Raises
    ------
    FMUCheckError
        Not an FMU, an input file that cannot be read or names no input of the FMU, or a
        failed simulation.
    """
    from fmpy.util import write_csv

    result = simulate(fmu, input_csv, output_interval=output_interval)
    # atomically: an interrupted or failed write leaves the previous reference as it was
    with atomic_output(reference_csv) as temporary:
        write_csv(temporary, result)
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


def check_fmu(fmu: str | Path, input_csv: str | Path, reference_csv: str | Path, *,
              rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL) -> list[str]:
    """Simulate `fmu` on the reference's grid and compare every output with it:
    |y - y_ref| <= rtol (max(y_ref) - min(y_ref)) + atol at every sample.

    Parameters
    ----------
    fmu : str or Path
        The .fmu file.
    input_csv : str or Path
        "time" (s) and one column per FMU input, in its unit.
    reference_csv : str or Path
        "time" (s, evenly spaced: the communication step) and one column per output.
    rtol : float
        Relative to each signal's range (unitless).
    atol : float
        In each signal's unit (1e-8: 10 nm on a position).

    Returns
    -------
    list of str
        The problems (an output missing, or where and by how much it misses); empty when
        all pass.

    Raises
    ------
    FMUCheckError
        Not an FMU, a CSV file that cannot be read or does not fit, or a failed simulation.
    """
    model_description(fmu)  # not an FMU: say so before reading the CSV files
    reference = read_csv(reference_csv, min_rows=2, steps_allowed=False)
    interval = float(reference["time"][1] - reference["time"][0])
    result = simulate(fmu, input_csv, output_interval=interval,
                      stop_time=float(reference["time"][-1]))
    return compare(result, reference, rtol=rtol, atol=atol)
