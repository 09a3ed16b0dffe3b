"""The version 2 kitchen example planned end to end (small test maps), every step checked by pinocchio FK."""

from __future__ import annotations

import numpy as np

from placement.planning import Planner
from placement.planning.verify import base_matrix
from test_scene_v2 import KITCHEN


def test_kitchen_plans_with_reach_side_grasps_and_orientations(maps_dir, pr2):
    planner = Planner(KITCHEN, maps=maps_dir)
    result = planner.plan()
    assert result.ok, [s.reason for s in result.steps if s.status != "ok"]
    steps = result.steps
    assert [(s.action, s.target) for s in steps] == [
        ("reach", "drawer_left,drawer_right"), ("pick", "cup"), ("place", "side_table_spot"), ("pick", "can_lying"),
        ("place", "counter_spot"), ("pick", "juice"), ("place", "table_spot")]
    assert steps[0].grasp in ("drawer_left", "drawer_right")
    assert steps[2].grasp in ("place-orientation0", "place-orientation1")
    assert steps[5].grasp.startswith("side-")  # the shelf is too high for a top grasp
    for s in steps:
        want = planner.scene.trajectory(s.grasp).matrices() if s.action == "reach" else None
        if want is not None:
            np.testing.assert_allclose(np.asarray(s.tcp), want, atol=1e-12)
        arm = pr2.arm(s.arm)
        q = np.array([s.joints[j] for j in arm.joints])
        T = base_matrix(*s.base) @ pr2.tcp_pose(s.arm, q)
        target = np.asarray(s.tcp[-1])
        assert np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01
        assert np.trace(T[:3, :3].T @ target[:3, :3]) > 1 + 2 * np.cos(np.radians(3))
