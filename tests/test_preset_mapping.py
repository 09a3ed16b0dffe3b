"""Robot presets, the mapping alone (values, documents, footprints, idle configurations): every bad preset is one
PresetError line naming the file and the key path."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.presets import DELETE, changed, message, pr2_mapping, write
from support.robots import armar6_spec

import placement
from placement.errors import PresetError, RobotError
from placement.robots.preset import PRESET_DIR
from placement.robots.spec import parse_preset

# -- the mapping alone ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "value,words",
    [
        ([0, 0, 0, 0, 0.5, 0, 0.5], ["norm 0.707106781", "norm 1"]),
        ([0, 0, 0, 0, 0, 0, 0], ["norm 0"]),
        ([0, 0, 0, 0, 0, 0], ["expected 7 numbers [x y z qx qy qz qw], got 6"]),
        ([0, 0, "z", 0, 0, 0, 1], ["tcp_offset[2]", "expected a number, got string 'z'"]),
        ([0, 0, 0, 0, 0, 0, math.nan], ["tcp_offset[6]", "finite"]),
        ([math.inf, 0, 0, 0, 0, 0, 1], ["tcp_offset[0]", "finite"]),
        ([0, 0, 0, 0, 0, True, 1], ["tcp_offset[5]", "boolean"]),
        ("0 0 0 0 0 0 1", ["expected a list"]),
    ],
)
def test_bad_tcp_offset(tmp_path, value, words):
    message(
        tmp_path, changed(pr2_mapping(), arms__right__tcp_offset=value), PresetError, "arms.right.tcp_offset", *words
    )


def test_near_unit_quaternion_is_normalised(tmp_path):
    s = 1 + 5e-7
    spec = changed(
        pr2_mapping(), arms__right__tcp_offset=[0, 0, 0, 0, 0.7071067811865476 * s, 0, 0.7071067811865476 * s]
    )
    arm = placement.load_robot(write(tmp_path, spec)).arm("right")
    R = arm.tcp_offset[:3, :3]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(arm.tcp_offset, placement.load_robot("pr2").arm("right").tcp_offset, atol=1e-15)
    message(tmp_path, changed(spec, arms__right__tcp_offset=[0, 0, 0, 0, 0, 0, 1 + 2e-6]), PresetError, "norm 1.000002")


@pytest.mark.parametrize(
    "key,value,words",
    [
        ("home", [0, 0, "x", 0, 0, 0, 0], ["arms.right.home[2]", "string 'x'"]),
        ("home", [0, 0, 0, math.nan, 0, 0, 0], ["arms.right.home[3]", "finite"]),
        ("home", [0, 0, 0, 0, -math.inf, 0, 0], ["arms.right.home[4]", "finite"]),
        ("home", [0, 0, 0, 0, 0, 0], ["arms.right.home", "expected 7 values", "got 6"]),
        ("home", {"a": 1}, ["arms.right.home", "expected a list", "mapping"]),
        ("joints", [1, 2, 3, 4, 5, 6, 7], ["arms.right.joints[0]", "expected a non-empty string, got 1"]),
        ("joints", "r_shoulder_pan_joint", ["arms.right.joints", "expected a list of joint names"]),
        (
            "joints",
            ["r_shoulder_pan_joint", "r_shoulder_lift_joint", "r_upper_arm_roll_joint", "r_elbow_flex_joint"],
            ["arms.right.joints", "at least 5 joint names, got 4"],
        ),
        ("tip_frame", ["r_gripper_tool_frame"], ["arms.right.tip_frame", "non-empty string"]),
        ("grip", 1, ["arms.right.grip", "unknown key", "home, idle, joints, tcp_offset, tip_frame"]),
        ("joints", DELETE, ["arms.right.joints", "missing required key"]),
    ],
)
def test_bad_arm_values(tmp_path, key, value, words):
    message(tmp_path, changed(pr2_mapping(), **{f"arms__right__{key}": value}), PresetError, *words)


def test_duplicate_joint(tmp_path):
    spec = pr2_mapping()
    spec["arms"]["right"]["joints"][3] = spec["arms"]["right"]["joints"][1]
    message(tmp_path, spec, PresetError, "arms.right.joints[3]", "'r_shoulder_lift_joint' is listed twice")


def test_arm_joint_also_fixed(tmp_path):
    spec = changed(pr2_mapping(), fixed_joints={"torso_lift_joint": 0.15, "r_elbow_flex_joint": -1.0})
    message(tmp_path, spec, PresetError, "arms.right.joints[3]", "also held in fixed_joints")


@pytest.mark.parametrize(
    "value,words",
    [
        ({"torso_lift_joint": "high"}, ["fixed_joints.torso_lift_joint", "string 'high'"]),
        ({"torso_lift_joint": math.nan}, ["fixed_joints.torso_lift_joint", "finite"]),
        ({"torso_lift_joint": math.inf}, ["fixed_joints.torso_lift_joint", "finite"]),
        ({"torso_lift_joint": True}, ["fixed_joints.torso_lift_joint", "boolean"]),
        ({7: 0.1}, ["fixed_joints.7", "expected a non-empty string as name, got 7"]),
        (["torso_lift_joint", 0.15], ["fixed_joints", "expected a mapping, got a list"]),
    ],
)
def test_bad_fixed_joints(tmp_path, value, words):
    message(tmp_path, changed(pr2_mapping(), fixed_joints=value), PresetError, *words)


@pytest.mark.parametrize("key,unit", [("footprint_radius", "[m]"), ("v_max", "[m/s]"), ("omega_max", "[rad/s]")])
def test_base_values_are_required_positive_finite(tmp_path, key, unit):
    message(tmp_path, changed(pr2_mapping(), **{key: DELETE}), PresetError, f"{key}: missing required key", unit)
    for bad, words in [
        (0, "> 0"),
        (-1.0, "> 0"),
        (math.inf, "finite"),
        (math.nan, "finite"),
        (True, "boolean"),
        ("fast", "string"),
    ]:
        message(tmp_path, changed(pr2_mapping(), **{key: bad}), PresetError, key, words)


def test_builtin_and_fixture_presets_give_the_base_values(pr2):
    text = (PRESET_DIR / "pr2.yaml").read_text()
    assert (pr2.v_max, pr2.omega_max) == (0.5, 1.0)
    # the real 0.67 m square base; the circumscribed radius stays available
    assert pr2.footprint.tolist() == [[0.335, 0.335], [-0.335, 0.335], [-0.335, -0.335], [0.335, -0.335]]
    assert pr2.footprint_radius == pytest.approx(math.hypot(0.335, 0.335))
    assert all(f"\n{k}:" in text for k in ("footprint", "v_max", "omega_max"))
    assert {"footprint_radius", "v_max", "omega_max"} <= set(armar6_spec())


@pytest.mark.parametrize(
    "spec,words",
    [
        ("", ["the file is empty"]),
        ("# only a comment\n", ["the file is empty"]),
        ("- name: pr2\n", ["expected a mapping, got a list"]),
        ("name: pr2\narms: [\n", ["invalid YAML at line 3, column 1"]),
        ("name: a\nname: b\n", ["invalid YAML at line 2, column 1", "duplicate key 'name'"]),
        (
            "name: pr2\nwheels: 4\n",
            ["wheels: unknown key; allowed keys: arms, base_frame, base_frame_parent, base_frame_xyz, fixed_joints"],
        ),
    ],
)
def test_bad_documents(tmp_path, spec, words):
    message(tmp_path, spec, PresetError, *words)


@pytest.mark.parametrize(
    "key,value,words",
    [
        ("arms", {}, ["arms: expected at least 1 entry, got 0"]),
        ("arms", ["right"], ["arms: expected a mapping, got a list"]),
        ("arms", {"right": ["r_shoulder_pan_joint"]}, ["arms.right: expected a mapping, got a list"]),
        ("arms", {None: {}}, ["arms.None: expected a non-empty string as name, got null"]),
        ("name", 6, ["name: expected a non-empty string, got 6"]),
        ("base_frame", None, ["base_frame: expected a non-empty string, got null"]),
        ("urdf", "missing.urdf", ["urdf: URDF file not found", "missing.urdf"]),
        ("urdf", "a\0b\nc", ["urdf: URDF file not found", "a\\x00b\\nc"]),
        ("srdf", "missing.srdf", ["srdf: SRDF file not found", "missing.srdf"]),
    ],
)
def test_bad_top_level_values(tmp_path, key, value, words):
    message(tmp_path, changed(pr2_mapping(), **{key: value}), PresetError, *words)


def test_mapping_is_checked_before_the_urdf(tmp_path):
    """A broken URDF is never parsed when the mapping already fails, and parse_preset needs no model."""
    (tmp_path / "bad.urdf").write_text("<robot")
    spec = changed(pr2_mapping(), urdf="bad.urdf", v_max=-1)
    message(tmp_path, spec, PresetError, "v_max")
    with pytest.raises(PresetError, match="^x.yaml: arms.right.home"):
        parse_preset(changed(spec, v_max=1, arms__right__home=[0]), tmp_path, "x.yaml")
    assert parse_preset(changed(spec, v_max=1), tmp_path, "x.yaml").urdf == tmp_path / "bad.urdf"


def test_urdf_that_does_not_load(tmp_path):
    (tmp_path / "bad.urdf").write_text("<robot name='r'><link name='l'/><joint")
    msg = message(tmp_path, changed(pr2_mapping(), urdf="bad.urdf"), RobotError, "urdf: URDF", "does not load")
    (tmp_path / "bad.urdf").write_bytes(b"<robot name='\xff'/>")
    message(tmp_path, changed(pr2_mapping(), urdf="bad.urdf"), RobotError, "urdf:", "not UTF-8")
    assert "bad.urdf" in msg


# a 0.6 x 0.4 m rectangle, clockwise, with the base frame 0.1 m behind its centre
RECTANGLE = [[0.4, 0.2], [0.4, -0.2], [-0.2, -0.2], [-0.2, 0.2]]


def test_footprint_polygon_is_stored_counter_clockwise_with_its_radius(tmp_path):
    from placement.robots import load_robot
    from placement.robots.footprint import inscribed_radius, signed_area

    robot = load_robot(write(tmp_path, changed(pr2_mapping(), footprint_radius=DELETE, footprint=RECTANGLE)))
    assert robot.footprint.shape == (4, 2) and signed_area(robot.footprint) > 0
    assert robot.footprint_radius == pytest.approx(math.hypot(0.4, 0.2))
    assert inscribed_radius(robot.footprint) == pytest.approx(0.2)


@pytest.mark.parametrize("value,words", [(RECTANGLE, ["footprint_radius", "exactly one of footprint_radius"])])
def test_footprint_and_radius_exclude_each_other(tmp_path, value, words):
    message(tmp_path, changed(pr2_mapping(), footprint=value), PresetError, *words)


@pytest.mark.parametrize(
    "value,words",
    [
        ([[0.3, 0.3], [-0.3, 0.3]], ["footprint", "at least 3"]),
        ([[0.3, 0.3], [-0.3, 0.3], [0.0]], ["footprint[2]", "expected 2"]),
        ([[0.3, 0.3], [-0.3, "a"], [0.0, -0.3]], ["footprint[1][1]", "number"]),
        ([[0.3, 0.3], [-0.3, -0.3], [0.3, -0.3], [-0.3, 0.3]], ["footprint", "crosses itself"]),
        ([[0.01, 0.01], [-0.01, 0.01], [-0.01, -0.01], [0.01, -0.01]], ["footprint", "area", "metres"]),
        ([[1.3, 0.3], [0.7, 0.3], [0.7, -0.3], [1.3, -0.3]], ["footprint", "origin (0, 0) is not inside"]),
        ([[0.3, 0.3], [0.3, 0.3], [-0.3, 0.0], [0.3, -0.3]], ["footprint[1]", "repeats"]),
        ("square", ["footprint", "expected a list"]),
    ],
)
def test_bad_footprints_are_one_line_errors(tmp_path, value, words):
    message(tmp_path, changed(pr2_mapping(), footprint_radius=DELETE, footprint=value), PresetError, *words)


def test_idle_configuration_defaults_to_home_and_is_checked(tmp_path, pr2):
    from placement.robots import load_robot

    assert np.allclose(pr2.arm("right").idle[:2], [-0.023593, 1.10728])  # the built-in PR2 tucks its arms
    plain = load_robot(write(tmp_path, pr2_mapping()))  # the round test copy gives no idle
    assert np.array_equal(plain.arm("right").idle, plain.arm("right").home)
    message(tmp_path, changed(pr2_mapping(), arms__right__idle=[0.0] * 6), PresetError, "arms.right.idle", "expected 7")
    message(
        tmp_path,
        changed(pr2_mapping(), arms__right__idle=[9.0] + [0.0] * 6),
        PresetError,
        "arms.right.idle[0]",
        "outside the limits",
    )
