"""Scenes with outputs on elements (SPACAR's OUTE, OUTF) that the simulation and FMU tests of
them share: the planar and spatial stages with their leaves' deformations and stress
resultants, and a chain pushed by a truss whose elongation is a kinematic input."""

from kinematic_scenes import C2, K2, M1, M2, scene


def stage_planar():
    """stage_planar_3dof (force F on 3.x): the left leaf's elongation and bending as
    deformations and stress resultants, the right leaf's bending stress, and the rigid
    bar's axial force and bending moment (reactions)."""
    data = scene("stage_planar_3dof")
    data["outputs"] |= {
        "e1_left": {"element": "leaf_left", "deformation": "e1"},
        "e2_left": {"element": "leaf_left", "deformation": "e2"},
        "N_left": {"element": "leaf_left", "deformation": "e1", "quantity": "stress"},
        "M2_left": {"element": "leaf_left", "deformation": "e2", "quantity": "stress"},
        "M3_right": {"element": "leaf_right", "deformation": "e3", "quantity": "stress"},
        "N_bar": {"element": "bar", "deformation": "e1", "quantity": "stress"},
        "M2_bar": {"element": "bar", "deformation": "e2", "quantity": "stress"}}
    return data


def stage_spatial():
    """stage_spatial_1dof (force F on 3.x): the leaves' sideways bending e5, e6 and the right
    leaf's torsion e2, deformations and stress resultants; the left leaf's rigid elongation
    and torsion (reactions)."""
    data = scene("stage_spatial_1dof")
    data.setdefault("outputs", {})
    data["outputs"] |= {
        "e5_left": {"element": "leaf_left", "deformation": "e5"},
        "M5_left": {"element": "leaf_left", "deformation": "e5", "quantity": "stress"},
        "M6_left": {"element": "leaf_left", "deformation": "e6", "quantity": "stress"},
        "T_right": {"element": "leaf_right", "deformation": "e2", "quantity": "stress"},
        "e6_right": {"element": "leaf_right", "deformation": "e6"},
        "N_left": {"element": "leaf_left", "deformation": "e1", "quantity": "stress"},
        "T_left": {"element": "leaf_left", "deformation": "e2", "quantity": "stress"}}
    return data


def pushed_chain(*, name="pushed"):
    """Ground -truss act (its elongation L, a kinematic input, moved 0 to 1 mm)- node 1 (M1)
    -spring b (K2, C2)- node 2 (M2, the DOF): act's force (a reaction, minus L's effort),
    b's elongation and force (with its damper)."""
    return {
        "scene": {"name": name},
        "sections": {"act": {"EA": 2e5}, "b": {"kx": K2, "cx": C2}},
        "nodes": {"0": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "1": {"position": [0.1, 0.0], "mass": M1, "fixed": ["y"]},
                  "2": {"position": [0.2, 0.0], "mass": M2, "dof": ["x"]}},
        "elements": {"act": {"type": "PLTRUSS", "nodes": ["0", "1"], "section": "act"},
                     "b": {"type": "PLSPRING", "nodes": ["1", "2"], "section": "b",
                           "released": ["e1"]}},
        "inputs": {"L": {"kind": "motion", "element": "act", "deformation": "e1",
                         "value": 1e-3}},
        "outputs": {"x2": {"node": "2", "coordinate": "x"},
                    "push": {"element": "act", "deformation": "e1", "quantity": "stress"},
                    "stretch": {"element": "act", "deformation": "e1"},
                    "eb": {"element": "b", "deformation": "e1"},
                    "fb": {"element": "b", "deformation": "e1", "quantity": "stress"}}}
