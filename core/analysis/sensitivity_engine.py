"""Which path the analyses of a design-sensitivity sweep take: the compiled engine's statics
(`static_engine`, and after them its linearisation, `linear_engine`, which follows where the
statics packed the engine) or each analysis' own default.

A sweep (`sensitivity.sensitivities`) evaluates the base model once and, per key that needs
the difference scheme, four perturbed models (p +- h, p +- h/2), each a new model: a full
static solve, linearisation, modes, the rest (`sensitivity_quantities.evaluate`). The engine
pays for itself per evaluation only where the statics iterate (a loaded model: without loads
and gravity `static_equilibrium` takes one numpy step either way) and the model is small
enough that packing it, once per perturbed model, costs less than what its steps save
(SWEEP_MAX_DOFS = 300: above it a new model's packing, 0.75 s of CPU on the 507-DOF
manipulator_reduced, is more than the numpy statics of it, 0.18 s); its start-up in a
process (numba, llvmlite, the cached entries: about 0.12 s of CPU) is paid once and must be
paid back by the evaluations:

    engine  <=>  the statics take it, NDOF <= SWEEP_MAX_DOFS and
                 evaluations x (NDOF + OVERHEAD_DOFS) >= ENGINE_MIN_WORK,

an integer rule (no timing at run time, so the choice cannot flip with the CPU; a tie takes
the engine). Where it says no, every analysis keeps its own rule (`compiled=None`): the
statics' (from 300 free coordinates) takes the engine on its own; but above SWEEP_MAX_DOFS,
where the statics' rule takes the engine for a model solved more than once, a sweep's
models are each solved once, so the sweep asks for the numpy path (`statics_path`).

Measured (docs/benchmarks.md, 2026-11-30; 2-core VM under a load of 6 to 11), CPU of one
evaluation of a loaded model in a process with the engine started, each new model packed,
engine against numpy: truss_1dof_x (1 DOF) 5.3 against 6.7 ms, a one-BEAM spatial cantilever
(6 DOFs) 7.4 against 17 ms, stage_spatial_19dof (19) 14.7 against 31 ms, cantilevers of 4
and 8 BEAMs (24, 48 DOFs) 0.43 and 0.55 of the numpy path's; unloaded models
(stage_planar_3dof, wire_tripod, stage_spatial_1dof) within 10 % either way, as neither
path iterates. Whole processes (a sweep of stage_spatial_19dof, engine over numpy,
alternating, medians): 1.12 at 5 evaluations, 1.02 at 9, 0.97 at 13, 0.92 at 21, 0.80 at
33, the break-even at about 11 (work 220 with OVERHEAD_DOFS = 1); truss_1dof_x 1.22 at 13,
its saving of 1.4 ms per evaluation paying back the start-up from about 125 (work 250).
ENGINE_MIN_WORK = 250 takes the engine at or within a few per cent of the break-even on both.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from . import static_engine

if TYPE_CHECKING:  # names for the annotations only
    from ..model import Model

# the work (module docstring) from which a sweep takes the engine, and the DOFs' worth of
# the numpy path's own cost per evaluation that does not grow with the model
ENGINE_MIN_WORK = 250
OVERHEAD_DOFS = 1
# the largest model a sweep takes the engine for (module docstring)
SWEEP_MAX_DOFS = 300
# the evaluations of a sweep: the base model, and four per key differenced
EVALUATIONS_PER_KEY = 4


def sweep_evaluations(keys: int) -> int:
    """The evaluations a sweep over `keys` keys makes at most (every key differenced; an
    analytic key makes none, but under a load, where the engine matters, few are)."""
    return 1 + EVALUATIONS_PER_KEY * int(keys)


def preferred(model: Model, evaluations: int) -> bool:
    """Whether a sweep of about `evaluations` evaluations of `model` takes the engine's
    statics (module docstring: the rule and its threshold)."""
    ndof = int(model.ndof)
    work = int(evaluations) * (ndof + OVERHEAD_DOFS)
    return (static_engine.supports(model) and ndof <= SWEEP_MAX_DOFS
            and work >= ENGINE_MIN_WORK)


def statics_path(model: Model, evaluations: int, compiled: bool | None) -> bool | None:
    """The `compiled` to give each evaluation's statics: True where asked or where the rule
    prefers the engine, False where asked or where the model is above SWEEP_MAX_DOFS (each
    perturbed model packed for one solve: module docstring), else None (the statics' own
    rule)."""
    if compiled is not None:
        return bool(compiled)
    if preferred(model, evaluations):
        return True
    return False if model.ndof > SWEEP_MAX_DOFS else None


__all__ = ["ENGINE_MIN_WORK", "EVALUATIONS_PER_KEY", "OVERHEAD_DOFS", "SWEEP_MAX_DOFS",
           "preferred",
           "statics_path", "sweep_evaluations"]
