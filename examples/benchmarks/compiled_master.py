"""A compiled co-simulation master: a numba loop calling an FMU's fmi2SetReal, fmi2DoStep and
fmi2GetReal, so that the FMU's overhead is measured without a Python master's own.

A master written in Python pays for its own interpreter at every call: a loop over fmpy's
ctypes handles (one setReal, doStep and getReal per step) spends about 3 us per step in
ctypes' argument conversion, as much as pythonfmu's binary itself (measured 2026-11-24 on
stage_planar_3dof: 11.2 % beyond the engine through that loop, 7.6 % through this one). A
compiled master (libcosim, a C++ or Modelica tool) does not, and this one does not either:
numba compiles the calls through ctypes prototypes into plain C calls.

Pointers are passed as 64-bit integers (the addresses of numpy arrays, the component), which
the C calling conventions of x86-64 and AArch64 pass exactly as pointers.
"""

from ctypes import CFUNCTYPE, c_double, c_int, c_uint64, c_void_p, cast

import numba
import numpy as np

# fmi2Status f(fmi2Component, const fmi2ValueReference[], size_t, fmi2Real[])
_VALUES = CFUNCTYPE(c_int, c_uint64, c_uint64, c_uint64, c_uint64)
# fmi2Status fmi2DoStep(fmi2Component, fmi2Real t, fmi2Real h, fmi2Boolean)
_DO_STEP = CFUNCTYPE(c_int, c_uint64, c_double, c_double, c_int)

_loops = {}  # compiled loops by the addresses of the three functions


def _loop(set_real, do_step, get_real):
    """The compiled stepping loop over these three C functions (ctypes prototypes)."""

    @numba.njit(cache=False)
    def loop(component, vr_in, values, vr_out, y, steps, h):
        for k in range(steps):
            if set_real(component, vr_in, 1, values) or do_step(component, k * h, h, 1) \
                    or get_real(component, vr_out, 1, y):
                return k
        return -1

    return loop


def compiled_steps(fmu, vr_in, vr_out, force, h):
    """A function `steps -> x` that steps an instantiated, initialised fmpy FMU2Slave `steps`
    times by h (s) from compiled code, setting the input `vr_in` to `force` and reading the
    output `vr_out` at every step, and returns the last output. Compiled here, not in the
    call; the call raises RuntimeError at the first FMI call that answers an error."""
    addresses = tuple(cast(getattr(fmu.dll, name), c_void_p).value
                      for name in ("fmi2SetReal", "fmi2DoStep", "fmi2GetReal"))
    loop = _loops.get(addresses)
    if loop is None:
        loop = _loops[addresses] = _loop(_VALUES(addresses[0]), _DO_STEP(addresses[1]),
                                         _VALUES(addresses[2]))
        loop(0, 0, 0, 0, 0, 0, h)  # compile now, with no step to make
    arrays = (np.array([vr_in], dtype=np.uint32), np.array([force], dtype=float),
              np.array([vr_out], dtype=np.uint32), np.zeros(1))
    component = cast(fmu.component, c_void_p).value
    pointers = tuple(a.ctypes.data for a in arrays)

    def steps(count):
        failed = loop(component, *pointers, count, h)
        if failed >= 0:
            raise RuntimeError(f"the FMU answered an error status at step {failed}")
        return float(arrays[3][0])

    return steps
