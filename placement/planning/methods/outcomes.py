"""Step results shared by the methods: a verified placement, an infeasible step and why."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from placement.planning.arrays import BasePose, FloatArray
from placement.planning.context import PlanningContext
from placement.planning.problems import Option, Step, blocked_summary, height_range
from placement.planning.results import Cost, InfeasibleStep, PlacedStep
from placement.planning.torso import option_robot
from placement.planning.verification import resting


def infeasible(step: Step, reason: str, diagnosis: dict[str, Any] | None = None) -> InfeasibleStep:
    """The result of a step that could not be planned, with its ``reason`` (one line)."""
    return InfeasibleStep(step.index, step.action, step.target, reason=reason, diagnosis=diagnosis or {})


def blocked_reason(opts: Sequence[Option]) -> str:
    """How many of the options the gripper alone rules out and the commonest culprit, in words ("" for none)."""
    summary = blocked_summary(opts)
    if summary is None:
        return ""
    n, first = summary
    culprit = first.blocked
    if n == len(opts):
        return f"the gripper collides at every candidate ({n}) wherever the base stands, mostly {culprit}"
    return f"{n} of {len(opts)} candidates are ruled out as the gripper alone collides there, mostly {culprit}"


def unreachable_reason(ctx: PlanningContext, opts: Sequence[Option]) -> str:
    """Why no placement of a step keeps the threshold, in words."""
    blocked = blocked_reason(opts)
    if opts and all(o.blocked is not None for o in opts):
        return blocked
    free = [o for o in opts if o.blocked is None]
    reason = _unreached(ctx, free)
    return f"{reason} ({blocked})" if blocked else reason


def _unreached(ctx: PlanningContext, opts: Sequence[Option]) -> str:
    if opts and all(o.out_of_range for o in opts):
        ranges = ", ".join(
            f"{arm} {lo:.2f}..{hi:.2f} m" for arm, (lo, hi) in ((a, height_range(m)) for a, m in ctx.maps.items())
        )
        z = sorted({round(float(v), 3) for o in opts for v in o.candidate.poses[:, 2, 3]})
        return (
            f"the TCP poses (heights {', '.join(f'{v:g}' for v in z)} m) are outside the height range of "
            f"the maps ({ranges} above the base frame)"
        )
    arms = sorted({o.arm for o in opts}) or sorted(ctx.maps)
    words = ", ".join(f"{a} {ctx.threshold_words(a)}" for a in arms)
    return f"no base placement reaches the target with the map thresholds ({words})"


def placed(
    ctx: PlanningContext,
    step: Step,
    o: Option,
    base: BasePose,
    qs: FloatArray,
    nav_c: float,
    heur_c: float,
    value: float,
    timings: dict[str, float],
    clearance_m: float | None = None,
) -> PlacedStep:
    """The result of a verified placement: weighted Eq. 6 terms, joints by name (``qs`` (P, n): the
    arm at every pose of the trajectory), travel time [s], clearance [m] (None without a collision
    check), and the rest of the robot's configuration as the collision check assumed it (the other
    arms idle, see :mod:`placement.planning.verification.configuration`)."""
    cfg = ctx.config
    arm = ctx.robot.arm(o.arm)
    q = qs[-1]
    joints = {name: float(v) for name, v in zip(arm.joints, q)}
    joints.update(option_robot(ctx, o).fixed_joints)
    cost = Cost(cfg.lambda_n * nav_c, cfg.lambda_m / value, cfg.lambda_nh * heur_c)
    c = o.candidate
    return PlacedStep(
        step.index,
        step.action,
        step.target,
        arm=o.arm,
        grasp=c.grasp or c.name,
        base=(base[0], base[1], base[2]),
        tcp=c.poses,
        q=q,
        qs=qs,
        joints=joints,
        clearance_m=clearance_m,
        manipulability=value,
        cost=cost,
        travel_time_s=nav_c / ctx.robot.v_max,
        timings_ms=timings,
        trajectory=c.name,
        object=step.carries,
        placed_pose=c.object_pose,
        support=c.support,
        resting=resting(ctx.robot, o.arm),
    )


__all__ = ["blocked_reason", "infeasible", "placed", "unreachable_reason"]
