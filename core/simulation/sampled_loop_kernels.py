"""The compiled side of the sampled loop (`sampled_loop`): the measurement of the loop
outputs, one sample (its controller's side in `sampled_control`), and the loops over samples
on CVODE and on the one-step ESDIRK, each with a C entry through which Python runs it
(`loop_runner`: a process that loads the compiled code from the cache runs the loop without
numba).
"""

from ..engine import access
from ..engine import data as ed
from ..numerics.array_tables import array_table, floats, floats2d, ints
from ..numerics.jit import entry, kernel
from ..numerics.native import (
    as_float_pointer,
    as_int_pointer,
    call_engine,
    call_get_real,
    call_solve,
    call_stepper,
    call_with_time,
    carray,
)
from . import esdirk_kernels, esdirk_layout
from .sampled_control import CONTROLLER_KINDS, control_sample, controller_table
from .sampled_measure import ADVANCE, COORDINATES, MEASURE, N_COORDINATES, PLANT
from .stepper import restart_plant
from .sundials_restart import (
    A_ACTUAL_INIT_STEP,
    A_ANALYTIC,
    A_MEMORY,
    A_SOLVE,
    A_STOP,
    A_TRET,
    A_Y,
    L_INITIAL_STEP,
    L_JACOBIAN,
    cvode_restart,
)

# the addresses handed to the compiled loop are in `sampled_measure`'s order (ADDRESSES;
# CVODE's own are in its `address_table`, sundials_restart.A_...)
MEASURE_FAILED = -1000
# a failed measurement of y_N after the last sample: END_MEASURE - its status (data.OK ..)
END_MEASURE = -2000


@kernel(inline="always")  # into measure, its one caller
def _all_dofs(dofs):
    """Whether every output is a coordinate DOF (no index -1); a loop, where np.all(dofs >=
    0) would allocate a temporary array every sample."""
    for j in range(dofs.size):
        if dofs[j] < 0:
            return False
    return True


@kernel
def measure(addresses, y, scratch, coordinates, out):
    """The loop outputs (positions, m; angles, rad) at the integrator state y into out; a
    status. As `Simulator.outputs`: q_ref + y at the DOFs when every output is a coordinate
    DOF, else Newton from the plant's last coordinates moved to y (`measuring`), in the
    entry at addresses[MEASURE] (`sampled_measure`: compiled only for a loop that has such an
    output; NOT_CONNECTED where none was given). coordinates: the outputs' packed rows
    (`engine.ports.port_specs`, flat), then the DOF of each output or -1
    (`mechanics.ports.output_dofs`)."""
    q_ref = access.reference_dofs(addresses[PLANT])
    dofs = coordinates[coordinates.size - out.size:]
    if _all_dofs(dofs):
        for j in range(out.size):
            out[j] = q_ref[dofs[j]] + y[dofs[j]]
        return ed.OK
    if addresses[MEASURE] == 0:
        return ed.NOT_CONNECTED
    addresses[COORDINATES], addresses[N_COORDINATES] = coordinates.ctypes.data, coordinates.size
    # the addresses array as the table of "operations", MEASURE as the operation's index
    return call_engine(addresses.ctypes.data, MEASURE, addresses.ctypes.data, 0.0,
                       y.ctypes.data, scratch.ctypes.data, out.ctypes.data, float(out.size))


@kernel(inline="always")  # into the loop of the integrator in use, its one caller
def _sample(addresses, y, scratch, k, controller, held):
    """Sample k: measure y_k, then the controller's sample (`sampled_control.control_sample`:
    u_k+1 computed, u_k into the held plant inputs for [t_k, t_k+1)).
    Returns 1 when the held inputs changed, 0 when not, -1 when y_k could not be measured.
    controller: (reference, feedforward, A, B, C, D, state, inputs, coordinates, quanta,
    position, force, error, output, new_state) as `run_sampled_loop` packs it."""
    coordinates, position = controller[8], controller[10]
    if measure(addresses, y, scratch, coordinates, position[k]) != ed.OK:
        return -1
    return control_sample(k, controller, held)


@kernel(inline="always")  # into its C entry, its one caller: one compilation unit
def loop_cvode(addresses, cvode, loop_state, learnt, totals, held, y, scratch, start, stop, fs,
          controller):
    """Samples start .. stop - 1 of the loop on CVODE (`cvode`: its `address_table`; learnt
    and totals: its arrays); 0, or CVODE's failure flag (or MEASURE_FAILED) with
    loop_state[0] the time reached. Each change of the held force restarts it as
    `Simulator._restart` does, through the same kernels."""
    plant = addresses[PLANT]
    x_plant = access.coordinates(plant)
    memory = cvode[A_MEMORY]
    tret = carray(as_float_pointer(cvode[A_TRET]), (1,))
    t = loop_state[0]
    restart = loop_state[1] != 0.0
    for k in range(start, stop):
        changed = _sample(addresses, y, scratch, k, controller, held)
        if changed < 0:
            loop_state[0] = t
            return MEASURE_FAILED
        if changed or restart:  # as Simulator.set_inputs and its restart in advance
            restart_plant(plant, held, x_plant, True)
            flag = cvode_restart(cvode, learnt, totals, t)
            if flag < 0:
                loop_state[0] = t
                return flag
            restart = False
        t_next = (k + 1) / fs
        call_with_time(cvode[A_STOP], memory, t_next)
        flag = call_solve(cvode[A_SOLVE], memory, t_next, cvode[A_Y],
                          cvode[A_TRET], 1)
        if flag < 0:
            loop_state[0] = tret[0]
            loop_state[1] = 1.0
            return flag
        if learnt[L_INITIAL_STEP] == 0.0:  # as sundials.Cvode.learn_initial_step
            call_get_real(cvode[A_ACTUAL_INIT_STEP], memory, learnt.ctypes.data)
        learnt[L_JACOBIAN] = 1.0 if cvode[A_ANALYTIC] != 0 else 0.0
        t = t_next
    loop_state[0] = t
    loop_state[1] = 1.0 if restart else 0.0
    return 0


@kernel(inline="always")  # into its C entry, its one caller: one compilation unit
def loop_esdirk(addresses, loop_state, held, memory, flags, vectors, arguments, scratch,
                 start, stop, fs, controller):
    """Samples start .. stop - 1 of the loop on the one-step integrator; 0, or its failure
    status (or MEASURE_FAILED) with loop_state[0] the time reached. Each change of the held
    force does what `Simulator.set_inputs` and the restart in `advance` do with it: the new
    inputs, the integrator's state re-entered (its first stage recomputed). The integrator
    steps through its C entry (`esdirk_entry`: at addresses[ADVANCE], with the stepper's
    `arguments`), not a linked copy of `esdirk_kernels.advance`."""
    plant = addresses[PLANT]
    x_plant = access.coordinates(plant)
    y = vectors[esdirk_layout.V_Y]
    t = loop_state[0]
    for k in range(start, stop):
        changed = _sample(addresses, y, scratch, k, controller, held)
        if changed < 0:
            loop_state[0] = t
            return MEASURE_FAILED
        if changed or loop_state[1] != 0.0:  # as Simulator._restart, through its kernels
            # no state set since the last step (as Simulator._restart_kinematics): the first
            # stage from the last one and the engine's input response (esdirk_kernels.restart)
            inputs_only = loop_state[2] == 0.0
            restart_plant(plant, held, x_plant, not inputs_only)
            esdirk_kernels.restart(plant, memory, flags, t, inputs_only)
            loop_state[1] = loop_state[2] = 0.0
        t_next = (k + 1) / fs
        # to t_next, no step budget
        flags[esdirk_layout.I_ONE_STEP] = flags[esdirk_layout.I_MAX_STEPS] = 0
        status = call_stepper(addresses[ADVANCE], arguments.ctypes.data, t_next)
        if status != esdirk_layout.OK:
            loop_state[0] = memory[esdirk_layout.M_T]
            loop_state[1] = loop_state[2] = 1.0
            return status
        t = t_next
    loop_state[0] = t
    return 0


# -- the C entries: the arrays of a run in one table (numerics.array_tables), the
# controller's first, in `sample`'s order, then the driver's
ESDIRK_KINDS = "ifffiFif"  # addresses, loop_state, held, memory, flags, vectors, arguments,
#                            scratch
CVODE_KINDS = "iiffifff"  # addresses, cvode, loop_state, learnt, totals, held, y, scratch
_N = len(CONTROLLER_KINDS)


@kernel(inline="always")
def _measure_end(addresses, y, scratch, controller, stop):
    """After the run's last sample (stop = N): y_N measured into position[N]; 0, or
    END_MEASURE - the status of a measurement that failed."""
    coordinates, position = controller[8], controller[10]
    if stop != position.shape[0] - 1:
        return 0
    status = measure(addresses, y, scratch, coordinates, position[stop])
    return 0 if status == ed.OK else END_MEASURE - status


@entry("int32(voidptr, int64, int64, float64)")
def _esdirk_entry(address, start, stop, fs):
    """`loop_esdirk` on the arrays of the table at `address` (CONTROLLER_KINDS, then
    ESDIRK_KINDS), and y_N measured after the last sample (`_measure_end`)."""
    table = carray(as_int_pointer(address), (3 * (_N + len(ESDIRK_KINDS)),))
    controller = controller_table(table)
    addresses, vectors, scratch = ints(table, _N), floats2d(table, _N + 5), floats(table, _N + 7)
    flag = loop_esdirk(addresses, floats(table, _N + 1), floats(table, _N + 2),
                       floats(table, _N + 3), ints(table, _N + 4), vectors,
                       ints(table, _N + 6), scratch, start, stop, fs, controller)
    if flag != 0:
        return flag
    return _measure_end(addresses, vectors[esdirk_layout.V_Y], scratch, controller, stop)


@entry("int32(voidptr, int64, int64, float64)")
def _cvode_entry(address, start, stop, fs):
    """`loop_cvode` on the arrays of the table at `address` (CONTROLLER_KINDS, then
    CVODE_KINDS), and y_N measured after the last sample (`_measure_end`)."""
    table = carray(as_int_pointer(address), (3 * (_N + len(CVODE_KINDS)),))
    controller = controller_table(table)
    addresses, y, scratch = ints(table, _N), floats(table, _N + 6), floats(table, _N + 7)
    flag = loop_cvode(addresses, ints(table, _N + 1), floats(table, _N + 2),
                      floats(table, _N + 3), ints(table, _N + 4), floats(table, _N + 5), y,
                      scratch, start, stop, fs, controller)
    if flag != 0:
        return flag
    return _measure_end(addresses, y, scratch, controller, stop)


LOOP_ENTRIES = {"esdirk": (_esdirk_entry, ESDIRK_KINDS), "sundials": (_cvode_entry, CVODE_KINDS)}


def loop_runner(driver, controller, arrays):
    """run(start, stop, fs) -> flag: the loop over samples start .. stop - 1 of `driver`
    ("esdirk" or "sundials") through its C entry, on the controller's arrays (as
    `run_sampled_loop` packs them) and the driver's (`ESDIRK_KINDS`, `CVODE_KINDS`)."""
    function, kinds = LOOP_ENTRIES[driver]
    kept = (*controller, *arrays)  # the table points into them
    table = array_table(kept, CONTROLLER_KINDS + kinds)
    address = table.ctypes.data

    def run(start, stop, fs, _keep=(kept, table)):
        return function.ctypes(address, start, stop, fs)

    return run
