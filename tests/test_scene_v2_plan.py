"""Version 2 scenes with the small test maps: the kitchen example planned end to end, every step checked
by pinocchio FK, and side grasps' inverse reachability confirmed by IK."""

from __future__ import annotations

import numpy as np
import pytest
from support.budgets import unbudgeted
from support.scenes import KITCHEN

from placement.maps.opening import open_map
from placement.planning import Planner
from placement.planning.problems.grasps import box_grasps
from placement.planning.problems.manipulation import base_yaws, manipulation_map
from placement.planning.verification.ik import base_matrix, trajectory_ik
from placement.scene import SceneObject, load_scene
from placement.scene.navgrid import NavGrid


@pytest.mark.slow
def test_kitchen_plans_with_reach_side_grasps_and_orientations(maps_dir, pr2):
    # no time budget: the plan must not depend on the machine's load
    scene = load_scene(KITCHEN)
    planner = Planner(unbudgeted(scene), maps=maps_dir)
    result = planner.plan()
    assert result.ok, [s.reason for s in result.steps if s.status != "ok"]
    steps = result.steps
    assert [(s.action, s.target) for s in steps] == [
        ("reach", "drawer_left,drawer_right"),
        ("pick", "cup"),
        ("place", "side_table_spot"),
        ("pick", "can_lying"),
        ("place", "counter_spot"),
        ("pick", "juice"),
        ("place", "table_spot"),
    ]
    assert steps[0].grasp in ("drawer_left", "drawer_right")
    # the cup is set down upright at one of the two allowed yaws, held as it was picked
    assert steps[2].trajectory in (f"{steps[1].grasp}@orientation0", f"{steps[1].grasp}@orientation1")
    assert steps[5].grasp.startswith("side-")  # the shelf is too high for a top grasp
    for pick, place in zip(steps[1::2], steps[2::2]):
        assert (place.arm, place.grasp, place.object) == (pick.arm, pick.grasp, pick.target)
    assert result.verify(pr2) == []
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


def test_side_grasp_irms_are_confirmed_by_ik(maps_dir, pr2):
    """For side grasps in several directions and heights, the map's best placements are reachable:
    IK (pinocchio) succeeds at one of the 5 best, its FK on the face centre."""
    rmap = open_map(maps_dir, "right", pr2)
    nav = NavGrid((-1.5, -1.5), 0.05, (60, 60))
    yaws = base_yaws(40)
    xs, ys = nav.centres()
    for yaw, height in ((0.0, 0.8), (1.0, 0.95), (2.0, 1.05), (-2.5, 0.9)):
        o = SceneObject("o", [0.0, 0.0, height], yaw, [0.06, 0.07, 0.15])
        (c,) = [c for c in box_grasps(o.pose, o.size) if c.name == "side--x"]
        value, yaw_index = manipulation_map(rmap, c.poses, nav, yaws)
        assert (value > 0).sum() > 100
        found = False
        for flat in np.argsort(-value.ravel())[:5]:
            iy, ix = np.unravel_index(flat, value.shape)
            base = (float(xs[ix]), float(ys[iy]), float(yaws[yaw_index[iy, ix]]))
            ik = trajectory_ik(pr2, "right", c.poses, base, pr2.arm("right").home)
            if ik.ok:
                T = base_matrix(*base) @ pr2.tcp_pose("right", ik.qs[-1])
                assert np.linalg.norm(T[:3, 3] - c.poses[-1, :3, 3]) < 3e-3
                found = True
                break
        assert found, (yaw, height)
