"""A loop plot names its input axis by what the input is (controllers/loop_result.py)."""

from flexure.controllers.loop_result import effort_name
from flexure.core import load_scene

NAMES = {"force": "force", "moment": "moment", "drive": "drive signal"}


def test_each_input_of_the_built_in_scenes_is_named_by_its_unit_as_its_quantity_says():
    """The runner records an input's unit; its name on the plot must be the quantity the
    scene declared: manipulator_control_vcm's coils take a drive signal (V), not a force."""
    seen = set()
    for scene in ("stage_planar_1dof", "manipulator_control", "manipulator_control_vcm",
                  "wire_tripod"):
        for port in load_scene(scene).inputs:
            if port.quantity in NAMES:
                unit = port.unit.replace(".", " ")  # as the runner records it
                assert effort_name(unit) == NAMES[port.quantity], (scene, port.name, unit)
                seen.add(port.quantity)
    assert seen == set(NAMES)
