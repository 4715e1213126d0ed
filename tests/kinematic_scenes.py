"""Scenes and paths the kinematic-input tests share: built-in scenes with a kinematic
input, a chain of springs and masses, a pendulum, a sine path; the chain split into a
force-driven leader and a displacement-driven follower, and a smooth motion of its node 1
(the displacement-driven FMUs' tests)."""

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


def turned_pendulum(mass, length, g, *, name="pendulum", **motion):
    """The data of a point mass `mass` (kg) on a stiff link `length` (m) under gravity g
    (m/s^2), turned about its pivot by the kinematic input A on the hinge's angle (rad;
    `motion`: the input's keys, as its value)."""
    return {"scene": {"name": name, "gravity": [0.0, -g]},
            "sections": {"link": {"EA": 1e6, "EI": 1e3}},
            "nodes": {"pivot": {"position": [0.0, 0.0], "fixed": ["x", "y"]},
                      "hinge": {"angle": 0.0},
                      "bob": {"position": [0.0, -length], "mass": mass},
                      "bob_r": {"angle": 0.0}},
            "elements": {"link": {"type": "PLBEAM", "nodes": ["pivot", "hinge", "bob", "bob_r"],
                                  "section": "link"}},
            "inputs": {"A": {"kind": "motion", "node": "hinge", "coordinate": "phi", **motion}}}


X0, STROKE, PERIOD = 0.1, 1e-3, 0.04  # node 1's start (m), the motion's stroke (m), period (s)


def motion(t):
    """A smooth motion of node 1 that starts at rest (its first three derivatives zero):
    u = X0 + STROKE / 4 (1 - cos w t)^2; (u, u', u'') in m, m/s, m/s^2."""
    w = 2 * np.pi / PERIOD
    c, s = np.cos(w * t), np.sin(w * t)
    return (X0 + STROKE / 4 * (1 - c) ** 2, STROKE / 2 * (1 - c) * w * s,
            STROKE / 2 * w**2 * (s**2 + (1 - c) * c))


# node 1's mass M1 split: the follower carries some of it, since the prescribed form solves
# with the mass matrix of every DOF, the moved node's too (a massless one is singular); a
# small part, since a coupling by positions and forces is stable only while the mass the
# follower moves is small against the leader's (tests/test_fmu_motion_pair.py)
FOLLOWER_MASS = M1 / 10


def leader():
    """The chain's first half, force-driven: ground -k1, c1- node 1 (M1 - FOLLOWER_MASS), the
    force F on 1.x; its position and velocity out."""
    data = chain()
    data["scene"]["name"] = "leader"
    data["nodes"] = {"0": data["nodes"]["0"],
                     "1": data["nodes"]["1"] | {"dof": ["x"], "mass": M1 - FOLLOWER_MASS}}
    data["elements"] = {"a": data["elements"]["a"]}
    data["sections"] = {"a": data["sections"]["a"]}
    data["inputs"] = {"F": {"node": "1", "coordinate": "x"}}
    data["outputs"] = {"x1": {"node": "1", "coordinate": "x"},
                       "v1": {"node": "1", "coordinate": "x", "quantity": "velocity"}}
    return data


def follower():
    """The chain's second half, displacement-driven: node 1 (FOLLOWER_MASS) moved (u), -k2,
    c2- m2 (node 2); the force that moves node 1 is u.effort."""
    data = chain()
    data["scene"]["name"] = "follower"
    data["nodes"] = {"1": {"position": [X0, 0.0], "fixed": ["y"], "mass": FOLLOWER_MASS},
                     "2": data["nodes"]["2"]}
    data["elements"] = {"b": data["elements"]["b"]}
    data["sections"] = {"b": data["sections"]["b"]}
    return data


def whole():
    """The chain in one scene: the force F on m1, both masses free."""
    data = chain()
    data["scene"]["name"] = "whole"
    data["nodes"]["1"]["dof"] = ["x"]
    data["inputs"] = {"F": {"node": "1", "coordinate": "x"}}
    data["outputs"] = {"x1": {"node": "1", "coordinate": "x"},
                       "x2": {"node": "2", "coordinate": "x"}}
    return data
