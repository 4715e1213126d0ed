"""Meshing: a flexure given as one beam with `segments = n` becomes n beams in a row.

    [elements.leaf_left]
    type = "PLBEAM"
    nodes = ["1", "2", "3", "4"]
    section = "leaf"
    released = ["e1", "e2", "e3"]
    segments = 4

The scene builder (`flexure.core.scene.building`) replaces such an element by the segments
"leaf_left_1" ... "leaf_left_n" of the same type, section and principal axis, joined at n - 1
interior nodes: translational "leaf_left_1" ... "leaf_left_(n-1)" on the straight line between
the element's end positions (equal spacing), each with a rotational node "..._r" whose initial
orientation interpolates the end nodes' (the same orientation for a straight flexure). The
interior nodes carry no lumped mass: the beams' own distributed mass and section inertia are
the flexure's.

The DOFs are made so that the exact-constraint count stays exact, as in SPACAR: the interior
nodes' coordinates are dependent, and on segments 1 ... n-1 every deformation the element
releases (or makes a DOF) is a DOF, while its prescribed (zero) deformations stay zero. A
segment's deformations fix the pose of its end node relative to its start node (3 of each in
the plane, 6 in space), so this chain determines every interior node from the element's first
node. The last segment keeps the element's own statuses, which tie the chain to the element's
last node as the element itself did. A scene that lists no DOFs at all leaves every segment
with the element's statuses and lets flexure choose the whole model's DOFs
(`constraints.choose_dofs`). The model gains (n - 1) times the element's released and
DOF deformations as DOFs; its mechanics are those of n beams with free interior nodes (the
DOF deformations are stressed like released ones: the same energy, another choice of
generalized coordinates than interior node coordinates as DOFs).

Only beams can be meshed (a truss between interior nodes would leave them free sideways); the
segment and node names must be new to the scene.
"""

import numpy as np

MAX_SEGMENTS = 1000
BEAM_NODES = ("translational", "rotational", "translational", "rotational")


def segment_count(builder, key, element):
    """The element's `segments` (1 when absent), checked: an integer from 1 to MAX_SEGMENTS."""
    count = element.get("segments", 1)
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_SEGMENTS:
        builder.fail(f"{key}.segments", f"expected a whole number of segments from 1 to "
                                        f"{MAX_SEGMENTS}, got {count!r}")
    return count


def segment_names(name, count):
    """The names of the `count` segments of element `name`: name_1 ... name_count."""
    return [f"{name}_{j}" for j in range(1, count + 1)]


def split(builder, name, element, kind, nodes, count):
    """The segments of element `name` as [(segment name, its table)], adding the interior
    nodes to the builder; `nodes` are the element's four validated node names, `kind` its
    element module. One element as it is when count is 1."""
    key = f"elements.{name}"
    if count == 1:
        return [(name, element)]
    if tuple(kind.node_kinds) != BEAM_NODES:
        builder.fail(f"{key}.segments", f"only beams (PLBEAM, BEAM) can be split into "
                                        f"segments; {name!r} is a {kind.type_name}")
    dofs = set(builder.names(f"{key}.dof", element.get("dof", []), kind.deformation_names))
    released = set(builder.names(f"{key}.released", element.get("released", []),
                                 kind.deformation_names))
    free = [d for d in kind.deformation_names if d in dofs or d in released]
    p, rp, q, rq = nodes
    chain = [(p, rp)]
    for j in range(1, count):
        t, r = f"{name}_{j}", f"{name}_{j}_r"
        for new in (t, r):
            if new in builder.node_kind:
                builder.fail(f"{key}.segments", f"the interior node {new!r} of the segments "
                                                "has the name of a node of the scene; rename "
                                                "that node")
        s = j / count
        builder.add_interior_node(t, "translational", _between(builder, p, q, s))
        builder.add_interior_node(r, "rotational", _between_rotations(builder, rp, rq, s))
        chain.append((t, r))
    chain.append((q, rq))
    segments = []
    for j, segment in enumerate(segment_names(name, count)):
        table = {k: v for k, v in element.items() if k not in ("segments", "released", "dof")}
        table["nodes"] = [*chain[j], *chain[j + 1]]
        if j < count - 1 and builder.lists_dofs:  # not prescribed zero: a DOF of the chain
            table["released"], table["dof"] = [], free
        else:  # the last keeps the element's own statuses; all do when the scene lists no
            # DOFs, which flexure then chooses for the whole model (constraints.choose_dofs)
            table["released"] = sorted(released, key=kind.deformation_names.index)
            table["dof"] = sorted(dofs, key=kind.deformation_names.index)
        segments.append((segment, table))
    return segments


def _between(builder, a, b, s):
    """The coordinate values (m) a fraction s of the way from node a to node b."""
    va, vb = builder.node_values(a), builder.node_values(b)
    return list((1.0 - s) * va + s * vb)


def _between_rotations(builder, a, b, s):
    """Rotational coordinates a fraction s of the way from node a to node b: the angle (rad)
    in the plane; in space the Euler parameters interpolated and normalised (the end nodes'
    own when they are equal, the usual case), of the same sign as a's."""
    va, vb = builder.node_values(a), builder.node_values(b)
    if va.size == 1:
        return [(1.0 - s) * va[0] + s * vb[0]]
    if np.dot(va, vb) < 0.0:
        vb = -vb
    lam = (1.0 - s) * va + s * vb
    return list(lam / np.linalg.norm(lam))


__all__ = ["MAX_SEGMENTS", "segment_count", "segment_names", "split"]
