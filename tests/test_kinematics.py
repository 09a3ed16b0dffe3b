"""The numba FK/Jacobian kernel against pinocchio (agree to 1e-9)."""

from __future__ import annotations

import zlib

import numpy as np
import pinocchio as pin
import pytest
from support.robots import random_configs

from placement.kernels.kinematics import fk_jacobian, fk_jacobian_batch

TOL = 1e-9
N_CONFIGS = 200


def pinocchio_reference(robot, arm_name: str, Q: np.ndarray):
    """TCP poses (N, 4, 4) in the base frame and LOCAL TCP Jacobians (N, 6, n) of the arm joints.

    A TCP frame (tip frame placement * tcp_offset) is added to a copy of the
    model; the Jacobian columns are those of the arm joints' velocity indices.
    """
    arm = robot.arm(arm_name)
    model = pin.Model(robot.model)
    tip_id = model.getFrameId(arm.tip_frame)
    tip = model.frames[tip_id]
    placement_ = tip.placement * pin.SE3(arm.tcp_offset)
    tcp_id = model.addFrame(pin.Frame("test_tcp", tip.parentJoint, tip_id, placement_, pin.FrameType.OP_FRAME))
    data = model.createData()
    base_id = model.getFrameId(robot.base_frame)
    cols = [model.joints[j].idx_v for j in arm.joint_ids]
    T = np.empty((len(Q), 4, 4))
    J = np.empty((len(Q), 6, arm.dof))
    for i, q in enumerate(Q):
        qf = robot.full_q(arm_name, q)
        pin.computeJointJacobians(model, data, qf)
        pin.updateFramePlacements(model, data)
        T[i] = (data.oMf[base_id].inverse() * data.oMf[tcp_id]).homogeneous
        J[i] = pin.getFrameJacobian(model, data, tcp_id, pin.LOCAL)[:, cols]
    return T, J


def kernel(robot, arm_name: str, Q: np.ndarray):
    ch = robot.arm(arm_name).chain
    return fk_jacobian_batch(np.ascontiguousarray(Q), ch.link_T, ch.axis, ch.kind, ch.tip_T)


ROBOT_ARMS = [("pr2", "right"), ("pr2", "left"), ("armar6", "left"), ("armar6", "right")]


@pytest.fixture
def robot(request):
    return request.getfixturevalue(request.param)


@pytest.mark.parametrize("robot,arm_name", ROBOT_ARMS, indirect=["robot"])
def test_fk_and_jacobian_match_pinocchio(robot, arm_name):
    arm = robot.arm(arm_name)
    rng = np.random.default_rng(zlib.crc32(f"{robot.name}/{arm_name}".encode()))
    Q = random_configs(arm, N_CONFIGS, rng)
    T_ref, J_ref = pinocchio_reference(robot, arm_name, Q)
    T, J = kernel(robot, arm_name, Q)
    assert T.shape == (N_CONFIGS, 4, 4) and J.shape == (N_CONFIGS, 6, arm.dof)
    np.testing.assert_allclose(T, T_ref, rtol=0, atol=TOL)
    np.testing.assert_allclose(J, J_ref, rtol=0, atol=TOL)
    # the test is not vacuous: configurations differ and the Jacobian has full rank
    assert np.ptp(T_ref[:, :3, 3], axis=0).min() > 0.1
    assert np.linalg.matrix_rank(J_ref[0]) == 6


@pytest.mark.parametrize("robot,arm_name", ROBOT_ARMS, indirect=["robot"])
def test_tcp_pose_matches_kernel(robot, arm_name):
    arm = robot.arm(arm_name)
    rng = np.random.default_rng(7)
    Q = random_configs(arm, 50, rng)
    T, _ = kernel(robot, arm_name, Q)
    T_pin = np.array([robot.tcp_pose(arm_name, q) for q in Q])
    np.testing.assert_allclose(T_pin, T, rtol=0, atol=TOL)
    # orthonormal rotation, homogeneous last row
    R = T[:, :3, :3]
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_array_equal(T[:, 3], np.broadcast_to([0.0, 0.0, 0.0, 1.0], (len(Q), 4)))


@pytest.mark.parametrize("robot,arm_name", ROBOT_ARMS, indirect=["robot"])
def test_continuous_joints_are_periodic(robot, arm_name):
    """q and q + 2 pi on a continuous joint give the same pose (pinocchio's nq = 2 joints)."""
    arm = robot.arm(arm_name)
    if not arm.continuous.any():
        pytest.skip("arm has no continuous joint")
    rng = np.random.default_rng(3)
    Q = random_configs(arm, 20, rng)
    Q2 = Q + 2 * np.pi * arm.continuous
    T1, J1 = kernel(robot, arm_name, Q)
    T2, J2 = kernel(robot, arm_name, Q2)
    np.testing.assert_allclose(T2, T1, atol=1e-9)
    np.testing.assert_allclose(J2, J1, atol=1e-9)
    T_ref, _ = pinocchio_reference(robot, arm_name, Q2)
    np.testing.assert_allclose(T2, T_ref, atol=TOL)


def test_single_config_kernel_equals_batch(pr2):
    arm = pr2.arm("right")
    ch = arm.chain
    q = arm.home.copy()
    T, J, work = np.empty((4, 4)), np.empty((6, arm.dof)), np.empty((arm.dof + 3, 4, 4))
    fk_jacobian(q, ch.link_T, ch.axis, ch.kind, ch.tip_T, T, J, work)
    Tb, Jb = kernel(pr2, "right", q[None])
    np.testing.assert_array_equal(T, Tb[0])
    np.testing.assert_array_equal(J, Jb[0])


def test_jacobian_is_derivative_of_fk(pr2):
    """Independent of pinocchio: finite differences of the kernel's FK give its LOCAL Jacobian."""
    arm = pr2.arm("right")
    rng = np.random.default_rng(11)
    q = random_configs(arm, 1, rng)[0]
    h = 1e-6
    T0, J0 = kernel(pr2, "right", q[None])
    T0, J0 = T0[0], J0[0]
    for j in range(arm.dof):
        dq = np.zeros(arm.dof)
        dq[j] = h
        Tp, _ = kernel(pr2, "right", (q + dq)[None])
        Tm, _ = kernel(pr2, "right", (q - dq)[None])
        # body twist: R^T dp, and the vee of R^T dR
        v = T0[:3, :3].T @ (Tp[0, :3, 3] - Tm[0, :3, 3]) / (2 * h)
        W = T0[:3, :3].T @ (Tp[0, :3, :3] - Tm[0, :3, :3]) / (2 * h)
        w = np.array([W[2, 1], W[0, 2], W[1, 0]])
        np.testing.assert_allclose(np.r_[v, w], J0[:, j], atol=1e-7)


def test_armar6_fixed_torso_is_used(armar6):
    """The preset's fixed torso height (-0.2 m, prismatic) is folded into the chain."""
    q = np.zeros(8)
    model = armar6.model
    data = model.createData()
    qf = pin.neutral(model)
    qf[model.joints[model.getJointId("torso_joint")].idx_q] = -0.2
    for jid in armar6.arm("left").joint_ids:
        jm = model.joints[jid]
        if jm.nq == 2:
            qf[jm.idx_q], qf[jm.idx_q + 1] = 1.0, 0.0
        else:
            qf[jm.idx_q] = 0.0
    pin.framesForwardKinematics(model, data, qf)
    M = (data.oMf[model.getFrameId("platform")].inverse() * data.oMf[model.getFrameId("Hand L Palm")]).homogeneous
    T, _ = kernel(armar6, "left", q[None])
    np.testing.assert_allclose(T[0], M @ armar6.arm("left").tcp_offset, atol=TOL)
    # and it differs from the torso at 0 by exactly the prismatic stroke along the torso axis
    qf[model.joints[model.getJointId("torso_joint")].idx_q] = 0.0
    pin.framesForwardKinematics(model, data, qf)
    M0 = (data.oMf[model.getFrameId("platform")].inverse() * data.oMf[model.getFrameId("Hand L Palm")]).homogeneous
    assert np.linalg.norm(M0[:3, 3] - M[:3, 3]) == pytest.approx(0.2, abs=1e-9)


def test_prismatic_joint_in_the_chain(tmp_path):
    """An arm whose chain starts with a prismatic joint (PR2 torso lift + right arm): FK and J = pinocchio."""
    import placement

    preset = tmp_path / "pr2_lift.yaml"
    preset.write_text(
        "name: pr2_lift\n"
        "urdf: package://example-robot-data/robots/pr2_description/urdf/pr2.urdf\n"
        "base_frame: base_footprint\n"
        "footprint_radius: 0.47\n"
        "v_max: 0.5\n"
        "omega_max: 1.0\n"
        "arms:\n"
        "  right:\n"
        "    joints: [torso_lift_joint, r_shoulder_pan_joint, r_shoulder_lift_joint, r_upper_arm_roll_joint,\n"
        "             r_elbow_flex_joint, r_forearm_roll_joint, r_wrist_flex_joint, r_wrist_roll_joint]\n"
        "    tip_frame: r_gripper_tool_frame\n"
    )
    robot = placement.load_robot(str(preset))
    arm = robot.arm("right")
    assert arm.chain.kind[0] == 1 and np.all(arm.chain.kind[1:] == 0)
    Q = random_configs(arm, 100, np.random.default_rng(3))
    T_ref, J_ref = pinocchio_reference(robot, "right", Q)
    T, J = kernel(robot, "right", Q)
    assert np.abs(T - T_ref).max() < TOL
    assert np.abs(J - J_ref).max() < TOL
