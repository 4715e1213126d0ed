"""Scenes and paths the kinematic-input tests share: built-in scenes with a kinematic
input, a chain of springs and masses, a pendulum, a sine path."""

import numpy as np

from flexure.core import build_model
from flexure.core.scene.building import parse_toml, scene_path


def scene(name):
    return parse_toml(scene_path(name))


def with_motion(name, node, coordinate, *, drop_dof=True, **keys):
    """A built-in scene with a kinematic input X on node.coordinate (its DOF removed)."""
    data = scene(name)
    if drop_dof:
        data["nodes"][node]["dof"] = [a for a in data["nodes"][node].get("dof", [])
                                      if a != coordinate]
    data.setdefault("inputs", {})["X"] = {"kind": "motion", "node": node,
                                          "coordinate": coordinate, **keys}
    return data


def chain(*, rho_A=0.0):
    """Ground -spring a- node 1 (mass m1, the kinematic input) -b- node 2 (mass m2, the DOF):
    b a PLSPRING, or with rho_A a PLTRUSS with consistent mass (coupling M_fk)."""
    b_type = "PLTRUSS" if rho_A else "PLSPRING"
    b_section = ({"EA": K2 * 0.1, "EdA": C2 * 0.1, "rho_A": rho_A} if rho_A
                 else {"kx": K2, "cx": C2})
    return {
        "scene": {"name": "chain"},
        "sections": {"a": {"kx": K1, "cx": C1}, "b": b_section},
        "nodes": {"0": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "1": {"position": [0.1, 0.0], "mass": M1},
                  "2": {"position": [0.2, 0.0], "mass": M2, "dof": ["x"]}
                  | ({"fixed": ["y"]} if rho_A else {})},
        "elements": {"a": {"type": "PLSPRING", "nodes": ["0", "1"], "section": "a",
                           "released": ["e1"]},
                     "b": {"type": b_type, "nodes": ["1", "2"], "section": "b",
                           "released": ["e1"]}},
        "inputs": {"u": {"kind": "motion", "node": "1", "coordinate": "x"}},
        "outputs": {"x2": {"node": "2", "coordinate": "x"},
                    "v2": {"node": "2", "coordinate": "x", "quantity": "velocity"}},
    }


K1, C1, K2, C2, M1, M2 = 800.0, 0.3, 500.0, 0.2, 0.4, 0.25



def sine(x0, amplitude, omega):
    return lambda t: ([x0 + amplitude * np.sin(omega * t)],
                      [amplitude * omega * np.cos(omega * t)],
                      [-amplitude * omega ** 2 * np.sin(omega * t)])



def pendulum(mass, length, g):
    return build_model({
        "scene": {"name": "pendulum", "gravity": [0.0, -g]},
        "sections": {"link": {"EA": 1e6, "EI": 1e3}},
        "nodes": {"pivot": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                  "hinge": {"angle": 0.0, "dof": ["phi"]},
                  "bob": {"position": [0.0, -length], "mass": mass},
                  "bob_r": {"angle": 0.0}},
        "elements": {"link": {"type": "PLBEAM", "nodes": ["pivot", "hinge", "bob", "bob_r"],
                              "section": "link"}},
        "inputs": {"T": {"node": "hinge", "coordinate": "phi"}},
        "outputs": {"theta": {"node": "hinge", "coordinate": "phi"},
                    "tension": {"element": "link", "deformation": "e1", "quantity": "stress"}}})
