"""A node inertia's point products in closed form, for the element pass of `inertia_product`.

A node inertia (`elements.rotary_inertia`) carries its rigid body by three points p_k =
R(lambda) b_k on the node's four Euler parameters, each with its "mass" s_k on the three
components: Mp = diag(s_k) (x) I_3, its pattern the 9 diagonal entries. The general pass
reaches its points through the group's inertia entry (a call by address, into scratch) and
its products through Mp's pattern and Dp's full (9, 4) rows, twice (at a and at a = 0). Here
the points, Dp = 2 C_k lambda and (D2p v) v = 2 R(v) b_k come from the closed forms of
`rotation_kernels` (as `rotary_inertia.inertia_kernel` gives them) and both products are
formed in one pass over the nine points, each sum in the order `inertia_product.
element_product` takes: the same bits. Packing marks such a group (group field
node_inertia, when its pattern is the diagonal).
"""

from ..numerics.jit import kernel
from ..numerics.rotation_kernels import rotated_half_jacobian, rotated_vector


@kernel(inline="always")
def _add_point(out, d0, d1, d2, d3, mass, point):
    """out (4,) += (d0, d1, d2, d3) w, w = mass point: one point component's share of Dp^T w,
    w summed from zero and skipped where it is zero, as the general point kernel does (the
    same bits)."""
    w = 0.0
    w += mass * point
    if w != 0.0:
        out[0] += d0 * w
        out[1] += d1 * w
        out[2] += d2 * w
        out[3] += d3 * w


@kernel(inline="always")  # into `inertia_product._element_pass`, its one caller
def node_point_products(ref, xl, vl, moving, with_gravity, gravity, Mp, a_e, out_a, out_0,
                        split):
    """out_a (4,) = Dp^T Mp (g_p - (D2p v) v - Dp a_e) and, if split, out_0 (4,) = the same
    at a_e = 0 ((D2p v) v only if moving, g_p only with_gravity; the Euler parameters'
    generalised forces, N m) for one node inertia: its Euler parameters xl (4,), their
    rates vl (4,), its packed reference row ref (the body vectors b_k at 3 k ...), the point
    gravity (9,; zero for these tangent points, read as the general pass reads it) and its
    Mp (81,)."""
    m0, m1, m2, m3 = xl[0], xl[1], xl[2], xl[3]
    a0, a1, a2, a3 = a_e[0], a_e[1], a_e[2], a_e[3]
    for b in range(4):
        out_a[b] = 0.0
        out_0[b] = 0.0
    for k in range(3):
        b0, b1, b2 = ref[3 * k], ref[3 * k + 1], ref[3 * k + 2]
        h = rotated_half_jacobian(b0, b1, b2, m0, m1, m2, m3)
        w = rotated_vector(b0, b1, b2, vl[0], vl[1], vl[2], vl[3])
        for c in range(3):
            pp = 3 * k + c
            d0, d1, d2, d3 = 2.0 * h[0][c], 2.0 * h[1][c], 2.0 * h[2][c], 2.0 * h[3][c]
            g_p = gravity[pp] if with_gravity else 0.0
            point = g_p - 2.0 * w[c] if moving else g_p
            at_rest = point
            if a0 != 0.0:
                point -= d0 * a0
            if a1 != 0.0:
                point -= d1 * a1
            if a2 != 0.0:
                point -= d2 * a2
            if a3 != 0.0:
                point -= d3 * a3
            mass = Mp[pp * 10]
            _add_point(out_a, d0, d1, d2, d3, mass, point)
            if split:
                _add_point(out_0, d0, d1, d2, d3, mass, at_rest)
