"""SUNDIALS' shared libraries, as scikit-sundae's wheel ships them (7.9), loaded with ctypes:
the functions flexure calls, each with its C prototype, loaded once per process (`libraries()`);
`core/simulation/sundials.py` drives CVODE and IDA through them. Loading checks that the serial
vector and the dense matrix are laid out as flexure's compiled callbacks read them (`native`)."""

import ctypes
import glob
import importlib.util
import os

from ..numerics.native import NVECTOR_DATA_OFFSET

_VP, _D, _INT, _LONG = ctypes.c_void_p, ctypes.c_double, ctypes.c_int, ctypes.c_long


def library_folder() -> str:
    """The folder of scikit-sundae's SUNDIALS shared libraries (ImportError when missing)."""
    # found, not imported: importing sksundae costs 0.3 s of CPU (scipy.optimize), and only
    # its wheel's shared libraries are used
    spec = importlib.util.find_spec("sksundae")
    if spec is None or spec.origin is None:
        raise ImportError("scikit-sundae is not installed: flexure needs its SUNDIALS "
                          "libraries (pip install scikit-sundae)")
    site = os.path.dirname(os.path.dirname(spec.origin))
    for folder in (os.path.join(site, "scikit_sundae.libs"), os.path.join(site, "sksundae")):
        if glob.glob(os.path.join(folder, "libsundials_cvode*")):
            return folder
    raise ImportError("scikit-sundae's SUNDIALS libraries were not found next to sksundae "
                      f"({site})")


def _load(folder, name):
    paths = sorted(glob.glob(os.path.join(folder, f"libsundials_{name}*.so*")) +
                   glob.glob(os.path.join(folder, f"libsundials_{name}*.dylib")) +
                   glob.glob(os.path.join(folder, f"sundials_{name}*.dll")))
    if not paths:
        raise ImportError(f"SUNDIALS library {name!r} not found in {folder}")
    return ctypes.CDLL(paths[0], mode=ctypes.RTLD_GLOBAL)


class _Libraries:
    """The SUNDIALS functions flexure calls, with their C prototypes."""

    def __init__(self):
        folder = library_folder()
        self.core = _load(folder, "core")
        self.nvec = _load(folder, "nvecserial")
        self.matrix = _load(folder, "sunmatrixdense")
        self.linsol = _load(folder, "sunlinsoldense")
        self.cvode = _load(folder, "cvode")
        self.ida = _load(folder, "ida")
        proto = _prototype
        proto(self.core.SUNContext_Create, _INT, [_INT, ctypes.POINTER(_VP)])
        proto(self.core.SUNContext_Free, _INT, [ctypes.POINTER(_VP)])
        proto(self.core.SUNContext_ClearErrHandlers, _INT, [_VP])
        proto(self.nvec.N_VNew_Serial, _VP, [_INT, _VP])
        proto(self.nvec.N_VGetArrayPointer, _VP, [_VP])
        proto(self.nvec.N_VDestroy, None, [_VP])
        proto(self.matrix.SUNDenseMatrix, _VP, [_INT, _INT, _VP])
        proto(self.matrix.SUNDenseMatrix_Data, _VP, [_VP])
        proto(self.matrix.SUNMatDestroy, None, [_VP])
        proto(self.linsol.SUNLinSol_Dense, _VP, [_VP, _VP, _VP])
        proto(self.linsol.SUNLinSolFree, _INT, [_VP])
        cv = self.cvode
        proto(cv.CVodeCreate, _VP, [_INT, _VP])
        proto(cv.CVodeInit, _INT, [_VP, _VP, _D, _VP])
        proto(cv.CVodeReInit, _INT, [_VP, _D, _VP])
        proto(cv.CVodeSVtolerances, _INT, [_VP, _D, _VP])
        for name in ("CVodeSetUserData", "CVodeSetJacFn"):
            proto(getattr(cv, name), _INT, [_VP, _VP])
        proto(cv.CVodeSetLinearSolver, _INT, [_VP, _VP, _VP])
        proto(cv.CVodeSetMaxNumSteps, _INT, [_VP, _LONG])
        for name in ("CVodeSetMaxStep", "CVodeSetStopTime", "CVodeSetInitStep"):
            proto(getattr(cv, name), _INT, [_VP, _D])
        for name in ("CVodeSetMaxOrd", "CVodeSetMaxNonlinIters", "CVodeSetStabLimDet"):
            proto(getattr(cv, name), _INT, [_VP, _INT])
        proto(cv.CVode, _INT, [_VP, _D, _VP, ctypes.POINTER(_D), _INT])
        for name in ("CVodeGetNumSteps", "CVodeGetNumRhsEvals", "CVodeGetNumJacEvals",
                     "CVodeGetNumErrTestFails", "CVodeGetNumNonlinSolvIters"):
            proto(getattr(cv, name), _INT, [_VP, ctypes.POINTER(_LONG)])
        for name in ("CVodeGetLastStep", "CVodeGetActualInitStep"):
            proto(getattr(cv, name), _INT, [_VP, ctypes.POINTER(_D)])
        proto(cv.CVodeGetReturnFlagName, ctypes.c_char_p, [_LONG])
        proto(cv.CVodeFree, None, [ctypes.POINTER(_VP)])
        ida = self.ida
        proto(ida.IDACreate, _VP, [_VP])
        proto(ida.IDAInit, _INT, [_VP, _VP, _D, _VP, _VP])
        proto(ida.IDAReInit, _INT, [_VP, _D, _VP, _VP])
        proto(ida.IDASVtolerances, _INT, [_VP, _D, _VP])
        for name in ("IDASetUserData", "IDASetJacFn"):
            proto(getattr(ida, name), _INT, [_VP, _VP])
        proto(ida.IDASetLinearSolver, _INT, [_VP, _VP, _VP])
        proto(ida.IDASetMaxNumSteps, _INT, [_VP, _LONG])
        for name in ("IDASetMaxStep", "IDASetStopTime"):
            proto(getattr(ida, name), _INT, [_VP, _D])
        proto(ida.IDASetMaxOrd, _INT, [_VP, _INT])
        proto(ida.IDASolve, _INT, [_VP, _D, ctypes.POINTER(_D), _VP, _VP, _INT])
        for name in ("IDAGetNumSteps", "IDAGetNumResEvals", "IDAGetNumJacEvals"):
            proto(getattr(ida, name), _INT, [_VP, ctypes.POINTER(_LONG)])
        proto(ida.IDAGetReturnFlagName, ctypes.c_char_p, [_LONG])
        proto(ida.IDAFree, None, [ctypes.POINTER(_VP)])
        self._check_layout()

    def _check_layout(self):
        """The compiled callbacks read a vector's and a dense matrix's data pointer from the
        structs directly (`native`); refuse a library whose layout differs."""
        context = _VP()
        self.core.SUNContext_Create(0, ctypes.byref(context))
        vector = self.nvec.N_VNew_Serial(3, context)
        matrix = self.matrix.SUNDenseMatrix(3, 3, context)
        try:
            content = ctypes.cast(vector, ctypes.POINTER(_VP))[0]
            data = ctypes.cast(content + NVECTOR_DATA_OFFSET, ctypes.POINTER(_VP))[0]
            m_content = ctypes.cast(matrix, ctypes.POINTER(_VP))[0]
            m_data = ctypes.cast(m_content + 8, ctypes.POINTER(_VP))[0]
            if (data != self.nvec.N_VGetArrayPointer(vector)
                    or m_data != self.matrix.SUNDenseMatrix_Data(matrix)):
                raise ImportError("this SUNDIALS build lays out its serial vectors or dense "
                                  "matrices differently from what flexure's callbacks read")
        finally:
            self.matrix.SUNMatDestroy(matrix)
            self.nvec.N_VDestroy(vector)
            self.core.SUNContext_Free(ctypes.byref(context))


def _prototype(function, restype, argtypes):
    function.restype = restype
    function.argtypes = argtypes


_LIBRARIES = None


def libraries():
    """The loaded SUNDIALS libraries (loaded once per process)."""
    global _LIBRARIES
    if _LIBRARIES is None:
        _LIBRARIES = _Libraries()
    return _LIBRARIES


def function_address(function):
    """The address (int) of a ctypes function, for compiled code that calls it."""
    return ctypes.cast(function, _VP).value
