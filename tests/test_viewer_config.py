"""The viewer draws the other arms where the collision check and the plan put them: at ``idle``."""

from __future__ import annotations

import numpy as np

import placement
from placement.viewer.robot_view import config_of


def test_the_other_arm_is_drawn_at_its_idle_pose():
    robot = placement.load_robot("pr2")
    left = robot.arm("left")
    assert left.idle is not None and not np.allclose(left.idle, left.home)  # the PR2's tucked arm
    q = config_of(robot, "right", robot.arm("right").home)
    model = robot.model
    for name, want in zip(left.joints, left.idle):
        joint = model.joints[model.getJointId(name)]
        i = joint.idx_q
        got = q[i] if joint.nq == 1 else np.arctan2(q[i + 1], q[i])  # continuous: (cos, sin)
        assert abs(got - want) < 1e-9
