"""The compiled checks of `plausibility.RangeCheck`: whether a state is within the model's
range of validity, in the few microseconds an FMU can spend on it after every doStep.
(A module of their own: `plausibility` is imported by the analyses, which need no numba.)"""


from ..numerics.array_tables import floats, ints
from ..numerics.jit import entry, kernel
from ..numerics.native import as_int_pointer, carray


@kernel
def within(x, e, indices, bounds, n_elongations):
    """`plausibility.RangeCheck.within` compiled: a tenth of the numpy expression's time on a
    few elements, where each numpy call's overhead dominated a doStep of the FMU. `indices` holds
    the elongations' deformation indices (the first `n_elongations`), then the translational
    coordinates'; `bounds` their bounds |e1| (m), then the coordinates' start values (m),
    then the distance bound (m)."""
    for i in range(n_elongations):
        if abs(e[indices[i]]) > bounds[i]:
            return False
    distance_bound = bounds[bounds.size - 1]
    for i in range(n_elongations, indices.size):
        if abs(x[indices[i]] - bounds[i]) > distance_bound:
            return False
    return True


@kernel
def within_at(address):
    """`within` of the arrays in the table at `address` (`plausibility.RangeCheck.watch`): an
    array table (`numerics.array_tables`) of x, e, indices and bounds ("ffif"), then the
    number of elongations."""
    table = carray(as_int_pointer(address), (13,))
    return within(floats(table, 0), floats(table, 1), ints(table, 2), floats(table, 3),
                  table[12])


@entry("int32(int64)")
def within_entry(address):
    """`within_at` as a C entry (1 or 0), through which Python calls it: a process that loads
    the compiled code from the cache checks without numba."""
    return 1 if within_at(address) else 0
