"""Robot presets against their URDF model (joints, frames, limits, links, the model cache) and the numeric
wrappers that refuse NaN: every bad preset is one PresetError/RobotError line naming the file and the key path."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from support.presets import changed, message, pr2_mapping, write

import placement
from placement.errors import FrameNotFound, JointNotFound, PlacementError, PresetError
from placement.kernels.ik import dls_attempt
from placement.kinematics.ik import solve_ik

# -- against the model ---------------------------------------------------------------------------------


def test_unknown_joint_and_frame_name_close_names(tmp_path):
    spec = pr2_mapping()
    spec["arms"]["right"]["joints"][2] = "r_upper_arm_rol_joint"
    msg = message(tmp_path, spec, JointNotFound, "arms.right.joints[2]", "close names: r_upper_arm_roll_joint")
    assert "'r_upper_arm_rol_joint' not found in robot 'pr2'" in msg
    message(
        tmp_path,
        changed(pr2_mapping(), arms__left__tip_frame="l_gripper_tool_fram"),
        FrameNotFound,
        "arms.left.tip_frame",
        "close names: l_gripper_tool_frame",
    )
    message(tmp_path, changed(pr2_mapping(), base_frame="base_foot"), FrameNotFound, "base_frame: frame 'base_foot'")
    message(
        tmp_path,
        changed(pr2_mapping(), fixed_joints={"torso_lift": 0.1}),
        JointNotFound,
        "fixed_joints.torso_lift",
        "torso_lift_joint",
    )


@pytest.mark.parametrize(
    "index,joint,words",
    [
        (0, "l_shoulder_pan_joint", ["is not on the chain from base frame 'base_footprint' to tip frame"]),
        (0, "head_pan_joint", ["is not on the chain"]),
        (6, "r_gripper_r_finger_joint", ["is a mimic joint (it follows 'r_gripper_l_finger_joint')"]),
        (0, "base_footprint_joint", ["is a fixed joint in the URDF"]),
        (6, "r_gripper_palm_joint", ["is a fixed joint in the URDF"]),
    ],
)
def test_joint_off_the_chain_fixed_or_mimic(tmp_path, index, joint, words):
    spec = pr2_mapping()
    spec["arms"]["right"]["joints"][index] = joint
    message(tmp_path, spec, PresetError, f"arms.right.joints[{index}]", f"'{joint}'", *words)


def test_joints_out_of_order_or_moving_the_base(tmp_path):
    spec = pr2_mapping()
    joints = spec["arms"]["right"]["joints"]
    joints[1], joints[2] = joints[2], joints[1]
    message(tmp_path, spec, PresetError, "arms.right.joints[2]", "listed from the base to the tip")
    spec = changed(pr2_mapping(), base_frame="r_upper_arm_link")
    message(tmp_path, spec, PresetError, "arms.right.joints[0]", "moves the base frame 'r_upper_arm_link'")


def test_home_outside_the_limits(tmp_path):
    spec = changed(pr2_mapping(), arms__right__home=[-0.5, 0.3, -1.5, 0.5, 0.0, -0.8, 0.0])
    message(tmp_path, spec, PresetError, "arms.right.home[3]", "0.5 is outside the limits [", "'r_elbow_flex_joint'")
    # a continuous joint (forearm roll) takes any finite value
    spec = changed(pr2_mapping(), arms__right__home=[-0.5, 0.3, -1.5, -1.6, 7.0, -0.8, -9.0])
    assert placement.load_robot(write(tmp_path, spec)).arm("right").home[4] == 7.0


def test_fixed_joint_outside_its_limits(tmp_path):
    msg = message(
        tmp_path,
        changed(pr2_mapping(), fixed_joints={"torso_lift_joint": 0.5}),
        PresetError,
        "fixed_joints.torso_lift_joint: 0.5 is outside the URDF limits [0, 0.3",
    )
    assert "torso_lift_joint" in msg
    assert placement.load_robot(write(tmp_path, changed(pr2_mapping(), fixed_joints={"torso_lift_joint": 0.0})))


@pytest.mark.slow
def test_cli_prints_one_error_line(tmp_path):
    """Through the command line: exit 2, one `error:` line, nothing written."""
    path = write(tmp_path, changed(pr2_mapping(), arms__right__home=[0, 0, math.nan, 0, 0, 0, 0]))
    proc = subprocess.run(
        [sys.executable, "-m", "placement.cli.main", "maps", "build", "--robot", path, "--out", str(tmp_path / "m")],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert proc.stderr.strip() == f"error: {path}: arms.right.home[2]: expected a finite number, got nan"
    assert not (tmp_path / "m").exists()


# -- the URDF model cache ----------------------------------------------------------------------------


def test_model_cache_follows_the_urdf_bytes(tmp_path):
    from placement.robots.spec import resolve_path

    urdf = tmp_path / "pr2.urdf"
    text = resolve_path(pr2_mapping()["urdf"], tmp_path).read_text()
    urdf.write_text(text)
    path = write(tmp_path, changed(pr2_mapping(), urdf="pr2.urdf"))
    a, b = placement.load_robot(path), placement.load_robot(path)
    assert a.model is not b.model and a.urdf_sha256 == b.urdf_sha256
    assert a.arm("right").upper[3] == b.arm("right").upper[3]
    old = '<joint name="r_elbow_flex_joint" type="revolute">'
    assert text.count(old) == 1
    head, tail = text.split(old)
    urdf.write_text(head + old + tail.replace('upper="0.00"', 'upper="0.25"', 1))
    c = placement.load_robot(path)
    assert c.urdf_sha256 != a.urdf_sha256 and c.arm("right").upper[3] == 0.25 != a.arm("right").upper[3]


def test_file_preset_equals_builtin(tmp_path, pr2):
    robot = placement.load_robot(write(tmp_path, pr2_mapping()))
    for name in ("right", "left"):
        a, b = robot.arm(name), pr2.arm(name)
        for f in ("home", "lower", "upper", "continuous", "velocity", "tcp_offset"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
        for f in ("link_T", "axis", "kind", "tip_T"):
            np.testing.assert_array_equal(getattr(a.chain, f), getattr(b.chain, f))
    assert robot.fingerprint == pr2.fingerprint


# -- numeric wrappers refuse NaN -----------------------------------------------------------------------


def test_ik_refuses_non_finite_input(pr2):
    T = pr2.tcp_pose("right", pr2.arm("right").home)
    for kwargs in (
        {"q_seed": [math.nan] * 7},
        {"q_seed": ["a"] * 7},
        {"pos_tol": math.nan},
        {"rot_tol": math.inf},
        {"max_iter": 0},
        {"seeds": 2.0},
        {"rng_seed": -1},
    ):
        with pytest.raises(PlacementError, match=next(iter(kwargs))):
            solve_ik(pr2, "right", T, **kwargs)
    with pytest.raises(PlacementError, match="IK target"):
        solve_ik(pr2, "right", np.full((4, 4), math.nan))
    assert solve_ik(pr2, "right", T).success


def test_ik_kernel_survives_nan(pr2):
    """The guard in the rotation log: a NaN start ends as a failed attempt, not a ZeroDivisionError."""
    a = pr2.arm("right")
    ch = a.chain
    q = a.home.copy()
    q[0] = math.nan
    ok, *_ = dls_attempt(
        q,
        np.eye(4),
        a.lower,
        a.upper,
        a.continuous,
        ch.link_T,
        ch.axis,
        ch.kind,
        ch.tip_T,
        1e-3,
        1e-2,
        50,
        1e-3,
        0.4,
        20,
    )
    assert not ok


def test_manipulability_refuses_non_finite_input(pr2):
    q = pr2.arm("right").home.copy()
    assert placement.extended_manipulability(pr2, "right", q) > 0
    q[2] = math.nan
    with pytest.raises(PlacementError, match="finite"):
        placement.extended_manipulability(pr2, "right", q)
    with pytest.raises(PlacementError, match="row_factors"):
        placement.extended_manipulability(pr2, "right", pr2.arm("right").home, row_factors=np.full((6, 2), np.inf))


# -- links named by ignore_collisions --------------------------------------------------------------


def test_ignore_collisions_names_two_different_links(tmp_path):
    pair = ["r_wrist_roll_link", "r_forearm_link"]
    robot = placement.load_robot(write(tmp_path, changed(pr2_mapping(), ignore_collisions=[pair, pair[::-1]])))
    assert robot.ignore_collisions == {frozenset(pair)}
    assert placement.load_robot(write(tmp_path, pr2_mapping())).ignore_collisions == frozenset()
    msg = message(
        tmp_path,
        changed(pr2_mapping(), ignore_collisions=[pair, ["r_wrist_rol_link", "base_link"]]),
        FrameNotFound,
        "ignore_collisions[1][0]: link 'r_wrist_rol_link' not found in robot 'pr2'",
        "close names: r_wrist_roll_link",
    )
    assert "frame" not in msg
    # a joint or a frame that is no link is no link
    message(
        tmp_path,
        changed(pr2_mapping(), ignore_collisions=[["r_wrist_roll_joint", "base_link"]]),
        FrameNotFound,
        "ignore_collisions[0][0]: link 'r_wrist_roll_joint'",
    )


@pytest.mark.parametrize(
    "value,words",
    [
        ([["base_link", "base_link"]], ["ignore_collisions[0]: a pair of the same link 'base_link'"]),
        ([["base_link"]], ["ignore_collisions[0]: expected 2 link names [link_a, link_b], got 1"]),
        ([["base_link", 3]], ["ignore_collisions[0][1]: expected a non-empty string"]),
        ("base_link", ["ignore_collisions: expected a list of link pairs"]),
        ([["a", "b", "c"]], ["expected 2 link names"]),
    ],
)
def test_bad_ignore_collisions(tmp_path, value, words):
    message(tmp_path, changed(pr2_mapping(), ignore_collisions=value), PresetError, *words)


def test_mimic_joints_are_the_urdfs_and_no_actuated_joint(pr2):
    """The robot's mimic joints are those its URDF declares (against a plain ElementTree reading of the
    file), and the configuration's actuated joints leave them out (the PR2's finger joints follow one)."""
    import xml.etree.ElementTree as ET

    from placement.planning.verification.configuration import actuated_joints

    root = ET.parse(pr2.urdf_path).getroot()
    want = {j.get("name") for j in root.iter("joint") if j.find("mimic") is not None}
    assert want and pr2.mimic_joints == want
    actuated = actuated_joints(pr2)
    assert not set(actuated) & want
    model = pr2.model
    one_dof = {model.names[j] for j in range(1, model.njoints) if model.joints[j].nv == 1}
    assert set(actuated) == one_dof - want
