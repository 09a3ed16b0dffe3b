"""Generated top and side grasps of boxes in any orientation, object-frame grasps, place orientations and
reach steps, checked against pinocchio (SE3, quaternions, FK of IK solutions) rather than our own code."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from support.scenes import ON_SIDE, v2_doc

from placement.kernels.grid import zyx_angles
from placement.kinematics.ik import solve_ik
from placement.planning.problems.grasps import GRIPPER_OPENING, SIDE_TILT, box_grasps, top_grasps
from placement.planning.problems.steps import object_grasps, step_candidates, task_steps
from placement.planning.settings import PlannerConfig
from placement.planning.verification.ik import base_matrix
from placement.scene import SceneObject, Trajectory, parse_scene


def _se3(position, q) -> pin.SE3:
    return pin.XYZQUATToSE3(np.array([*position, *q], dtype=float))


def _random_quaternion(rng) -> np.ndarray:
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def test_object_frame_grasps_are_their_world_transform():
    rng = np.random.default_rng(7)
    for _ in range(20):
        q_obj, pos = _random_quaternion(rng), rng.uniform(-2, 2, 3)
        poses = np.array([[*rng.uniform(-0.2, 0.2, 3), *_random_quaternion(rng)] for _ in range(3)])
        o = SceneObject("o", pos, 0.0, [0.1, 0.1, 0.1], q_obj, (Trajectory("mine", poses),))
        (c,) = object_grasps(o, 2)
        assert c.name == "mine"
        for k in range(3):
            expected = (_se3(pos, q_obj) * _se3(poses[k, :3], poses[k, 3:])).homogeneous
            np.testing.assert_allclose(c.poses[k], expected, atol=1e-12)


def test_upright_top_grasps_are_those_of_version_1():
    o = SceneObject("o", [1.0, 2.0, 0.8], 0.7, [0.04, 0.10, 0.12])
    v1 = top_grasps(o.position, o.yaw, o.size)
    assert [c.name for c in object_grasps(o, 1)] == ["top", "top-flipped"]
    v2 = object_grasps(o, 2)
    for a, b in zip(v1, v2[:2]):
        assert a.name == b.name
        np.testing.assert_allclose(a.poses, b.poses, atol=1e-12)


def test_side_grasps_of_an_upright_box():
    yaw, size = 0.4, np.array([0.06, 0.08, 0.16])
    o = SceneObject("o", [0.6, -0.2, 0.9], yaw, size)
    grasps = {c.name: c.poses for c in box_grasps(o.pose, o.size)}
    assert set(grasps) == {"side-+x", "side--x", "side-+y", "side--y", "top", "top-flipped"}
    R = pin.Quaternion(np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])).matrix()  # x, y, z, w
    for name, poses in grasps.items():
        if not name.startswith("side"):
            continue
        m, sign = "xyz".index(name[-1]), 1.0 if name[-2] == "+" else -1.0
        normal = sign * R[:, m]
        np.testing.assert_allclose(poses[1, :3, 3], o.position + normal * size[m] / 2, atol=1e-12)
        np.testing.assert_allclose(poses[1, :3, 2], -normal, atol=1e-12)  # horizontal, into the face
        np.testing.assert_allclose(poses[0, :3, 3], poses[1, :3, 3] + 0.10 * normal, atol=1e-12)
        closing = poses[1, :3, 1]
        assert math.asin(closing[2]) == pytest.approx(SIDE_TILT)
        assert abs(closing @ normal) < 1e-12
        # ZYX pitch 80 degrees: away from the gimbal lock at 90
        assert abs(math.degrees(zyx_angles(poses[1])[1])) == pytest.approx(90 - math.degrees(SIDE_TILT))
        Rt = poses[1, :3, :3]
        np.testing.assert_allclose(Rt.T @ Rt, np.eye(3), atol=1e-12)
        assert np.linalg.det(Rt) == pytest.approx(1)


def test_sides_too_wide_to_close_across_get_no_grasp():
    o = SceneObject("o", [0, 0, 1], 0.0, [0.05, 0.12, 0.3])  # closes across x only
    names = [c.name for c in box_grasps(o.pose, o.size)]
    assert names == ["top", "top-flipped", "side-+y", "side--y"]
    assert box_grasps(SceneObject("w", [0, 0, 1], 0.0, [0.1, 0.1, 0.05]).pose, [0.1, 0.1, 0.05]) == []
    assert GRIPPER_OPENING == 0.09


def test_can_lying_on_its_side():
    size = np.array([0.07, 0.07, 0.12])
    o = SceneObject("can", [2.0, 0.1, 0.785], 0.0, size, ON_SIDE)
    grasps = {c.name: c.poses for c in box_grasps(o.pose, o.size)}
    assert set(grasps) == {"side-+z", "side--z", "top", "top-flipped"}
    top = grasps["top"][1]
    np.testing.assert_allclose(top[:3, 3], [2.0, 0.1, 0.82], atol=1e-12)  # the highest face, 3.5 cm up
    np.testing.assert_allclose(top[:3, 2], [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(np.abs(top[:3, 1]), [1, 0, 0], atol=1e-12)  # across the 7 cm diameter
    world_z = pin.Quaternion(np.array(ON_SIDE)).matrix()[:, 2]  # the can's axis, horizontal
    for name in ("side-+z", "side--z"):  # the end caps
        sign = 1.0 if name[-2] == "+" else -1.0
        np.testing.assert_allclose(grasps[name][1, :3, 3], o.position + sign * 0.06 * world_z, atol=1e-12)


@pytest.mark.parametrize("yaw", [0.0, 0.5, -2.0])
def test_side_grasp_reached_by_ik_lies_on_the_face(pr2, yaw):
    """IK on the PR2 (base at the origin) for the side grasp facing the robot; pinocchio FK puts the
    TCP on the face centre with a horizontal approach."""
    size = np.array([0.06, 0.07, 0.15])
    target = np.array([0.62, -0.25, 0.85])
    o = SceneObject("o", target, yaw, size)
    R = pin.Quaternion(np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])).matrix()
    # the face whose outward normal points most towards the base
    m, sign = max(((m, s) for m in (0, 1) for s in (1.0, -1.0)), key=lambda ms: -(ms[1] * R[:, ms[0]]) @ target)
    name = f"side-{'+' if sign > 0 else '-'}{'xyz'[m]}"
    (c,) = [c for c in box_grasps(o.pose, o.size) if c.name == name]
    q = pr2.arm("right").home
    for pose in c.poses:  # 20 starts a pose: 4 from the home pose miss the straight-ahead grasp
        res = solve_ik(pr2, "right", pose, q, seeds=20, pos_tol=2e-3, rot_tol=2e-2)
        assert res.success
        q = res.q
    T = base_matrix(0, 0, 0) @ pr2.tcp_pose("right", q)
    face = target + sign * R[:, m] * size[m] / 2
    assert np.linalg.norm(T[:3, 3] - face) < 3e-3
    assert abs(T[2, 2]) < 0.03  # the approach is horizontal


def test_place_orientations_and_reach_candidates():
    s = parse_scene(v2_doc())
    steps = task_steps(s)
    assert [(st.action, st.target) for st in steps] == [
        ("reach", "door,door2"),
        ("pick", "can"),
        ("place", "spot"),
        ("pick", "cup"),
        ("place", "bin"),
        ("reach", "door"),
    ]
    cfg = PlannerConfig()
    reach = step_candidates(s, steps[0], cfg)
    assert [c.name for c in reach] == ["door", "door2"]
    np.testing.assert_allclose(reach[1].poses[1], _se3([1.1, 1.5, 1.0], [0, 0, 0, 1]).homogeneous)
    # the lying can set down lying, turned to the listed orientation, by each of its grasps
    can = s.object("can")
    grasps = step_candidates(s, steps[1], cfg)
    places = step_candidates(s, steps[2], cfg)
    assert [c.name for c in places] == [f"{g.name}@orientation0" for g in grasps]
    R = pin.Quaternion(0.5, 0.5, 0.5, 0.5).matrix()
    for g, place in zip(grasps, places):
        np.testing.assert_allclose(place.object_pose[:3, :3], R, atol=1e-7)
        np.testing.assert_allclose(place.object_pose[:3, 3], [2.2, 0.0, 0.75 + 0.035], atol=1e-7)  # on the table
        for P, G in zip(place.poses, g.poses):  # held as it was grasped
            np.testing.assert_allclose(np.linalg.inv(P) @ place.object_pose, np.linalg.inv(G) @ can.pose, atol=1e-8)
    assert [c.name for c in step_candidates(s, steps[4], cfg)][:2] == ["rim@yaw0", "rim@yaw45"]
    assert [c.name for c in step_candidates(s, steps[3], cfg)] == ["rim"]
