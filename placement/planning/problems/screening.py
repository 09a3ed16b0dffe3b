"""Candidates the gripper alone rules out, before any map, IK or base pose.

The shapes of a gripper move rigidly with its TCP (the fingers held at the opening every collision
check holds them at). A candidate trajectory one of whose poses puts those shapes into a table or
another object collides at every base pose, with every arm configuration that reaches it: its
manipulation maps, its IK and its collision checks would be spent for nothing. A step's candidates
are screened once per arm (:meth:`~placement.collision.SceneCollision.gripper_collisions`), and the
ones it rules out keep an option without a map that names the culprit (``Option.blocked``), so that
an infeasible step can say that every grasp puts the hand into the table.

The screen never rules out what verification could accept: an IK solution puts the TCP within
``ik_pos_tol_m`` and ``ik_rot_tol_rad`` of its target, which moves a point of the gripper at most
``ik_pos_tol_m + ik_rot_tol_rad * r`` (``r``: its distance from the TCP). A candidate is ruled out
only where the gripper comes that much closer to the scene than the collision padding allows.
Published grasp sets (grasps from every side of an object) lose a third to a half of their candidates
to it on the building scenes: those from below or through the table top.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from placement.collision import SceneCollision
from placement.collision.tables import CollisionResult
from placement.planning.problems.grasps import Candidate
from placement.planning.problems.option import Option
from placement.planning.problems.steps import Step, pose_role
from placement.planning.settings import PlannerConfig


def step_objects(steps: Sequence[Step], step: Step) -> tuple[str | None, list[str]]:
    """(the object the gripper may touch, the objects no longer where the scene has them) in the
    collision checks of ``step`` of ``steps``: a pick's gripper touches what it grasps; objects picked
    before are gone (a place's own object among them: it is in the hand)."""
    gone = [s.target for s in steps[: step.index] if s.action == "pick"]
    if step.action == "pick":
        return step.target, [g for g in gone if g != step.target]
    return None, gone


def screen_slack(checker: SceneCollision, arm: str, config: PlannerConfig) -> float:
    """How far [m] a verified IK solution may move a point of ``arm``'s gripper from where its
    candidate puts it: the IK's position tolerance plus its rotation tolerance times the gripper's
    reach from the TCP."""
    return config.ik_pos_tol_m + config.ik_rot_tol_rad * checker.gripper_reach(arm)


def screen(
    checker: SceneCollision,
    config: PlannerConfig,
    steps: Sequence[Step],
    step: Step,
    arm: str,
    candidates: Sequence[Candidate],
) -> list[CollisionResult | None]:
    """Per candidate of ``step``: the collision of ``arm``'s gripper alone that rules it out, or None."""
    grasped, gone = step_objects(steps, step)
    slack = screen_slack(checker, arm, config)
    return checker.gripper_collisions(arm, [c.poses for c in candidates], slack, grasped, gone)


def blocked_words(culprit: str, pose: int | None, action: str, poses: int) -> str:
    """``culprit`` at pose ``pose`` of a ``action`` trajectory of ``poses`` poses, in words."""
    return culprit if pose is None else f"{culprit} at the {pose_role(action, pose, poses)} pose"


def blocked_summary(opts: Sequence[Option]) -> tuple[int, Option] | None:
    """(how many of ``opts`` the gripper rules out, the first of those with the commonest culprit), or
    None when it rules out none."""
    why = Counter(o.blocked for o in opts if o.blocked is not None)
    if not why:
        return None
    culprit = why.most_common(1)[0][0]
    return sum(why.values()), next(o for o in opts if o.blocked == culprit)


__all__ = ["blocked_summary", "blocked_words", "screen", "screen_slack", "step_objects"]
