"""The sampled loop's measurement of outputs that are not DOFs, as a C entry of its own.

An output that is a coordinate DOF is read from the integrator's state (`sampled_loop_kernels
.measure`); one that is not (an encoder on a rigid body, an angle about a global axis, a
position whose DOF is an elongation) needs x = F(q) at the measured DOFs q: the outputs'
packed model started from the plant's last solution (`measuring`), its positions solved
(`engine.OP_POSITIONS`) and the outputs read from them. That branch is this module's entry,
compiled the first time a loop with such an output asks for its address (`sampled_loop`),
and called by the compiled loops through the loop's addresses array. Linked into the loops'
entries it was compiled (and optimised by LLVM) for every first loop, the demo's too, whose
output is a DOF.
"""

from ..engine import access, engine
from ..engine import data as ed
from ..engine.ports import position_value
from ..numerics.jit import entry
from ..numerics.native import address_of, as_float_pointer, as_int_pointer, call_engine, carray
from .measuring import start_from_plant

# the loop's addresses array (int64), as `sampled_loop` fills it: the packed plant, the
# outputs' packed model, the process's table of engine operations, the integrator's advance
# entry, this module's entry (0 until a loop needs it), the measured outputs' packed rows and
# their number of entries (`sampled_loop_kernels.measure`)
(PLANT, OUTPUT, ENGINE, ADVANCE, MEASURE, COORDINATES, N_COORDINATES, ADDRESSES) = range(8)
# the engine's entry signature: the compiled loops call the entry with `call_engine`, the
# addresses array taking the place of the table of operations and MEASURE of the operation
MEASURE_ENTRY = engine.ENGINE_ENTRY


@entry(MEASURE_ENTRY)
def measure_entry(op, user_data, t, a, b, c, s):
    """The outputs (positions, m; angles, rad) at the integrator state y (a; its first NDOF
    entries are q - q_ref) into out (c, s entries) by Newton on the outputs' packed model;
    b: NDOF float64 of scratch; user_data the loop's addresses array. A status (`data`)."""
    addresses = carray(as_int_pointer(address_of(user_data)), (ADDRESSES,))
    plant = addresses[PLANT]
    ndof = access.dims(plant)[ed.NDOF]
    y = carray(as_float_pointer(address_of(a)), (ndof,))
    q = carray(as_float_pointer(address_of(b)), (ndof,))
    out = carray(as_float_pointer(address_of(c)), (int(s),))
    coordinates = carray(as_int_pointer(addresses[COORDINATES]), (addresses[N_COORDINATES],))
    q_ref = access.reference_dofs(plant)
    access.restart_kinematics(addresses[OUTPUT], access.coordinates(plant))
    for j in range(ndof):
        q[j] = q_ref[j] + y[j]
    start_from_plant(plant, addresses[OUTPUT], q)
    status = call_engine(addresses[ENGINE], engine.OP_POSITIONS, addresses[OUTPUT], 0.0,
                         q.ctypes.data, 0, 0, 0.0)
    if status != ed.OK:
        return status
    x = access.coordinates(addresses[OUTPUT])
    for j in range(out.size):
        out[j] = position_value(coordinates, j, x)
    return ed.OK
