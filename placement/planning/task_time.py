"""The task time model: base, arm and torso move in parallel, steps add up (the benchmark's objective, and what
the whole-task methods minimise over base yaws, see :mod:`placement.planning.program.turning`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from placement.errors import PlacementError
from placement.planning.results import PlacedStep, PlanResult, StepResult, placed_steps
from placement.planning.verification import joint_limits, velocity_limit
from placement.robots import Robot


class Move(NamedTuple):
    """What the time model needs of one planned step."""

    yaw: float  # base yaw of the placement [rad]
    travel_s: float  # base travel time from the previous placement [s]
    arm: str
    joints: dict[str, float]  # joint name -> IK solution, and the fixed joints' values [rad or m]


def move_of(step: PlacedStep) -> Move:
    """A planned step as a move."""
    return Move(float(step.base[2]), float(step.travel_time_s), step.arm, step.joints)


def plan_moves(result: PlanResult | None) -> list[Move] | None:
    """The steps of a plan as moves, or None unless the plan succeeded."""
    if result is None or not result.ok:
        return None
    return [move_of(s) for s in placed_steps(result.steps)]


def steps_seconds(robot: Robot, steps: Sequence[StepResult], start_yaw: float) -> list[dict[str, float]]:
    """:func:`step_times` of planned steps from the base yaw ``start_yaw`` [rad]."""
    return step_times(robot, [move_of(s) for s in placed_steps(steps)], start_yaw)


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def task_time(robot: Robot, result: PlanResult | None, start: tuple[float, float, float]) -> dict[str, Any] | None:
    """Per-step and total time [s] of a planned task, or None if a step failed.

    ``start``: the start pose (x [m], y [m], yaw [rad]). Base, arm and torso move in parallel:
    step time = max(base time, arm time, torso time), with base time = max(travel cost / v_max,
    |yaw change| / omega_max) from the previous placement (the start pose first); arm time = max
    over the step's arm joints of |q - q_prev| / URDF velocity limit, from that arm's previous
    solution (its home configuration first); torso time = max over the preset's fixed joints (the
    PR2's torso lift) of |value - previous value| / URDF velocity limit, from the previous step's
    value (the robot starts in its preset posture: the preset's value before the first step; a step
    that does not give a fixed joint holds it at the preset's value, as its configuration does);
    continuous joints take the shorter way round. Grasping and releasing are excluded (constant).
    Returns {"total_s", "steps": [{"base_s", "arm_s", "torso_s", "step_s"}]}; PlacementError when a
    fixed joint moves but its URDF velocity limit is not positive.
    """
    moves = plan_moves(result)
    if moves is None:
        return None
    steps = step_times(robot, moves, float(start[2]))
    return {"total_s": sum(x["step_s"] for x in steps), "steps": steps}


def step_times(robot: Robot, moves: list[Move], start_yaw: float) -> list[dict[str, float]]:
    """``{"base_s", "arm_s", "torso_s", "step_s"}`` [s] of each move from the base yaw ``start_yaw``
    [rad] (see :func:`task_time`)."""
    prev_yaw = start_yaw
    prev_q = {arm: robot.arm(arm).home.copy() for arm in robot.arms}
    prev_fixed = dict(robot.fixed_joints)
    steps: list[dict[str, float]] = []
    for m in moves:
        base_s = max(m.travel_s, abs(_wrap(m.yaw - prev_yaw)) / robot.omega_max)
        arm = robot.arm(m.arm)
        q = np.array([m.joints[j] for j in arm.joints])
        d = np.abs(q - prev_q[m.arm])
        d = np.where(arm.continuous, np.abs((q - prev_q[m.arm] + math.pi) % (2 * math.pi) - math.pi), d)
        arm_s = float(np.max(d / arm.velocity))
        fixed = {j: float(m.joints.get(j, v)) for j, v in robot.fixed_joints.items()}
        torso_s = max((_fixed_time(robot, j, prev_fixed[j], v) for j, v in fixed.items()), default=0.0)
        steps.append({"base_s": base_s, "arm_s": arm_s, "torso_s": torso_s, "step_s": max(base_s, arm_s, torso_s)})
        prev_yaw, prev_q[m.arm], prev_fixed = m.yaw, q, fixed
    return steps


def _fixed_time(robot: Robot, joint: str, before: float, after: float) -> float:
    """Time [s] fixed joint ``joint`` takes from ``before`` to ``after`` [rad or m] at its URDF
    velocity limit (a continuous joint the shorter way round)."""
    d = abs(_wrap(after - before)) if joint_limits(robot, joint)[2] else abs(after - before)
    if d == 0.0:
        return 0.0
    v = velocity_limit(robot, joint)
    if not v > 0.0:
        raise PlacementError(
            f"fixed joint {joint} of robot '{robot.name}' moves {d:g} between steps but its URDF velocity "
            f"limit is {v:g}: the task time cannot be computed"
        )
    return d / v
