"""The model's inputs and outputs in compiled code: packed rows and their kernels.

Each port is packed as one int64 row of PORT_WIDTH entries (`port_specs`):

    [COORDINATE, c, -1, -1, -1, -1]          a force on / the value of coordinate c
    [ROTATION, l0, l1, l2, l3, k]            a moment about / the angle about global axis k
                                             of the node with Euler parameters x[l0 .. l3]

and the kernels below are the compiled twins of `flexure.core.mechanics.ports` (the maths is
in its docstring): the generalised force of the inputs, its load stiffness, the value of an
output, a port's velocity (the power conjugate of its force or moment, which a voice coil's
back-EMF takes: `actuators`), and a port's row on the DOFs (`port_row`, `angle_row`: an
input's column of the state space's B and an output's row of its C, `port_entries`). Units:
N, N m, m, rad, as the model's.
"""

import numpy as np

from ..numerics.jit import kernel
from ..numerics.rotation_kernels import (
    rates_coefficient,
    rates_row,
    rotation_vector_component,
    rotation_vector_value,
)

COORDINATE, ROTATION = 0, 1
PORT_WIDTH = 6
_AXES = {"rx": 0, "ry": 1, "rz": 2}


def port_specs(ports):
    """The packed rows (n_ports, PORT_WIDTH) int64 of `ports` (see the module)."""
    specs = np.full((len(ports), PORT_WIDTH), -1, dtype=np.int64)
    for row, port in zip(specs, ports, strict=True):
        if port.about_axis:
            row[0], row[1:5], row[5] = ROTATION, port.euler, _AXES[port.axis]
        else:
            row[0], row[1] = COORDINATE, port.coordinate
    return specs


@kernel
def add_input_forces(specs, inputs, x, r):
    """r += the generalised force of the inputs (n,) at coordinates x: u on coordinate c, or
    2 u E_k(lambda)^T on the Euler parameters for a moment u about axis k. specs is flat
    (n PORT_WIDTH)."""
    for j in range(inputs.size):
        base = j * PORT_WIDTH
        if specs[base] == COORDINATE:
            r[specs[base + 1]] += inputs[j]
            continue
        i0, i1, i2, i3 = specs[base + 1], specs[base + 2], specs[base + 3], specs[base + 4]
        e0, e1, e2, e3 = rates_row(x[i0], x[i1], x[i2], x[i3], specs[base + 5])
        u2 = 2.0 * inputs[j]
        r[i0] += u2 * e0
        r[i1] += u2 * e1
        r[i2] += u2 * e2
        r[i3] += u2 * e3


@kernel
def has_moment_inputs(specs, inputs):
    """Whether a moment input is non-zero (then the forces depend on the coordinates)."""
    for j in range(inputs.size):
        if specs[j * PORT_WIDTH] == ROTATION and inputs[j] != 0.0:
            return True
    return False


@kernel
def subtract_input_stiffness(specs, inputs, DF, ndof, K):
    """K -= DF_l^T (2 u P_k) DF_l for every moment input u about axis k (the load stiffness of
    a moment whose axis stays fixed in space; P_k = dE_k / dlambda, constant). DF (NX NDOF)
    and K (NDOF NDOF) flat, row by row."""
    for j in range(inputs.size):
        base = j * PORT_WIDTH
        if specs[base] != ROTATION or inputs[j] == 0.0:
            continue
        k = specs[base + 5]
        for a in range(4):
            ra = specs[base + 1 + a]
            for b in range(4):
                coefficient = 2.0 * inputs[j] * rates_coefficient(k, a, b)
                if coefficient == 0.0:
                    continue
                rb = specs[base + 1 + b]
                for i1 in range(ndof):
                    left = coefficient * DF[ra * ndof + i1]
                    if left == 0.0:
                        continue
                    for i2 in range(ndof):
                        K[i1 * ndof + i2] -= left * DF[rb * ndof + i2]


@kernel
def position_value(specs, j, x):
    """The position output j (packed rows, flat) at coordinates x: x_c, or phi_k (rad)."""
    base = j * PORT_WIDTH
    if specs[base] == COORDINATE:
        return x[specs[base + 1]]
    return rotation_vector_value(x[specs[base + 1]], x[specs[base + 2]], x[specs[base + 3]],
                                 x[specs[base + 4]], specs[base + 5])


@kernel
def port_velocity(specs, j, x, xdot):
    """The velocity of port j (packed rows, flat) at coordinates x and velocities xdot: xdot_c
    (m/s, rad/s), or the angular velocity omega_k = 2 E_k(lambda) lambda_dot about axis k
    (rad/s); the power conjugate of the port's force or moment."""
    base = j * PORT_WIDTH
    if specs[base] == COORDINATE:
        return xdot[specs[base + 1]]
    i0, i1, i2, i3 = specs[base + 1], specs[base + 2], specs[base + 3], specs[base + 4]
    e0, e1, e2, e3 = rates_row(x[i0], x[i1], x[i2], x[i3], specs[base + 5])
    return 2.0 * (e0 * xdot[i0] + e1 * xdot[i1] + e2 * xdot[i2] + e3 * xdot[i3])


@kernel
def port_row(specs, j, x, DF, ndof, out):
    """out (ndof,) = b_j(x)^T DF: the velocity of port j per DOF velocity, and the generalised
    force on the DOFs of a unit value of it (b_j the port's unit generalised force on the
    coordinates). DF (NX NDOF) flat, row by row."""
    base = j * PORT_WIDTH
    if specs[base] == COORDINATE:
        c = specs[base + 1]
        for i in range(ndof):
            out[i] = DF[c * ndof + i]
        return
    i0, i1, i2, i3 = specs[base + 1], specs[base + 2], specs[base + 3], specs[base + 4]
    e0, e1, e2, e3 = rates_row(x[i0], x[i1], x[i2], x[i3], specs[base + 5])
    for i in range(ndof):
        out[i] = 2.0 * (e0 * DF[i0 * ndof + i] + e1 * DF[i1 * ndof + i]
                        + e2 * DF[i2 * ndof + i] + e3 * DF[i3 * ndof + i])


@kernel
def angle_row(specs, j, x, DF, ndof, out):
    """out (ndof,) = d y_j / d q of a position output j (packed rows, flat): the row DF_c of a
    coordinate c (m/m, m/rad), or (d phi_k / d lambda) DF_l of the angle phi_k (rad) about
    axis k of a node with Euler parameters lambda (rad/m, rad/rad), the rotation vector's
    gradient (`rotation_kernels.rotation_vector_component`). DF (NX NDOF) flat, row by row."""
    base = j * PORT_WIDTH
    if specs[base] == COORDINATE:
        port_row(specs, j, x, DF, ndof, out)
        return
    lam = np.empty(4)
    for a in range(4):
        lam[a] = x[specs[base + 1 + a]]
    D = np.zeros(4)
    rotation_vector_component(lam, specs[base + 5], 1, D, np.empty((4, 4)))
    for i in range(ndof):
        value = 0.0
        for a in range(4):
            value += D[a] * DF[specs[base + 1 + a] * ndof + i]
        out[i] = value
