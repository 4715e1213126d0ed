"""The C entries through which the compiled engine calls an element's one-element kernels.

An element module writes its maths as two numba kernels on one element's arrays,

    deformations_kernel(x, ref, order, e, De, D2e)     x (m,), ref (width,), e (k,), ...
    inertia_kernel(x, v, ref, order, p, Dp, acc)       p (P,), Dp (P, m), acc (P,)

An inertia kernel reads the velocities v only at order 2, for acc = (D2p v) v: at order 1 the
engine does not fill v.

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

# the templates' globals, bound in each entry's copy: the element's kernel and numba.carray
kernel = None
carray = None


def _deformations_template(x, ref, order, e, De, D2e, m, k, width):
    kernel(carray(x, (m,)), carray(ref, (width,)), order, carray(e, (k,)),
           carray(De, (k, m)), carray(D2e, (k, m, m)))


def _inertia_template(x, v, ref, order, p, Dp, acc, m, P, width):
    kernel(carray(x, (m,)), carray(v, (m,)), carray(ref, (width,)), order,
           carray(p, (P,)), carray(Dp, (P, m)), carray(acc, (P,)))


def _bound(template, element_kernel, signature):
    """The template as a function of its own whose global `kernel` is `element_kernel`, named
    after it, as a lazily compiled C entry."""
    module = element_kernel.__module__.rsplit(".", 1)[-1]
    name = f"{module}_{element_kernel.__name__}_entry"
    doc = (f"C entry of {element_kernel.__module__}.{element_kernel.__name__} for the engine "
           "(pointers to one element's arrays).")

    def make():
        bound = {"kernel": element_kernel, "carray": _carray}
        function = types.FunctionType(template.__code__, {**template.__globals__, **bound},
                                      name)
        function.__qualname__, function.__doc__ = name, doc
        return function

    made = CompiledEntry(make, signature, make=True, name=name)
    made.__doc__ = doc
    return made


def deformations_entry(deformations_kernel):
    """The engine's C entry of an element's `deformations_kernel(x, ref, order, e, De, D2e)`:
    (x, ref, order, e, De, D2e, m, k, width) with pointers to one element's arrays."""
    return _bound(_deformations_template, deformations_kernel, DEFORMATIONS_ENTRY)


def inertia_entry(inertia_kernel):
    """The engine's C entry of an element's `inertia_kernel(x, v, ref, order, p, Dp, acc)`:
    (x, v, ref, order, p, Dp, acc, m, P, width) with pointers to one element's arrays."""
    return _bound(_inertia_template, inertia_kernel, INERTIA_ENTRY)
