"""The task time model of SPEC section 8: base and arm move in parallel, steps add up."""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from placement.planning.results import PlanResult
from placement.robots import Robot


class Move(NamedTuple):
    """What the time model needs of one planned step."""

    yaw: float  # base yaw of the placement [rad]
    travel_s: float  # base travel time from the previous placement [s]
    arm: str
    joints: dict[str, float]  # joint name -> IK solution [rad or m]


def plan_moves(result: PlanResult | None) -> list[Move] | None:
    """The steps of a plan as moves, or None unless the plan succeeded."""
    if result is None or not result.ok:
        return None
    moves = []
    for s in result.steps:
        assert s.base is not None and s.travel_time_s is not None and s.arm is not None  # a planned step has them
        moves.append(Move(float(s.base[2]), float(s.travel_time_s), s.arm, s.joints))
    return moves


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def task_time(robot: Robot, result: PlanResult | None, start: tuple[float, float, float]) -> dict[str, Any] | None:
    """Per-step and total time [s] of a planned task, or None if a step failed.

    ``start``: the start pose (x [m], y [m], yaw [rad]). Step time = max(base time, arm time):
    base time = max(travel cost / v_max, |yaw change| / omega_max) from the previous placement
    (the start pose first); arm time = max over the step's arm joints of |q - q_prev| / URDF
    velocity limit, from that arm's previous solution (its home configuration first); continuous
    joints take the shorter way round. Grasping and releasing are excluded (constant).
    """
    moves = plan_moves(result)
    if moves is None:
        return None
    prev_yaw = float(start[2])
    prev_q = {arm: robot.arm(arm).home.copy() for arm in robot.arms}
    steps: list[dict[str, float]] = []
    for m in moves:
        base_s = max(m.travel_s, abs(_wrap(m.yaw - prev_yaw)) / robot.omega_max)
        arm = robot.arm(m.arm)
        q = np.array([m.joints[j] for j in arm.joints])
        d = np.abs(q - prev_q[m.arm])
        d = np.where(arm.continuous, np.abs((q - prev_q[m.arm] + math.pi) % (2 * math.pi) - math.pi), d)
        arm_s = float(np.max(d / arm.velocity))
        steps.append({"base_s": base_s, "arm_s": arm_s, "step_s": max(base_s, arm_s)})
        prev_yaw, prev_q[m.arm] = m.yaw, q
    return {"total_s": sum(x["step_s"] for x in steps), "steps": steps}
