"""Pinocchio FK of a whole configuration given joint by joint: the tests' reference, independent of
the package's own helpers (placement.planning.verification.configuration), which it checks."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin


def model_fk(robot, joints: dict[str, float]) -> pin.Data:
    """Pinocchio data after frame FK with every joint of ``joints`` ({name: value [rad or m]}) set by
    name and the rest neutral (a continuous joint as its (cos, sin) pair)."""
    model = robot.model
    q = pin.neutral(model)
    for name, v in joints.items():
        jm = model.joints[model.getJointId(name)]
        q[jm.idx_q : jm.idx_q + jm.nq] = (math.cos(v), math.sin(v)) if jm.nq == 2 else (v,)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return data


def world_tcp(robot, arm: str, joints: dict[str, float], base) -> np.ndarray:
    """(4, 4) world pose of ``arm``'s canonical TCP (tip frame x ``tcp_offset``) by :func:`model_fk` of
    ``joints``, with the base frame at the planar pose ``base`` (x [m], y [m], yaw [rad])."""
    data = model_fk(robot, joints)
    model = robot.model
    base_frame = data.oMf[model.getFrameId(robot.base_frame)]
    tip = data.oMf[model.getFrameId(robot.arm(arm).tip_frame)]
    x, y, yaw = (float(v) for v in base)
    B = np.eye(4)
    B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    B[:2, 3] = (x, y)
    out: np.ndarray = B @ (base_frame.inverse() * tip).homogeneous @ np.asarray(robot.arm(arm).tcp_offset)
    return out
