"""The whole configuration of the robot at a planned step, as the planner assumed it.

A step moves one arm along its TCP trajectory with the base standing still. What the rest of the
robot does meanwhile is what the collision check (:mod:`placement.collision.checker`) assumed:

* the preset's fixed joints (the PR2's torso lift) at the step's values (the step result's
  ``joints``): a step may hold them at other values within their URDF limits (a torso raised for a
  high shelf), a step that does not give one holds it at the preset's value;
* every other arm at its ``idle`` configuration (the preset's, by default ``home``; the PR2's arm
  tucked). The task's steps are pick/place pairs, each pick followed at once by its place with the
  same arm, so an arm never holds an object while another arm works: an arm that is not the step's
  is always idle and empty-handed;
* every other joint of the model (head, grippers, laser tilt) at pinocchio's neutral value (0).

Mimic joints follow their leader and are not commanded, so they are left out. An executor commands
this configuration from the plan document alone (see docs/planning.md, the plan document).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import cast

import numpy as np
import pinocchio as pin

from placement.planning.arrays import FloatArray
from placement.robots import Robot
from placement.robots.model_cache import fk_data, frame_id


@dataclass(frozen=True)
class Resting:
    """What a step does not choose but assumes, besides the fixed joints in the step's ``joints``.

    Attributes:
        base_frame: the frame the step's base pose (x, y, yaw) places on the floor.
        idle: {other arm: {joint name: value [rad or m]}} every arm but the step's, at its idle
            configuration.
        other: {joint name: value [rad or m]} every actuated joint of no arm, at its neutral value
            (the fixed joints among them are overridden by the step's ``joints``).
        order: every actuated joint of the model, in the model's order.
        arms: {arm name: its joint names}, every arm of the robot in preset order.
    """

    base_frame: str
    idle: dict[str, dict[str, float]]
    other: dict[str, float]
    order: tuple[str, ...]
    arms: dict[str, list[str]]


def actuated_joints(robot: Robot) -> list[str]:
    """Names of the model's joints of one degree of freedom that are not mimic joints, model order.
    (Joints of several degrees of freedom, a floating or planar root, are not joints of a preset.)"""
    model = robot.model
    mimic = robot.mimic_joints
    return [model.names[j] for j in range(1, model.njoints) if model.joints[j].nv == 1 and model.names[j] not in mimic]


def joint_values(robot: Robot, q: FloatArray, names: list[str]) -> dict[str, float]:
    """{name: value [rad or m]} of the 1-DoF joints ``names`` in the pinocchio configuration ``q``
    (a continuous joint's angle from its (cos, sin) pair)."""
    model, out = robot.model, {}
    for name in names:
        jm = model.joints[model.getJointId(name)]
        if jm.nq == 2:
            out[name] = math.atan2(float(q[jm.idx_q + 1]), float(q[jm.idx_q]))
        else:
            out[name] = float(q[jm.idx_q])
    return out


def resting(robot: Robot, arm: str) -> Resting:
    """The :class:`Resting` part of ``robot``'s configuration while ``arm`` works (module doc)."""
    q = robot.reference_q()
    for a in robot.arms:
        if a != arm:
            q = robot.full_q(a, cast(np.ndarray, robot.arm(a).idle), q)  # (never None: Arm.__post_init__)
    order = actuated_joints(robot)
    values = joint_values(robot, q, order)
    arms = {a: list(robot.arm(a).joints) for a in robot.arms}
    idle = {a: {j: values[j] for j in names} for a, names in arms.items() if a != arm}
    in_arms = {j for names in arms.values() for j in names}
    other = {j: v for j, v in values.items() if j not in in_arms}
    return Resting(robot.base_frame, idle, other, tuple(order), arms)


def pinocchio_q(robot: Robot, joints: Mapping[str, float]) -> FloatArray:
    """The pinocchio configuration with every joint of ``joints`` ({name: value [rad or m]}) set and
    the rest neutral; a name the model lacks raises KeyError naming it."""
    model = robot.model
    q: FloatArray = pin.neutral(model)
    for name, value in joints.items():
        if not model.existJointName(name):
            raise KeyError(name)
        jm = model.joints[model.getJointId(name)]
        if jm.nq == 2:
            q[jm.idx_q], q[jm.idx_q + 1] = math.cos(value), math.sin(value)
        else:
            q[jm.idx_q] = value
    return q


def world_tcp(robot: Robot, arm: str, q: FloatArray, base: FloatArray) -> FloatArray:
    """(4, 4) world pose of ``arm``'s TCP by pinocchio FK of the whole configuration ``q`` with the
    base frame at ``base`` (4, 4) in the world."""
    data = fk_data(robot.model)
    pin.framesForwardKinematics(robot.model, data, q)
    a = robot.arm(arm)
    root = base @ data.oMf[robot.base_frame_id].inverse().homogeneous
    tip = data.oMf[frame_id(robot.model, a.tip_frame)].homogeneous
    out: FloatArray = root @ tip @ a.tcp_offset
    return out


def joint_limits(robot: Robot, name: str) -> tuple[float, float, bool]:
    """(lower, upper [rad or m], continuous) of the 1-DoF joint ``name`` of ``robot``'s URDF (a
    continuous joint: [-pi, pi], True)."""
    model = robot.model
    jm = model.joints[model.getJointId(name)]
    if jm.nq == 2:
        return -math.pi, math.pi, True
    return float(model.lowerPositionLimit[jm.idx_q]), float(model.upperPositionLimit[jm.idx_q]), False


def velocity_limit(robot: Robot, name: str) -> float:
    """The URDF velocity limit [rad/s or m/s] of the 1-DoF joint ``name`` of ``robot``."""
    model = robot.model
    return float(model.velocityLimit[model.joints[model.getJointId(name)].idx_v])


def fixed_problems(robot: Robot, joints: Mapping[str, float], tol: float = 1e-9) -> list[str]:
    """The values of ``robot``'s fixed joints in ``joints`` ({name: value [rad or m]}, a step's)
    outside their URDF limits, each as one problem naming the joint, its value and the limits (a
    fixed joint may differ from the preset's value, as a torso set per step does; one not in
    ``joints`` is not looked at)."""
    return [p for p in (_fixed_problem(robot, j, joints, tol) for j in robot.fixed_joints if j in joints) if p]


def _fixed_problem(robot: Robot, name: str, joints: Mapping[str, float], tol: float) -> str | None:
    lo, hi, continuous = joint_limits(robot, name)
    v = float(joints[name])
    if not math.isfinite(v) or (not continuous and not lo - tol <= v <= hi + tol):
        return f"fixed joint {name} is {v:g}, outside its URDF limits [{lo:g}, {hi:g}]"
    return None


def held(robot: Robot, joints: Mapping[str, float]) -> Robot:
    """``robot`` with its fixed joints at their values in ``joints`` (a step's; one missing or outside
    its limits stays at the preset's value, :func:`fixed_problems` reports it): the robot whose FK
    (:meth:`Robot.tcp_pose`) is the step's."""
    values = {}
    for j in robot.fixed_joints:
        if j in joints and _fixed_problem(robot, j, joints, 1e-9) is None:
            lo, hi, continuous = joint_limits(robot, j)
            v = float(joints[j])
            # a value rounded just past a limit is held at the limit: with_fixed takes none outside
            values[j] = v if continuous else min(max(v, lo), hi)
    return robot.with_fixed(values)


def out_of_limits(robot: Robot, arm: str, joints: Mapping[str, float], tol: float = 1e-9) -> list[str]:
    """The joints of ``arm`` in ``joints`` outside their limits (continuous joints never are)."""
    a = robot.arm(arm)
    v = np.array([joints[j] for j in a.joints])
    bad = ~a.continuous & ((v < a.lower - tol) | (v > a.upper + tol))
    return [a.joints[k] for k in np.flatnonzero(bad)]


__all__ = [
    "Resting",
    "actuated_joints",
    "fixed_problems",
    "held",
    "joint_limits",
    "joint_values",
    "out_of_limits",
    "pinocchio_q",
    "resting",
    "velocity_limit",
    "world_tcp",
]
