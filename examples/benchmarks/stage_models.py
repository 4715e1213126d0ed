"""The models the benchmark runs: the scene data of the planar leaf-spring stage, the stroke of
its 1 N step, and the stage with each leaf spring split into n PLBEAMs (`refined_stage`)."""

import copy
import tomllib
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENES = HERE.parent / "scenes"
LEAF_LENGTH = 0.1  # m


def scene_data(name="stage_planar_3dof"):
    with open(SCENES / f"{name}.toml", "rb") as handle:
        return tomllib.load(handle)


def step_stroke(force=1.0):
    """The stroke of the step (m): the linear static deflection F l^3 / (24 EI)."""
    leaf = scene_data()["sections"]["leaf"]
    EI = leaf["E"] * leaf["width"] * leaf["height"] ** 3 / 12
    return abs(force) * LEAF_LENGTH**3 / (24 * EI)


def refined_stage(n, *, damped=True):
    """stage_planar_3dof with each leaf spring split into `n` PLBEAMs (6 n - 3 DOFs).

    Every leaf element keeps the scene's released e1, e2, e3; the n - 1 intermediate nodes
    of a spring carry x, y and phi as DOFs. n = 1 is the scene itself. `damped=False` sets
    the leaves' EdA and EdI to 0."""
    from flexure.core import build_model

    data = copy.deepcopy(scene_data())
    data["scene"]["name"] = f"stage_planar_3dof_x{n}" + ("" if damped else "_undamped")
    data["scene"].pop("tunable", None)
    if not damped:
        data["sections"]["leaf"].update(EdA=0.0, EdI=0.0)
    elements = data["elements"]
    for side, bottom, top, x in (("left", ("1", "2"), ("3", "4"), 0.0),
                                 ("right", ("7", "8"), ("5", "6"), LEAF_LENGTH)):
        leaf = elements.pop(f"leaf_{side}")
        chain = [bottom]
        for j in range(1, n):
            t, r = f"{side}_{j}", f"{side}_{j}r"
            data["nodes"][t] = {"position": [x, LEAF_LENGTH * j / n], "dof": ["x", "y"]}
            data["nodes"][r] = {"angle": 0.0, "dof": ["phi"]}
            chain.append((t, r))
        chain.append(top)
        for j in range(n):
            elements[f"leaf_{side}_{j}"] = {**leaf, "nodes": [*chain[j], *chain[j + 1]]}
    return build_model(data, source=f"refined_stage({n})")
