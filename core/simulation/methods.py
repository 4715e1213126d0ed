"""The integration methods, in one list: name -> stepper class and its properties.

No numerical imports here: the command line registers its options from this list without
loading numba or SUNDIALS; `Method.stepper_class()` imports the stepper's module on first use.

Every other list of method names is read from `REGISTRY`: the command line's `--method`
choices (`flexure.core.cli.simulate`, `flexure.controllers.cli`), `Simulator`
(`flexure.core.simulation.simulator`), the compiled sampled loop
(`flexure.core.simulation.sampled_loop`, the methods with `compiled_loop`), the scene FMU's
"integrator.method" (`flexure.fmu.scene_slave`) and the work-precision study. A test
(`tests/test_integrator_contract.py`) fails when a method is added anywhere else only, and runs
the same contract over every method registered here. Adding a method: docs/extending.md.

SUNDIALS_METHODS run SUNDIALS' multistep integrators (`flexure.core.simulation.sundials`) and
take a largest order; ONE_STEP_METHODS are the compiled one-step ESDIRKs
(`flexure.core.simulation.esdirk`), which take a held input's change without a restart.

Every method integrates kinematic inputs (prescribed motion): the engine's operations run
their prescribed forms on a model that has them (`flexure.core.engine.prescribed` for the
first-order form, `prescribed_residual` for IDA's implicit one), so a method's operations
decide nothing there; the contract's kinematic-input tests run over every method.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass


@dataclass(frozen=True)
class Method:
    """One integration method and what the code around it needs to know of it.

    Attributes
    ----------
    name : str
        The name users give ("cvode-bdf").
    module, stepper : str
        The module under `flexure.core.simulation` and the `Stepper` class in it that runs
        the method (`stepper.Stepper`).
    variant : str
        What that class takes to run this method rather than its siblings (CVODE's "BDF" or
        "Adams", an ESDIRK tableau's name in `esdirk_method.TABLEAUS`).
    order : int
        The (largest) order of the method.
    variable_order : bool
        Whether the order varies during the run (the multistep methods, up to `order`;
        `max_order` lowers it).
    implicit : bool
        Whether the stages or steps are solved by Newton with the model's Jacobian.
    stiff : bool
        Whether it is meant for stiff problems (A- or L-stable at its low orders).
    one_step : bool
        Whether it takes a held input's change without a restart (keeping its step size,
        Newton matrix and the kinematics' warm start): a one-step method.
    operations : tuple of str
        The engine operations its stepper calls (`flexure.core.engine.engine` OP_ names,
        connected by `engine.connect`).
    compiled_loop : bool
        Whether the compiled sampled loop (`run_sampled_loop`) drives it.
    options : tuple of str
        The `Simulator` options it takes besides rtol, atol and max_step: "max_order",
        "finite-difference" (jacobian="finite-difference"), "input_functions".
    summary : str
        One line for the documentation and the command line.
    """

    name: str
    module: str
    stepper: str
    variant: str
    order: int
    variable_order: bool
    implicit: bool
    stiff: bool
    one_step: bool
    operations: tuple[str, ...]
    compiled_loop: bool
    options: tuple[str, ...]
    summary: str

    def stepper_class(self) -> type:
        """The `Stepper` class that runs the method (its module imported on first use)."""
        module = importlib.import_module(f"{__package__}.{self.module}")
        return getattr(module, self.stepper)

    def takes(self, option: str) -> bool:
        """Whether `Simulator` may pass it `option` ("max_order", "finite-difference",
        "input_functions")."""
        return option in self.options


_SUNDIALS_OPTIONS = ("max_order", "finite-difference", "input_functions")
_ESDIRK_OPERATIONS = ("OP_RHS", "OP_JACOBIAN", "OP_INPUT_RESPONSE")

# In this order: `METHODS` (and so the command line's choices) lists them so.
METHOD_TABLE = (
    Method("cvode-bdf", "sundials", "Cvode", "BDF", order=5, variable_order=True,
           implicit=True, stiff=True, one_step=False, operations=("OP_RHS", "OP_JACOBIAN"),
           compiled_loop=True, options=_SUNDIALS_OPTIONS,
           summary="CVODE's BDF, orders 1 to 5 (stiff; restarts at a changed input)"),
    Method("cvode-adams", "sundials", "Cvode", "Adams", order=12, variable_order=True,
           implicit=True, stiff=False, one_step=False, operations=("OP_RHS", "OP_JACOBIAN"),
           compiled_loop=True, options=_SUNDIALS_OPTIONS,
           summary="CVODE's Adams-Moulton, orders 1 to 12 (non-stiff)"),
    Method("ida", "sundials", "Ida", "IDA", order=5, variable_order=True, implicit=True,
           stiff=True, one_step=False, operations=("OP_RESIDUAL", "OP_RESIDUAL_JACOBIAN"),
           compiled_loop=False, options=_SUNDIALS_OPTIONS,
           summary="IDA's BDF on the implicit form, orders 1 to 5"),
    Method("esdirk", "esdirk", "Esdirk", "esdirk", order=4, variable_order=False,
           implicit=True, stiff=True, one_step=True, operations=_ESDIRK_OPERATIONS,
           compiled_loop=True, options=(),
           summary="ESDIRK4(3)6L[2]SA, order 4, 6 stages, L-stable (one-step)"),
    Method("esdirk3", "esdirk", "Esdirk", "esdirk3", order=3, variable_order=False,
           implicit=True, stiff=True, one_step=True, operations=_ESDIRK_OPERATIONS,
           compiled_loop=True, options=(),
           summary="ESDIRK3(2)4L[2]SA, order 3, 4 stages, L-stable (one-step)"),
    Method("esdirk2", "esdirk", "Esdirk", "esdirk2", order=2, variable_order=False,
           implicit=True, stiff=True, one_step=True, operations=_ESDIRK_OPERATIONS,
           compiled_loop=True, options=(),
           summary="TR-BDF2, order 2, 3 stages, L-stable (one-step; the loop's default)"),
    Method("sdirk2", "esdirk", "Esdirk", "sdirk2", order=2, variable_order=False,
           implicit=True, stiff=True, one_step=True, operations=_ESDIRK_OPERATIONS,
           compiled_loop=True, options=(),
           summary="Alexander's SDIRK, order 2, 2 implicit stages, L-stable (one-step; an "
                   "input change costs no input response)"),
)
REGISTRY = {method.name: method for method in METHOD_TABLE}

METHODS = tuple(REGISTRY)
SUNDIALS_METHODS = tuple(m.name for m in METHOD_TABLE if m.module == "sundials")
ONE_STEP_METHODS = tuple(m.name for m in METHOD_TABLE if m.one_step)
COMPILED_LOOP_METHODS = tuple(m.name for m in METHOD_TABLE if m.compiled_loop)

# The plant integrator of a sampled loop, and its relative tolerance, unless chosen. A changed
# force at every sample costs a one-step method one evaluation, and the sample period, not the
# order, bounds its step; TR-BDF2 has two implicit stages where esdirk3 has three. Measured
# at 4 kHz (1 mm in 1 s + 0.25 s; docs/decisions.md), against the loop on esdirk3 at 1e-11:
# esdirk2 at rtol 1e-5 takes one step per sample on stage_planar_1dof, stage_planar_3dof and
# stage_spatial_19dof, and their measured positions stay within 1.3e-9, 6.0e-9 and 1.3e-9 of the
# stroke (the loop's target is 1e-3, `flexure loop`'s 1e-7); esdirk3 at rtol 1e-6 stays within
# 6e-11, 1.8e-8 and 5e-10 in 1.2, 1.3 and 1.5 times the time. Tighter tolerances subdivide the
# samples for no visible gain (esdirk2 at 1e-6: two steps per sample on the spatial stage).
LOOP_METHOD = "esdirk2"
LOOP_RTOL = 1e-5


def method(name: str) -> Method:
    """The registered method called `name`.

    Raises
    ------
    KeyError
        No such method (the message lists the registered ones).
    """
    try:
        return REGISTRY[name]
    except (KeyError, TypeError):
        raise KeyError(f"unknown method {name!r}; expected one of {', '.join(METHODS)}") \
            from None


__all__ = ["COMPILED_LOOP_METHODS", "LOOP_METHOD", "LOOP_RTOL", "METHODS", "METHOD_TABLE",
           "ONE_STEP_METHODS", "REGISTRY", "SUNDIALS_METHODS", "Method", "method"]
