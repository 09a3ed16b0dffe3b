"""The plan a robot can execute: every planned step's ``configuration`` gives the base pose in the
named base frame and every actuated joint (the moving arm's IK solution, the fixed joints, the
idle arms as the collision check assumed them), and pinocchio FK of it puts the TCP on the poses.

The references here are independent of the planner: the actuated joints come from the URDF text
(joints of one degree of freedom that mimic none), the forward kinematics from pinocchio on the
model with the base placed by hand, the tool offset from the plan document's ``robot`` block."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from support.cli import run
from support.fk import model_fk

from placement.planning import Planner
from placement.planning.problems.steps import task_steps
from placement.planning.settings import PlannerConfig
from placement.robots import pose_to_matrix
from placement.scene import load_scene

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "table_clearing.yaml"
#: [m], [rad]: the tolerances the planner's IK verified each pose to
POS_TOL, ROT_TOL = PlannerConfig().ik_pos_tol_m + 1e-9, PlannerConfig().ik_rot_tol_rad + 1e-9


@pytest.fixture(scope="module")
def doc(maps_dir):
    """The example scene's plan as ``placement query --json`` prints it."""
    p = run("query", str(EXAMPLE), "--maps", str(maps_dir), "--json", "-q")
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


@pytest.fixture(scope="module")
def planned(maps_dir):
    """(planner, result) of the example scene, planned in this process."""
    scene = load_scene(EXAMPLE)
    planner = Planner(
        replace(scene, planner={**scene.planner, "ik_budget_ms": 60000.0, "time_budget_s": 3600.0}), maps=maps_dir
    )
    return planner, planner.plan()


def urdf_actuated(robot) -> list[str]:
    """The URDF's movable joints that mimic no other, by reading its XML (not the model's bookkeeping)."""
    root = ET.parse(robot.urdf_path).getroot()
    return [
        j.get("name")
        for j in root.iter("joint")
        if j.get("type") in ("revolute", "continuous", "prismatic") and j.find("mimic") is None
    ]


def world_tcp(robot, doc_robot, arm, joints, base) -> np.ndarray:
    """(4, 4) world TCP by pinocchio FK: every joint of ``joints`` set by name, the base frame placed
    at ``base`` {x, y, yaw}, the tool offset of the plan document."""
    model = robot.model
    data = model_fk(robot, joints)
    B = np.eye(4)
    c, s = math.cos(base["yaw"]), math.sin(base["yaw"])
    B[:2, :2] = [[c, -s], [s, c]]
    B[:2, 3] = base["x"], base["y"]
    info = doc_robot["arms"][arm]
    root = B @ np.linalg.inv(data.oMf[model.getFrameId(doc_robot["base_frame"])].homogeneous)
    return root @ data.oMf[model.getFrameId(info["tip_frame"])].homogeneous @ pose_to_matrix(info["tcp_offset"])


@pytest.mark.slow
def test_every_step_gives_every_actuated_joint(doc, pr2):
    assert doc["status"] == "ok" and len(doc["steps"]) == 6
    json.dumps(doc, allow_nan=False)  # strict JSON
    actuated = urdf_actuated(pr2)
    assert len(actuated) == 20  # torso, head 2, laser tilt, 2 x (7 arm + 1 gripper)
    for s in doc["steps"]:
        conf = s["configuration"]
        assert sorted(conf["joints"]) == sorted(actuated), s["step"]
        assert conf["base"] == {"frame": doc["robot"]["base_frame"], **dict(zip(("x", "y", "yaw"), s["base"]))}
        assert conf["base"]["frame"] == "base_footprint"
        # the moving arm at its IK solution of the last pose, the fixed joints per step as `joints`
        assert conf["arm"] == s["arm"] and conf["fixed_joints"] == ["torso_lift_joint"]
        assert {j: conf["joints"][j] for j in s["joints"]} == s["joints"]
        assert s["poses"][-1]["joints"] == {j: conf["joints"][j] for j in pr2.arm(s["arm"]).joints}
        assert conf["joints"]["torso_lift_joint"] == pr2.fixed_joints["torso_lift_joint"] == 0.15
        # the other arm tucked (its preset idle), holding nothing; the rest neutral
        for name, arm in conf["arms"].items():
            assert arm["joints"] == pr2.arm(name).joints
            if name == s["arm"]:
                assert arm["state"] == "moving"
                continue
            assert arm["state"] == "idle" and arm["holds"] is None
            got = np.array([conf["joints"][j] for j in arm["joints"]])
            np.testing.assert_allclose(got, pr2.arm(name).idle, rtol=0, atol=1e-12)
        named = set(s["joints"]) | {j for a in conf["arms"].values() for j in a["joints"]}
        assert {j: v for j, v in conf["joints"].items() if j not in named} == {
            "head_pan_joint": 0.0,
            "head_tilt_joint": 0.0,
            "l_gripper_l_finger_joint": 0.0,
            "laser_tilt_mount_joint": 0.0,
            "r_gripper_l_finger_joint": 0.0,
        }


def test_an_arm_holds_its_object_only_while_it_moves_it(doc, pr2):
    """The task's steps are pick/place pairs, each place right after its pick by the same arm: no
    step lies between a pick and its place, so no arm holds an object while another works (the
    planner does not hold two objects at once). A place's moving arm holds the object; a pick's
    holds nothing yet."""
    steps = task_steps(load_scene(EXAMPLE))
    assert all(s.action != "place" or s.pick == s.index - 1 for s in steps)
    assert [s.action for s in steps] == ["pick", "place"] * 3
    for s in doc["steps"]:
        arms = s["configuration"]["arms"]
        held = {name: a["holds"] for name, a in arms.items() if a["holds"] is not None}
        assert held == ({s["arm"]: s["object"]} if s["action"] == "place" else {}), s["step"]


def test_independent_fk_of_the_configuration_puts_the_tcp_on_every_pose(doc, pr2):
    worst = (0.0, 0.0)
    for s in doc["steps"]:
        conf = s["configuration"]
        for k, (pose, want) in enumerate(zip(s["poses"], s["tcp"])):
            joints = conf["joints"] | pose["joints"]  # along the trajectory only the moving arm changes
            T, W = world_tcp(pr2, doc["robot"], conf["arm"], joints, conf["base"]), pose_to_matrix(want)
            err = float(np.linalg.norm(T[:3, 3] - W[:3, 3]))
            ang = math.acos(float(np.clip((np.trace(T[:3, :3].T @ W[:3, :3]) - 1) / 2, -1, 1)))
            assert err <= POS_TOL and ang <= ROT_TOL, (s["step"], k, err, ang)
            worst = max(worst[0], err), max(worst[1], ang)
            # and exactly where the planner's own FK (the arm alone, base frame relative) puts it
            B = np.eye(4)
            B[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.0, conf["base"]["yaw"])
            B[:2, 3] = conf["base"]["x"], conf["base"]["y"]
            own = B @ pr2.tcp_pose(conf["arm"], [pose["joints"][j] for j in pr2.arm(conf["arm"]).joints])
            np.testing.assert_allclose(T, own, rtol=0, atol=1e-9)
    print(f"worst TCP error over the plan: {worst[0] * 1e3:.3g} mm, {worst[1]:.3g} rad")


def test_the_fk_fails_when_the_idle_arm_or_base_is_wrong(doc, pr2):
    """The FK above can fail: the torso raised moves the TCP, and the base turned does."""
    s = doc["steps"][0]
    conf = s["configuration"]
    ok = world_tcp(pr2, doc["robot"], conf["arm"], conf["joints"], conf["base"])
    raised = world_tcp(pr2, doc["robot"], conf["arm"], conf["joints"] | {"torso_lift_joint": 0.2}, conf["base"])
    np.testing.assert_allclose(raised[:3, 3] - ok[:3, 3], [0, 0, 0.05], atol=1e-9)
    turned = world_tcp(
        pr2, doc["robot"], conf["arm"], conf["joints"], conf["base"] | {"yaw": conf["base"]["yaw"] + 0.1}
    )
    assert np.linalg.norm(turned[:3, 3] - ok[:3, 3]) > 0.01


def test_the_plan_in_process_has_the_same_configuration(planned, doc):
    """``to_json()`` and the CLI give one document (timings apart)."""
    _, result = planned
    mine = result.to_json()
    assert [s["configuration"] for s in mine["steps"]] == [s["configuration"] for s in doc["steps"]]


def test_verify_checks_the_whole_configuration(planned, pr2):
    _, result = planned
    assert result.verify(pr2) == []
    s = result.steps[0]

    def problems(**changes):
        """verify's problems with the first step changed (the plan itself stays as it is)."""
        return replace(result, steps=[replace(s, **changes), *result.steps[1:]]).verify(pr2)

    # a step that holds its torso elsewhere: the configuration carries it, the FK sees the TCP move
    raised = replace(s, joints=s.joints | {"torso_lift_joint": 0.2})
    assert raised.configuration()["joints"]["torso_lift_joint"] == 0.2
    assert any("TCP off by 5.0 cm" in p for p in problems(joints=raised.joints))
    # the idle arm outside its limits
    other = next(a for a in s.resting.idle if a != s.arm)
    name = pr2.arm(other).joints[1]  # a shoulder lift, limited
    idle = {other: s.resting.idle[other] | {name: float(pr2.arm(other).upper[1]) + 0.1}}
    assert any(
        f"idle arm {other}: {name} outside their limits" in p for p in problems(resting=replace(s.resting, idle=idle))
    )
    # a joint left out, and a base frame the robot does not have
    other_joints = {j: v for j, v in s.resting.other.items() if j != "head_pan_joint"}
    assert any(
        "joints missing ['head_pan_joint']" in p for p in problems(resting=replace(s.resting, other=other_joints))
    )
    assert any(
        "base frame base_link, not base_footprint" in p
        for p in problems(resting=replace(s.resting, base_frame="base_link"))
    )
    assert result.verify(pr2) == []
