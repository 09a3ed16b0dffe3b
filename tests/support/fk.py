"""Pinocchio FK of a whole configuration given joint by joint: the tests' reference, independent of
the package's own helpers (placement.planning.configuration), which it checks."""

from __future__ import annotations

import math

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
