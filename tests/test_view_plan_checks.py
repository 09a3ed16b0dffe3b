"""`placement view SCENE --plan PLAN.json` shows a plan only if it was made for that scene and its
robot: scene and robot names, arms and their joints, step actions and targets, joints of the robot
within the URDF limits (the fixed joints too, at the step's values), the TCP where the joints put it
(with the step's torso)."""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import pytest

from placement.scene import load_scene
from placement.viewer.plan_file import PlanFileError, load_checked_plan

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "table_clearing.yaml"


@pytest.fixture(scope="module")
def plan_doc(maps_dir) -> dict:
    import placement

    doc = placement.Planner(EXAMPLE, "sequential", maps_dir).plan().to_json()
    assert doc["status"] == "ok" and len(doc["steps"]) == 6
    return doc


@pytest.fixture(scope="module")
def scene():
    return load_scene(EXAMPLE)


def first_ok(doc) -> dict:
    return next(s for s in doc["steps"] if s.get("status", "ok") == "ok")


def _elbow_100(d):
    s = first_ok(d)
    s["joints"][f"{s['arm'][0]}_elbow_flex_joint"] = 100.0


def _pose_elbow_100(d):
    s = first_ok(d)
    s["poses"][0]["joints"][f"{s['arm'][0]}_elbow_flex_joint"] = 100.0


def _other_target(d):
    d["steps"][0]["target"] = "mug_7"


def _swap_steps(d):
    d["steps"][0], d["steps"][2] = d["steps"][2], d["steps"][0]


def _other_action(d):
    d["steps"][1]["action"] = "pick"


def _stop_short(d):
    del d["steps"][3:]


def _too_many(d):
    d["steps"].append(copy.deepcopy(d["steps"][-1]) | {"step": 6})


def _unknown_joint(d):
    first_ok(d)["joints"]["knee_joint"] = 0.0


def _fixed_joint(d):
    first_ok(d)["joints"]["torso_lift_joint"] = 0.3  # within the limits: the step's torso, 15 cm above the TCP


def _fixed_joint_outside(d):
    first_ok(d)["joints"]["torso_lift_joint"] = 0.5


def _moved_tcp(d):
    first_ok(d)["tcp"][-1][2] += 0.3


def _moved_base(d):
    s = first_ok(d)
    s["base"][1] += 0.5


def _base_outside(d):
    first_ok(d)["base"] = [50.0, 4.0, 0.0]


def _arm_joints(d):
    arm = next(iter(d["robot"]["arms"]))
    d["robot"]["arms"][arm]["joints"] = d["robot"]["arms"][arm]["joints"][::-1]


def _long_scene_name(d):
    d["scene"] = "s" * 1_000_000


@pytest.mark.parametrize(
    "mutate, words",
    [
        (lambda d: d.update(scene="kitchen"), ["scene", "'kitchen'", "table_clearing"]),
        (lambda d: d.pop("scene"), ["does not name its scene"]),
        (lambda d: d["robot"].update(name="tiago"), ["robot.name", "tiago"]),
        (_other_target, ["steps[0]", "mug_7", "pick 'cup_1'"]),
        (_swap_steps, ["steps[0].step", "expected 0"]),
        (_other_action, ["steps[1]", "place 'place_a'"]),
        (_stop_short, ["stops after 3 of the task's 6 steps"]),
        (_too_many, ["7 steps", "has 6"]),
        (_elbow_100, ["elbow_flex_joint", "100", "outside the URDF limits"]),
        (_pose_elbow_100, ["poses[0].joints", "elbow_flex_joint", "outside the URDF limits"]),
        (_unknown_joint, ["knee_joint", "no such joint"]),
        (_fixed_joint, ["steps[0].joints", "TCP 15.0 cm", "torso_lift_joint 0.3)"]),
        (_fixed_joint_outside, ["steps[0].joints.torso_lift_joint", "0.5 is outside the URDF limits [0, 0.31]"]),
        (_moved_tcp, ["TCP", "cm", "another robot or scene"]),
        (_moved_base, ["TCP", "cm"]),
        (_base_outside, ["base", "outside the scene's bounds"]),
        (_arm_joints, ["robot.arms", "another robot model"]),
        (_long_scene_name, ["1,000,000 characters"]),
    ],
)
def test_a_plan_for_another_scene_or_robot_is_refused(plan_doc, scene, tmp_path, mutate, words):
    assert_refused(plan_doc, mutate, scene, tmp_path, words)


def assert_refused(plan_doc, mutate, scene, tmp_path, words) -> None:
    """The plan document mutated by ``mutate`` is refused in one line naming the file and ``words``."""
    doc = copy.deepcopy(plan_doc)
    mutate(doc)
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(PlanFileError) as e:
        load_checked_plan(path, scene)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(path)) and len(msg) < 1000, msg
    for w in words:
        assert w in msg, (w, msg)


def test_the_plan_of_the_scene_passes(plan_doc, scene, tmp_path):
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan_doc))
    steps = load_checked_plan(path, scene)
    assert [s.target for s in steps] == [s["target"] for s in plan_doc["steps"]]
    # an infeasible plan ends at its infeasible step
    doc = copy.deepcopy(plan_doc)
    doc["steps"][3] = {"step": 3, "action": "place", "target": "place_b", "status": "infeasible", "reason": "x"}
    del doc["steps"][4:]
    path.write_text(json.dumps(doc))
    assert [s.ok for s in load_checked_plan(path, scene)] == [True, True, True, False]


def test_a_fifo_is_not_read(scene, tmp_path):
    import os

    fifo = tmp_path / "plan.fifo"
    os.mkfifo(fifo)
    with pytest.raises(PlanFileError, match="not a regular file"):
        load_checked_plan(fifo, scene)


def run(*args, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "placement.cli.main", *args], capture_output=True, text=True, timeout=timeout, cwd=ROOT
    )


@pytest.mark.slow
def test_view_refuses_in_one_line_and_serves_the_right_plan(plan_doc, tmp_path):
    doc = copy.deepcopy(plan_doc)
    _elbow_100(doc)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    p = run("view", str(EXAMPLE), "--plan", str(bad), "--port", "0")
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "outside the URDF limits" in lines[0], p.stderr
    good = tmp_path / "good.json"
    good.write_text(json.dumps(plan_doc))
    p = run("view", str(EXAMPLE), "--plan", str(good), "--port", "0", "--json", "--timeout", "0.5", "-q")
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["url"].startswith("http://127.0.0.1:")


def first_place(d) -> dict:
    return next(s for s in d["steps"] if s.get("status", "ok") == "ok" and s["action"] == "place")


def _conf(d, joint, value):
    s = first_ok(d)
    name = joint.format(a=s["arm"][0])
    s["configuration"]["joints"][name] = value


@pytest.mark.parametrize(
    "mutate, words",
    [
        (
            lambda d: _conf(d, "{a}_elbow_flex_joint", -0.2),
            ["configuration.joints", "elbow_flex_joint", "but the step's joints give"],
        ),
        (
            lambda d: first_ok(d)["configuration"]["base"].update(y=first_ok(d)["base"][1] + 1.0),
            ["configuration.base", "is not the step's base"],
        ),
        (
            lambda d: first_ok(d)["configuration"].update(arm="left" if first_ok(d)["arm"] == "right" else "right"),
            ["configuration.arm"],
        ),
        (
            lambda d: _conf(d, "torso_lift_joint", 0.3),
            ["configuration.joints.torso_lift_joint", "but the step's joints give"],
        ),
        (lambda d: _conf(d, "knee_joint", 0.0), ["configuration.joints", "has no joint 'knee_joint'"]),
        (
            lambda d: _conf(d, "r_gripper_l_finger_joint", 50.0),
            ["r_gripper_l_finger_joint", "50 is outside the URDF limits"],
        ),
        (lambda d: _conf(d, "head_tilt_joint", 3.0), ["head_tilt_joint", "outside the URDF limits"]),
        (lambda d: _conf(d, "head_pan_joint", 1e308), ["head_pan_joint", "outside the URDF limits"]),
        (lambda d: _conf(d, "head_pan_joint", "0.1"), ["head_pan_joint", "must be a finite number"]),
        (
            lambda d: first_place(d)["placed_pose"].__setitem__(0, first_place(d)["placed_pose"][0] + 1.0),
            ["placed_pose", "100.0 cm"],
        ),
        (lambda d: first_place(d).pop("placed_pose"), ["placed_pose", "must say where"]),
        (
            lambda d: next(iter(d["robot"]["arms"].values())).update(tcp_offset=[0, 0, 0.1, 0, 0, 0, 1]),
            ["tcp_offset", "from robot 'pr2''s"],
        ),
        (lambda d: first_ok(d).update(trajectory="nowhere"), ["trajectory", "'nowhere' is not one of the scene's"]),
    ],
)
def test_a_plan_that_disagrees_with_itself_is_refused(plan_doc, scene, tmp_path, mutate, words):
    """What a viewer draws, a user believes: a step's configuration, trajectory and placed pose must be
    the step's and the scene's."""
    assert_refused(plan_doc, mutate, scene, tmp_path, words)


def test_a_plan_for_a_same_named_scene_whose_cup_stood_elsewhere_is_refused(plan_doc, scene, tmp_path):
    import dataclasses

    moved = tuple(
        dataclasses.replace(o, position=o.position + [0.3, 0.0, 0.0]) if o.name == "cup_1" else o for o in scene.objects
    )
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan_doc))
    assert len(load_checked_plan(path, scene)) == 6  # the scene it was made for: shown
    with pytest.raises(PlanFileError, match=r"steps\[0\]\.tcp\[0\]: 30\.0 cm and 0\.0 deg from trajectory"):
        load_checked_plan(path, dataclasses.replace(scene, objects=moved))


def test_a_plan_file_with_a_key_given_twice_is_refused(plan_doc, scene, tmp_path):
    text = json.dumps(plan_doc)
    path = tmp_path / "plan.json"
    path.write_text(text.replace('"scene": ', '"scene": "other", "scene": ', 1))
    with pytest.raises(PlanFileError, match="duplicate key 'scene'"):
        load_checked_plan(path, scene)
