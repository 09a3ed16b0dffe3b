"""The manipulation steps of a task and their TCP trajectory candidates."""

from __future__ import annotations

from dataclasses import dataclass

from .config import PlannerConfig
from .grasps import Candidate, box_grasps, in_world, oriented_places, place_candidates, top_grasps
from .scene import Scene, SceneObject


@dataclass(frozen=True)
class Step:
    """Step ``index`` of the task: ``action`` "pick" (an object), "place" (at a place location) or
    "reach" (one of the named trajectories ``options``; ``target`` is their names joined by ",")."""

    index: int
    action: str
    target: str
    options: tuple[str, ...] = ()


def task_steps(scene: Scene) -> list[Step]:
    """Every manipulation step of the scene's task, in order (a pick, then its place; or a reach)."""
    out: list[Step] = []
    for t in scene.task:
        if t.reach:
            out.append(Step(len(out), "reach", ",".join(t.reach), t.reach))
        else:
            out += [Step(len(out), "pick", t.pick), Step(len(out) + 1, "place", t.place)]
    return out


def object_grasps(o: SceneObject, version: int) -> list[Candidate]:
    """The grasps (world frame) of ``o``: its own, else generated: top grasps as in version 1 scenes,
    top and side grasps of the box in any orientation in version 2."""
    if o.grasps:
        return [in_world(g.name, o.pose, g.matrices()) for g in o.grasps]
    if version < 2:
        return top_grasps(o.position, o.yaw, o.size)
    return box_grasps(o.pose, o.size)


def step_candidates(scene: Scene, step: Step, config: PlannerConfig) -> list[Candidate]:
    """The TCP trajectories (world frame) that would do ``step``: grasps of the object, place
    trajectories at the location's orientations or gripper yaws, or the named trajectories."""
    if step.action == "pick":
        return object_grasps(scene.object(step.target), scene.version)
    if step.action == "reach":
        return [Candidate(n, scene.trajectory(n).matrices()) for n in step.options]
    loc = scene.place_location(step.target)
    if loc.orientations is not None:
        return oriented_places(loc.position, loc.orientations)
    return place_candidates(loc.position, config.grasp_yaws)
