"""The planner with a revolute torso pitch (one map build per setting): a cup in the middle of a deep
table, out of the upright arm's reach, is picked with the torso leaning forward, checked by pinocchio FK
of the robot at the step's torso value and by the plan's own verification."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from support.fk import model_fk
from support.pitch_torso import JOINT, write_pitch_torso

import placement
from placement.maps.buildspec import TorsoSpec
from placement.maps.torso_builds import build_torso_maps
from placement.planning.planner import Planner

SETTINGS = (0.0, 0.6)  # [rad]: upright (the preset's) and leaning forward


@pytest.fixture(scope="module")
def pitch(tmp_path_factory):
    """(robot, preset path, maps path): the arm at both settings, 0.1 m cells."""
    folder = tmp_path_factory.mktemp("pitch_planning")
    preset = write_pitch_torso(folder / "robot")
    robot = placement.load_robot(preset)
    built = build_torso_maps(
        robot,
        "arm",
        torso=TorsoSpec(JOINT, SETTINGS),
        samples=200_000,
        seed=2,
        resolution=0.1,
        bins=(8, 5, 8),
        progress=False,
    )
    return robot, preset, placement.save_maps(folder / "maps", robot, built)


def _scene(tmp_path, preset, maps) -> str:
    """A 1.2 m deep table with the cup in its middle: the base (0.3 m radius) stays 0.9 m or more from
    the cup, which the upright arm (its shoulder 1.3 m up, 0.82 m long) cannot span at 0.8 m height; a
    narrow stand to put it on."""
    scene = {
        "version": 1,
        "resolution": 0.05,
        "bounds": [0.0, 0.0, 6.0, 5.0],
        "robot": {"preset": str(preset), "start": [1.0, 4.0, 0.0]},
        "maps": str(maps),
        "obstacles": [
            {"name": "table", "box": {"center": [3.0, 2.5, 0.375], "size": [1.2, 1.2, 0.75]}, "table": True},
            {"name": "stand", "box": {"center": [1.0, 1.0, 0.4], "size": [0.3, 0.3, 0.8]}, "table": True},
        ],
        "objects": [{"name": "cup", "position": [3.0, 2.5, 0.8], "yaw": 0.4, "size": [0.06, 0.06, 0.1]}],
        "place_locations": [{"name": "spot", "position": [1.0, 1.0, 0.85]}],
        "task": [{"pick": "cup", "place": "spot"}],
        "planner": {"threshold": 0.01, "yaw_steps": 40},
    }
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    return str(path)


def _planar(x: float, y: float, yaw: float) -> np.ndarray:
    B = np.eye(4)
    B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    B[:2, 3] = (x, y)
    return B


@pytest.mark.parametrize("method", ["global", "sequential"])
def test_a_far_cup_is_picked_leaning_forward(tmp_path, pitch, method):
    robot, preset, maps = pitch
    planner = Planner(_scene(tmp_path, preset, maps), method)
    problems = planner.context.problems
    assert {o.torso for o in problems.options(0)} == set(SETTINGS)
    # upright, no placement keeps the threshold for the pick: only leaning reaches the cup
    upright = [o for o in problems.options(0) if o.torso == 0.0]
    assert max(float(o.value.max(initial=0.0)) for o in upright) < planner.context.threshold("arm")
    result = planner.plan()
    pick = result.steps[0]
    assert all(s.ok for s in result.steps), [s.reason for s in result.steps]
    assert pick.joints[JOINT] == 0.6
    assert result.verify(robot) == []
    for s in result.steps:  # pinocchio FK of the robot with the torso at the step's value
        a = robot.arm(s.arm)
        data = model_fk(robot, {**{j: s.joints[j] for j in a.joints}, JOINT: s.joints[JOINT]})
        base = data.oMf[robot.model.getFrameId(robot.base_frame)]
        tip = data.oMf[robot.model.getFrameId(a.tip_frame)]
        T = _planar(*s.base) @ (base.inverse() * tip).homogeneous @ a.tcp_offset
        target = np.asarray(s.tcp[-1])
        assert np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01
        cos = np.clip((np.trace(T[:3, :3].T @ target[:3, :3]) - 1) / 2, -1, 1)
        assert math.degrees(math.acos(cos)) < 3
        # the same joints with the torso upright miss the target: the step's value matters
        if s.joints[JOINT] != 0.0:
            data = model_fk(robot, {**{j: s.joints[j] for j in a.joints}, JOINT: 0.0})
            up = _planar(*s.base) @ (base.inverse() * data.oMf[robot.model.getFrameId(a.tip_frame)]).homogeneous
            assert np.linalg.norm((up @ a.tcp_offset)[:3, 3] - target[:3, 3]) > 0.1
