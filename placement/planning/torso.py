"""The torso setting of a step: the map, robot and collision check of an option at its torso value.

A robot whose maps carry a torso record (a lift such as the PR2's ``torso_lift_joint``, see
:mod:`placement.maps.torso`) has, per arm, one map view per torso setting: the same values with the
grid moved with the lift. Every step gets options at every setting (:class:`~placement.planning.option.Option`'s
``torso``), so each step chooses its base pose, arm, grasp and torso value; IK and the collision
check of an option run on the robot with the lift at the option's value.

The torso moves while the base drives (the parallel model of the task time, SPEC section 8), so a
torso change costs time only where it takes longer than the base's move. The whole-task methods hold
the lift at the preset's value on every step the maps serve there (their program prices travel, not
the lift; see :func:`placement.planning.bound.map_regions`); the step-by-step methods add the lift's
time to Eq. 6 (:func:`placement.planning.methods.stepwise.torso_ranked`). Verification tries the
options at the torso value the robot holds first (no motion), then the others, nearest first.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from placement.maps.rmap import ReachabilityMap
from placement.planning.variants import map_variants, torso_record, torso_value
from placement.robots import Robot

if TYPE_CHECKING:
    from placement.collision import SceneCollision
    from placement.planning.context import PlanningContext
    from placement.planning.option import Option


def torso_joint(maps: Mapping[str, ReachabilityMap]) -> str | None:
    """The joint the maps' torso records move (the same on every arm), or None."""
    joints = {record.joint for m in maps.values() if (record := torso_record(m)) is not None}
    return next(iter(joints)) if len(joints) == 1 else None


def robot_at(ctx: PlanningContext, torso: float | None) -> Robot:
    """The context's robot with the torso at ``torso`` [m] (the robot itself for None)."""
    joint = torso_joint(ctx.maps)
    if torso is None or joint is None:
        return ctx.robot
    return ctx.robot.with_fixed({joint: torso})


def collisions_at(ctx: PlanningContext, torso: float | None) -> SceneCollision | None:
    """The scene collision check of :func:`robot_at` (built once per torso value, kept in the
    context and updated with it), or None when the context checks no collisions."""
    base = ctx.collisions
    robot = robot_at(ctx, torso)
    if base is None or robot is ctx.robot:
        return base
    key = float(torso) if torso is not None else 0.0
    found = ctx.torso_checks.get(key)
    if found is None:
        from placement.collision import SceneCollision

        check = SceneCollision(robot, ctx.scene, padding=base.padding, clearance_cap=base.cap)
        found = ctx.torso_checks.setdefault(key, check)
    return found


def option_map(ctx: PlanningContext, o: Option) -> ReachabilityMap:
    """The map (view) an option was computed from."""
    return ctx.problems.map_for(o.arm, o.torso)


def start_torso(ctx: PlanningContext) -> float | None:
    """The torso value [m] the robot starts with: the preset's (None without torso records)."""
    joint = torso_joint(ctx.maps)
    return None if joint is None else float(ctx.robot.fixed_joints[joint])


def torso_first(options: Sequence[Option], order: Sequence[int], now: float | None) -> list[int]:
    """``order`` (indices into ``options``) re-sorted stably: options at torso value ``now`` [m]
    first, then by the torso motion they need (the least first)."""
    if now is None:
        return list(order)
    return sorted(order, key=lambda k: 0.0 if options[k].torso is None else abs(float(options[k].torso or 0.0) - now))


def torso_seconds(ctx: PlanningContext, a: float | None, b: float | None) -> float:
    """Time [s] the lift takes from ``a`` to ``b`` [m] at its URDF velocity limit (0 without a torso)."""
    if a is None or b is None:
        return 0.0
    record = next((torso_record(m) for m in ctx.maps.values() if torso_record(m) is not None), None)
    if record is None or not record.velocity > 0:
        return 0.0
    return abs(b - a) / float(record.velocity)


__all__ = [
    "collisions_at",
    "map_variants",
    "option_map",
    "robot_at",
    "start_torso",
    "torso_first",
    "torso_joint",
    "torso_record",
    "torso_seconds",
    "torso_value",
]
