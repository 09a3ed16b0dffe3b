"""The torso setting of a step: the map, robot and collision check of an option at its torso value.

A robot whose maps carry a torso record (a lift such as the PR2's ``torso_lift_joint``, see
:mod:`placement.maps.torso`) has, per arm, one map view per torso setting: the same values with the
grid moved with the lift. Every step gets options at every setting (:class:`~placement.planning.problems.option.Option`'s
``torso``), so each step chooses its base pose, arm, grasp and torso value; IK and the collision
check of an option run on the robot with the lift at the option's value.

The torso moves while the base drives (the parallel model of the task time, docs/design.md), so a
torso change costs time only where it takes longer than the base's move. ``global`` holds the lift
at the preset's value on every step the maps serve there (its program prices travel, not the lift;
see :func:`placement.planning.program.regions.map_regions`); ``optimal`` prices the torso's time per step
(:mod:`placement.planning.program.priced_torso`); the step-by-step methods add the lift's time to Eq. 6
(:func:`placement.planning.methods.stepwise.torso_ranked`). Verification tries the options at the
torso value the robot holds first (no motion), then the others, nearest first.

A torso of several joints held at postures (:mod:`placement.maps.torso`) is carried the same
way, its setting the posture's index: :func:`robot_at` holds every joint at the posture, a step's
``joints`` list every torso joint's value, and :func:`torso_seconds` is the slowest joint's time.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from placement.maps.rmap import ReachabilityMap
from placement.maps.torso import TorsoSettings
from placement.planning.problems import map_variants, torso_record, torso_value
from placement.robots import Robot

if TYPE_CHECKING:
    from placement.collision import SceneCollision
    from placement.planning.context import PlanningContext
    from placement.planning.problems import Option


def _record(maps: Mapping[str, ReachabilityMap]) -> TorsoSettings | None:
    """The first torso record among the maps' (they share the joint), or None."""
    return next((r for m in maps.values() if (r := torso_record(m)) is not None), None)


def torso_joint(maps: Mapping[str, ReachabilityMap]) -> str | None:
    """The joint the maps' torso records move (the same on every arm; for postures of several joints
    their names joined by "+", which no step's ``joints`` holds: see :func:`held_setting`), or None."""
    joints = {record.label for m in maps.values() if (record := torso_record(m)) is not None}
    return next(iter(joints)) if len(joints) == 1 else None


def robot_at(ctx: PlanningContext, torso: float | None) -> Robot:
    """The context's robot with the torso at ``torso`` [m or rad; a posture's index] (the robot itself
    for None): every torso joint at its value there."""
    record = _record(ctx.maps)
    if torso is None or record is None or torso_joint(ctx.maps) is None:
        return ctx.robot
    return ctx.robot.with_fixed(record.held(torso))


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


def option_robot(ctx: PlanningContext, o: Option) -> Robot:
    """The robot an option's IK runs on: :func:`robot_at` its torso setting."""
    return robot_at(ctx, o.torso)


def option_collisions(ctx: PlanningContext, o: Option) -> SceneCollision | None:
    """The collision check of an option's placements: :func:`collisions_at` its torso setting."""
    return collisions_at(ctx, o.torso)


def start_torso(ctx: PlanningContext) -> float | None:
    """The torso value [m or rad; a posture's index] the robot starts with: the preset's (None without
    torso records)."""
    joint = torso_joint(ctx.maps)
    record = _record(ctx.maps)
    if joint is None or record is None:
        return None
    return record.reference if record.joints else float(ctx.robot.fixed_joints[joint])


def held_setting(ctx: PlanningContext, joints: Mapping[str, float], before: float | None) -> float | None:
    """The torso setting [m or rad; a posture's index] a step's ``joints`` ({name: value}) hold: the
    torso joint's value, or the index of the posture whose every joint matches (to 1e-9); ``before``
    when they hold none."""
    record = _record(ctx.maps)
    if record is None or torso_joint(ctx.maps) is None:
        return before
    if not record.joints:
        return float(joints[record.joint]) if record.joint in joints else before
    for v in record.allowed:
        if all(j in joints and abs(float(joints[j]) - x) <= 1e-9 for j, x in record.held(v).items()):
            return v
    return before


def torso_first(options: Sequence[Option], order: Sequence[int], now: float | None) -> list[int]:
    """``order`` (indices into ``options``) re-sorted stably: options at torso value ``now`` [m]
    first, then by the torso motion they need (the least first)."""
    if now is None:
        return list(order)
    return sorted(order, key=lambda k: 0.0 if options[k].torso is None else abs(float(options[k].torso or 0.0) - now))


def torso_seconds(ctx: PlanningContext, a: float | None, b: float | None) -> float:
    """Time [s] the torso takes from setting ``a`` to ``b`` [m or rad; postures' indices] at its URDF
    velocity limits (:meth:`TorsoSettings.seconds`: for postures the slowest joint's); 0 without a torso."""
    if a is None or b is None:
        return 0.0
    record = _record(ctx.maps)
    if record is None or not record.velocity > 0:
        return 0.0
    return record.seconds(a, b)


__all__ = [
    "collisions_at",
    "held_setting",
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
