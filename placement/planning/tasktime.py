"""The task time model of SPEC section 8: base and arm move in parallel, steps add up."""

from __future__ import annotations

import math

import numpy as np

from ..robots import Robot


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def task_time(robot: Robot, result: dict, start) -> dict | None:
    """Per-step and total time [s] of a planned task, or None if a step failed.

    Step time = max(base time, arm time): base time = max(travel cost / v_max,
    |yaw change| / omega_max) from the previous placement (the start pose first); arm
    time = max over the step's arm joints of |q - q_prev| / URDF velocity limit, from
    that arm's previous solution (its home configuration first); continuous joints
    take the shorter way round. Grasping and releasing are excluded (constant).
    """
    if result.get("status") != "ok":
        return None
    prev_yaw = float(start[2])
    prev_q = {arm: robot.arm(arm).home.copy() for arm in robot.arms}
    steps = []
    for s in result["steps"]:
        yaw = float(s["base"][2])
        base_s = max(float(s["travel_time_s"]), abs(_wrap(yaw - prev_yaw)) / robot.omega_max)
        arm = robot.arm(s["arm"])
        q = np.array([s["joints"][j] for j in arm.joints])
        d = np.abs(q - prev_q[s["arm"]])
        d = np.where(arm.continuous, np.abs((q - prev_q[s["arm"]] + math.pi) % (2 * math.pi) - math.pi), d)
        arm_s = float(np.max(d / arm.velocity))
        steps.append({"base_s": base_s, "arm_s": arm_s, "step_s": max(base_s, arm_s)})
        prev_yaw, prev_q[s["arm"]] = yaw, q
    return {"total_s": sum(x["step_s"] for x in steps), "steps": steps}
