"""The gripper's opening comes from the robot preset (``gripper: {max_opening: [m]}``, the PR2's
0.09 m when absent) and decides which generated grasps a step has."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from placement.errors import PresetError
from placement.planning.problems.grasps import GRIPPER_OPENING
from placement.planning.problems.steps import object_grasps
from placement.robots import load_robot
from placement.robots.preset import PRESET_DIR
from placement.scene import SceneObject


def preset_with(tmp_path, gripper) -> str:
    spec = yaml.safe_load((PRESET_DIR / "pr2.yaml").read_text())
    spec["gripper"] = gripper
    path = tmp_path / "pr2_gripper.yaml"
    path.write_text(yaml.safe_dump(spec))
    return str(path)


def sides(grasps) -> set[str]:
    return {g.name for g in grasps if g.name.startswith("side")}


def test_a_smaller_opening_yields_fewer_side_grasps(tmp_path, pr2):
    """A 4 x 8 cm box: the PR2's 9 cm opening closes across either side (4 side grasps), a 5 cm one
    only across the 4 cm side (the faces of the 8 cm axis, +-y); both close on top."""
    small = load_robot(preset_with(tmp_path, {"max_opening": 0.05}))
    assert small.gripper.max_opening == 0.05
    assert pr2.gripper.max_opening == GRIPPER_OPENING == 0.09
    box = SceneObject("box", np.array([2.0, 0.0, 0.85]), 0.0, np.array([0.04, 0.08, 0.2]))
    wide = object_grasps(box, 2, pr2.gripper.max_opening)
    narrow = object_grasps(box, 2, small.gripper.max_opening)
    assert sides(wide) == {"side--x", "side--y", "side-+x", "side-+y"}
    assert sides(narrow) == {"side--y", "side-+y"}
    assert {"top", "top-flipped"} <= {g.name for g in narrow}


def test_an_absent_or_empty_gripper_keeps_the_default(tmp_path):
    assert load_robot(preset_with(tmp_path, None)).gripper.max_opening == GRIPPER_OPENING
    assert load_robot(preset_with(tmp_path, {})).gripper.max_opening == GRIPPER_OPENING


@pytest.mark.parametrize(
    ("gripper", "words"),
    [
        ({"max_opening": -0.01}, "gripper.max_opening"),
        ({"max_opening": 0}, "gripper.max_opening"),
        ({"max_opening": "wide"}, "gripper.max_opening"),
        ({"max_opening": 90}, "gripper.max_opening: must be <= 2 m"),
        ({"width": 0.1}, "gripper.width"),
        ([0.09], "gripper: expected a mapping"),
    ],
)
def test_bad_gripper_values_are_one_line_naming_the_key(tmp_path, gripper, words):
    with pytest.raises(PresetError) as err:
        load_robot(preset_with(tmp_path, gripper))
    assert words in str(err.value) and "\n" not in str(err.value)


def test_the_planner_generates_grasps_for_the_robots_gripper(tmp_path, maps_dir):
    """A planner's step candidates use its robot's opening: the 5 cm gripper has the side grasps
    of a 4 cm wide box only."""
    from placement.planning import Planner

    doc = {
        "version": 2,
        "resolution": 0.05,
        "bounds": [0.0, 0.0, 4.0, 3.0],
        "maps": str(maps_dir),
        "robot": {"preset": preset_with(tmp_path, {"max_opening": 0.05}), "start": [0.8, 1.5, 0.0]},
        "obstacles": [{"name": "table", "box": {"center": [2.5, 1.5, 0.375], "size": [0.8, 0.6, 0.75]}, "table": True}],
        "objects": [{"name": "box", "position": [2.5, 1.5, 0.85], "yaw": 0.0, "size": [0.04, 0.08, 0.2]}],
        "place_locations": [{"name": "spot", "position": [2.4, 1.3, 0.85]}],
        "task": [{"pick": "box", "place": "spot"}],
        "planner": {"threshold": 0.01, "yaw_steps": 40},
    }
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(doc))
    planner = Planner(tmp_path / "scene.yaml", collisions=False)
    assert planner.problems.opening_m == 0.05
    grasps = {o.candidate.grasp for o in planner.problems.options(0)}
    assert grasps == {"top", "top-flipped", "side--y", "side-+y"}
