"""The C entries through which the compiled engine calls an element's one-element kernels.

An element module writes its maths as two numba kernels on one element's arrays,

    deformations_kernel(x, ref, order, e, De, D2e)     x (m,), ref (width,), e (k,), ...
    inertia_kernel(x, v, ref, order, p, Dp, acc)       p (P,), Dp (P, m), acc (P,)

An inertia kernel reads the velocities v only at order 2, for acc = (D2p v) v: at order 1 the
engine does not fill v.

An element may also write its directional second derivative,

    directional_kernel(x, v, ref, h)                   v (m,), h (k,) = v^T D2e_b v

which the equations of motion need in place of D2e (the constraint rows' h = xdot^T D2e
xdot): then its entry is `entries.deformations_entry(deformations_kernel,
directional_kernel)`, and the engine evaluates its D2e only where a tangent reads it
(`kinematics.deformations`). The entry takes two more orders, below zero:

    ORDER_DIRECTIONAL   h into e (k,), v (m,) read at De's address; De and D2e untouched
    ORDER_ASK           e[0] = 1.0 if the element has a directional kernel, else 0.0
    ORDER_KEPT          e and De, and at D2e's address the rotations that the element's
                        rates share, where it has a `kept_kernel(x, ref, e, De, kept)`
                        (the BEAM: `beam_kernels.kept_deformations_kernel`; the engine
                        points D2e at the element's row of slot beam_points)

and gets the engine's entry points from them here:

    deformations_entry = entries.deformations_entry(deformations_kernel)
    inertia_entry = entries.inertia_entry(inertia_kernel)

Each entry is a lazily compiled C function (`numerics.jit.entry`) with the signature the
engine calls through a function pointer (`jit.DEFORMATIONS_ENTRY`, `jit.INERTIA_ENTRY`): it
wraps the raw pointers as arrays of the element's shape and calls the kernel. The entry is a
copy of one template function whose global `kernel` is the element's kernel (numba resolves
globals when it compiles) and whose qualified name is the kernel's own, which keys its entry in
the compiled-code cache: every element's entry is cached apart. (A closure over the kernel
would compile the same, but numba keys a closure's cache entry on its pickled cell contents,
which for a kernel change with every process: the entry would compile at every start.)
The copy is made when the entry's address is first asked for; neither declaring nor making
it imports numba (`carray` is a `jit.CompiledName`).
"""

import types

from ..numerics.jit import DEFORMATIONS_ENTRY, INERTIA_ENTRY, CompiledEntry
from ..numerics.native import carray as _carray

ORDER_DIRECTIONAL = -1  # h = v^T D2e v into e, v at De (elements with a directional kernel)
ORDER_ASK = -2  # e[0] = 1.0 if the element has a directional kernel, else 0.0
ORDER_KEPT = -3  # e, De and the kept rotations at D2e (elements with a kept kernel)
_NAN = float("nan")

# the templates' globals, bound in each entry's copy: the element's kernels and numba.carray
kernel = None
directional = None
kept = None
kept_width = 0
carray = None


def _deformations_template(x, ref, order, e, De, D2e, m, k, width):
    if order < 0:  # ORDER_ASK (ORDER_DIRECTIONAL is never asked of it: NaN if it were)
        carray(e, (k,))[0] = 0.0 if order == ORDER_ASK else _NAN  # a scalar store: no
        return  # slice assignment to compile into every element's entry
    kernel(carray(x, (m,)), carray(ref, (width,)), order, carray(e, (k,)),
           carray(De, (k, m)), carray(D2e, (k, m, m)))


def _directional_template(x, ref, order, e, De, D2e, m, k, width):
    if order == ORDER_ASK:
        carray(e, (k,))[0] = 1.0
        return
    if order == ORDER_DIRECTIONAL:
        directional(carray(x, (m,)), carray(De, (m,)), carray(ref, (width,)), carray(e, (k,)))
        return
    if order == ORDER_KEPT:
        kept(carray(x, (m,)), carray(ref, (width,)), carray(e, (k,)), carray(De, (k, m)),
             carray(D2e, (kept_width,)))
        return
    kernel(carray(x, (m,)), carray(ref, (width,)), order, carray(e, (k,)),
           carray(De, (k, m)), carray(D2e, (k, m, m)))


def _inertia_template(x, v, ref, order, p, Dp, acc, m, P, width):
    kernel(carray(x, (m,)), carray(v, (m,)), carray(ref, (width,)), order,
           carray(p, (P,)), carray(Dp, (P, m)), carray(acc, (P,)))


def _bound(template, element_kernel, signature, directional_kernel=None, kept_kernel=None,
           kept_width=0):
    """The template as a function of its own whose global `kernel` is `element_kernel` (and
    `directional` the element's directional kernel, if given), named after it, as a lazily
    compiled C entry."""
    module = element_kernel.__module__.rsplit(".", 1)[-1]
    name = f"{module}_{element_kernel.__name__}_entry"
    if directional_kernel is not None:  # another template: an entry of its own in the cache
        name = f"{module}_{element_kernel.__name__}_and_{directional_kernel.__name__}_entry"
    if kept_kernel is not None:
        name = f"{name[:-len('_entry')]}_and_{kept_kernel.__name__}_entry"
    doc = (f"C entry of {element_kernel.__module__}.{element_kernel.__name__} for the engine "
           "(pointers to one element's arrays).")

    def make():
        bound = {"kernel": element_kernel, "directional": directional_kernel,
                 "kept": kept_kernel, "kept_width": kept_width, "carray": _carray}
        function = types.FunctionType(template.__code__, {**template.__globals__, **bound},
                                      name)
        function.__qualname__, function.__doc__ = name, doc
        return function

    made = CompiledEntry(make, signature, make=True, name=name)
    made.__doc__ = doc
    return made


def deformations_entry(deformations_kernel, directional_kernel=None, kept_kernel=None,
                       kept_width=0):
    """The engine's C entry of an element's `deformations_kernel(x, ref, order, e, De, D2e)`
    and, if given, of its `directional_kernel(x, v, ref, h)` (ORDER_DIRECTIONAL) and of its
    `kept_kernel(x, ref, e, De, kept)` with kept (kept_width,) (ORDER_KEPT; a directional
    kernel comes with one): (x, ref, order, e, De, D2e, m, k, width) with pointers to one
    element's arrays."""
    if directional_kernel is None:
        return _bound(_deformations_template, deformations_kernel, DEFORMATIONS_ENTRY)
    return _bound(_directional_template, deformations_kernel, DEFORMATIONS_ENTRY,
                  directional_kernel, kept_kernel, kept_width)


def inertia_entry(inertia_kernel):
    """The engine's C entry of an element's `inertia_kernel(x, v, ref, order, p, Dp, acc)`:
    (x, v, ref, order, p, Dp, acc, m, P, width) with pointers to one element's arrays."""
    return _bound(_inertia_template, inertia_kernel, INERTIA_ENTRY)
