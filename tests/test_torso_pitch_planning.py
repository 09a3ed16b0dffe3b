"""The planner with a revolute torso pitch (one map build per setting): a cup in the middle of a deep
table, out of the upright arm's reach, is picked with the torso leaning forward, checked by pinocchio FK
of the robot at the step's torso value and by the plan's own verification."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.deep_table import deep_table_scene
from support.fk import world_tcp
from support.pitch_torso import JOINT, SETTINGS, pitch_torso_maps

from placement.planning.planner import Planner

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def pitch(tmp_path_factory):
    """(robot, preset path, maps path): the arm at both settings, 0.1 m cells."""
    return pitch_torso_maps(tmp_path_factory.mktemp("pitch_planning"))


@pytest.mark.parametrize("method", ["global", "sequential"])
def test_a_far_cup_is_picked_leaning_forward(tmp_path, pitch, method):
    robot, preset, maps = pitch
    planner = Planner(deep_table_scene(tmp_path, preset, maps), method)
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
        arm_q = {j: s.joints[j] for j in robot.arm(s.arm).joints}
        T = world_tcp(robot, s.arm, {**arm_q, JOINT: s.joints[JOINT]}, s.base)
        target = np.asarray(s.tcp[-1])
        assert np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01
        cos = np.clip((np.trace(T[:3, :3].T @ target[:3, :3]) - 1) / 2, -1, 1)
        assert math.degrees(math.acos(cos)) < 3
        # the same joints with the torso upright miss the target: the step's value matters
        if s.joints[JOINT] != 0.0:
            up = world_tcp(robot, s.arm, {**arm_q, JOINT: 0.0}, s.base)
            assert np.linalg.norm(up[:3, 3] - target[:3, 3]) > 0.1
