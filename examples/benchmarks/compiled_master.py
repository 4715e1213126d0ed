"""A compiled co-simulation master: a numba loop calling an FMU's fmi2SetReal, fmi2DoStep and
fmi2GetReal, so that the FMU's overhead is measured without a Python master's own.

A master written in Python pays for its own interpreter at every call: a loop over fmpy's
ctypes handles (one setReal, doStep and getReal per step) spends about 3 us per step in
ctypes' argument conversion, as much as pythonfmu's binary itself (measured on
stage_planar_3dof: 10.4 % beyond the engine through that loop, 7.0 % through this one). A
compiled master (libcosim, a C++ or Modelica tool) does not, and this one does not either:
numba compiles the calls through ctypes prototypes into plain C calls, the pointers (the
component, the addresses of numpy arrays) passed as integers to void* parameters.
"""

from ctypes import CFUNCTYPE, c_double, c_int, c_size_t, c_void_p, cast

import numba
import numpy as np

# fmi2Status f(fmi2Component, const fmi2ValueReference[], size_t, fmi2Real[])
_VALUES = CFUNCTYPE(c_int, c_void_p, c_void_p, c_size_t, c_void_p)
# fmi2Status fmi2DoStep(fmi2Component, fmi2Real t, fmi2Real h, fmi2Boolean)
_DO_STEP = CFUNCTYPE(c_int, c_void_p, c_double, c_double, c_int)
FMI2_DISCARD = 2  # fmi2OK 0 and fmi2Warning 1 let the master go on
CALLS = ("fmi2SetReal", "fmi2DoStep", "fmi2GetReal")

_loops = {}  # compiled loops by the addresses of the three functions


def _loop(set_real, do_step, get_real):
    """The compiled stepping loop over these three C functions (ctypes prototypes)."""

    @numba.njit(cache=False)
    def loop(component, vr_in, values, vr_out, y, steps, h):
        """-1, or k * 32 + call * 8 + status for the first call of step k (0 setReal,
        1 doStep, 2 getReal) that answered fmi2Discard or worse."""
        for k in range(steps):
            status = set_real(component, vr_in, 1, values)
            if status >= FMI2_DISCARD:
                return k * 32 + status
            status = do_step(component, k * h, h, 1)
            if status >= FMI2_DISCARD:
                return k * 32 + 8 + status
            status = get_real(component, vr_out, 1, y)
            if status >= FMI2_DISCARD:
                return k * 32 + 16 + status
        return -1

    return loop


def compiled_steps(fmu, vr_in, vr_out, force, h):
    """A function `steps -> x` that steps an instantiated, initialised fmpy FMU2Slave `steps`
    times by h (s) from compiled code, setting the input `vr_in` to `force` and reading the
    output `vr_out` at every step, and returns the last output. Compiled here, not in the
    call; the call raises RuntimeError at the first FMI call that answers fmi2Discard or
    worse, naming it. It holds the component's address: call it before fmi2FreeInstance."""
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
            step, call, status = failed // 32, failed % 32 // 8, failed % 8
            raise RuntimeError(f"the FMU answered {CALLS[call]} with status {status} at step "
                               f"{step}")
        return float(arrays[3][0])

    return steps
