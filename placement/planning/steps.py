"""The manipulation steps of a task and their TCP trajectory candidates."""

from __future__ import annotations

from dataclasses import dataclass

from .config import PlannerConfig
from .grasps import Candidate, place_candidates, top_grasps
from .scene import Scene


@dataclass(frozen=True)
class Step:
    """Step ``index`` of the task: ``action`` "pick" (an object) or "place" (at a place location)."""

    index: int
    action: str
    target: str


def task_steps(scene: Scene) -> list[Step]:
    """Every manipulation step of the scene's task, in order (a pick, then its place)."""
    out: list[Step] = []
    for t in scene.task:
        out += [Step(len(out), "pick", t.pick), Step(len(out) + 1, "place", t.place)]
    return out


def step_candidates(scene: Scene, step: Step, config: PlannerConfig) -> list[Candidate]:
    """The TCP trajectories (world frame) that would do ``step``: grasps of the object, or place
    trajectories at the location's gripper yaws."""
    if step.action == "pick":
        o = scene.object(step.target)
        return top_grasps(o.position, o.yaw, o.size)
    return place_candidates(scene.place_location(step.target).position, config.grasp_yaws)
