"""`robots init` on a gripper with one moving jaw (the SO-101: a fixed jaw on the last link, one revolute
jaw hinged beside it): the jaw's frame sits on its hinge, so the approach is not taken towards it but
towards the hand's named tool frame, and y (the closing direction) is the jaw's motion. Checked against
the hand's collision shapes: the jaw's far end moves along TCP y when it closes, and the point between
the jaws' far ends lies ahead of the wrist along TCP z."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from test_new_robots import SO_ARM, geometry, urdf_text

import placement
from placement.robots.onboarding.propose import propose
from placement.robots.onboarding.render import render
from placement.robots.onboarding.tcp import single_jaw


@pytest.fixture(scope="module")
def so_arm(tmp_path_factory):
    pytest.importorskip("xacro")
    out = tmp_path_factory.mktemp("so") / "so_arm_base.yaml"
    p = propose(SO_ARM, out)
    out.write_text(render(p))
    return placement.load_robot(out), p


def far_corner(geom: pin.GeometryModel, gdata: pin.GeometryData, k: int, z: np.ndarray) -> np.ndarray:
    """The centre (3,) of the 4 corners of collision box ``k`` farthest along ``z`` [m], root frame (its
    far face's centre when the box is aligned with ``z``)."""
    half = geom.geometryObjects[k].geometry.halfSide
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    M = gdata.oMg[k]
    world = corners @ M.rotation.T + M.translation
    return world[np.argsort(world @ z)[-4:]].mean(axis=0)


def hand_at(robot, q_arm: np.ndarray, jaw: float):
    """(data, geometry model, geometry data, TCP (4, 4)) with the arm at ``q_arm`` and the jaw at ``jaw`` [rad]."""
    model = robot.model
    q = robot.full_q("arm", q_arm)
    q[model.idx_qs[model.getJointId("gripper")]] = jaw
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    geom = geometry(model, urdf_text(SO_ARM))
    gdata = pin.GeometryData(geom)
    pin.updateGeometryPlacements(model, data, geom, gdata, q)
    a = robot.arm("arm")
    tcp = data.oMf[model.getFrameId(a.tip_frame)].homogeneous @ a.tcp_offset
    return data, geom, gdata, tcp


def test_single_jaw_is_recognised(so_arm):
    r, _ = so_arm
    m = r.model
    last = m.getJointId("wrist_roll")
    assert single_jaw(m, last, [m.getJointId("gripper")]) == m.getJointId("gripper")


def test_so_arm_tcp_is_its_gripper_frame(so_arm):
    r, p = so_arm
    a = r.arm("arm")
    assert a.tip_frame == "gripper_frame_link"
    assert "one moving jaw" in p.arms[0].tcp.how
    # approach along the SO-101 authors' gripper_frame_link z (it points out between the jaws)
    assert a.tcp_offset[:3, 2] @ np.array([0.0, 0.0, 1.0]) > math.cos(math.radians(1))
    assert np.linalg.norm(a.tcp_offset[:3, 3]) < 0.02  # no deepening: the jaws end 1 cm past the frame


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_so_arm_tcp_against_the_jaws_shapes(so_arm, seed):
    r, _ = so_arm
    a = r.arm("arm")
    rng = np.random.default_rng(seed)
    q_arm = rng.uniform(a.lower, a.upper) if seed else a.home
    model = r.model
    lo = model.lowerPositionLimit[model.idx_qs[model.getJointId("gripper")]]
    data, geom, gdata, tcp = hand_at(r, q_arm, lo + 0.2)
    z, y = tcp[:3, 2], tcp[:3, 1]
    wrist = data.oMi[model.getJointId("wrist_roll")].translation
    jaw_shapes = [k for k, g in enumerate(geom.geometryObjects) if g.parentJoint == model.getJointId("gripper")]
    fixed = [k for k, g in enumerate(geom.geometryObjects) if g.parentJoint == model.getJointId("wrist_roll")]
    moving_end = far_corner(geom, gdata, jaw_shapes[0], z)
    fixed_end = max((far_corner(geom, gdata, k, z) for k in fixed), key=lambda v: v @ z)
    # between the jaws' far ends: ahead of the wrist along the approach (old inference: 50 deg off)
    between = (moving_end + fixed_end) / 2 - wrist
    assert between @ z / np.linalg.norm(between) > math.cos(math.radians(15))
    # the jaw closing by 0.1 rad moves its far end across the approach, along TCP y
    _, geom2, gdata2, _ = hand_at(r, q_arm, lo + 0.1)
    step = far_corner(geom2, gdata2, jaw_shapes[0], z) - moving_end
    assert abs(step @ y) / np.linalg.norm(step) > 0.9


def test_old_inference_would_fail_these_checks(so_arm):
    """The checks above can fail: the TCP the finger centroid gave (approach to the jaw's hinge) is 50 deg off."""
    r, _ = so_arm
    model = r.model
    data = model.createData()
    q = r.full_q("arm", r.arm("arm").home)
    pin.framesForwardKinematics(model, data, q)
    wrist = data.oMi[model.getJointId("wrist_roll")].translation
    hinge = data.oMi[model.getJointId("gripper")].translation
    frame_z = data.oMf[model.getFrameId("gripper_frame_link")].rotation[:, 2]
    off = math.degrees(math.acos((hinge - wrist) @ frame_z / np.linalg.norm(hinge - wrist)))
    assert 40 < off < 60
