"""The manipulation steps of a task and their TCP trajectory candidates."""

from __future__ import annotations

from dataclasses import dataclass

from placement.errors import PlacementError
from placement.planning.problems.grasps import GRIPPER_OPENING, Candidate, box_grasps, in_world, top_grasps
from placement.planning.problems.transfer import transfer_places
from placement.planning.settings import PlannerConfig
from placement.scene import Scene, SceneObject


@dataclass(frozen=True)
class Step:
    """Step ``index`` of the task: ``action`` "pick" (an object), "place" (at a place location) or
    "reach" (one of the named trajectories ``options``; ``target`` is their names joined by ",").

    ``carries``: the object a pick takes or a place sets down (None for a reach); ``pick``: a
    place's pick step index (the transfer: same arm, same grasp)."""

    index: int
    action: str
    target: str
    options: tuple[str, ...] = ()
    carries: str | None = None
    pick: int | None = None


def pose_role(action: str, index: int, count: int) -> str:
    """The role of pose ``index`` of ``count`` in a trajectory of a ``action`` step, in words."""
    names = {"pick": ("pre-grasp", "grasp"), "place": ("pre-place", "place")}.get(action)
    if names and index == 0 and count > 1:
        return names[0]
    if names and index == count - 1:
        return names[1]
    return f"trajectory pose {index}"


def task_steps(scene: Scene) -> list[Step]:
    """Every manipulation step of the scene's task, in order (a pick, then its place; or a reach)."""
    out: list[Step] = []
    for t in scene.task:
        if t.reach:
            out.append(Step(len(out), "reach", ",".join(t.reach), t.reach))
        elif t.pick is not None and t.place is not None:
            i = len(out)
            out += [Step(i, "pick", t.pick, carries=t.pick), Step(i + 1, "place", t.place, carries=t.pick, pick=i)]
    return out


def object_grasps(o: SceneObject, version: int, opening_m: float = GRIPPER_OPENING) -> list[Candidate]:
    """The grasps (world frame) of ``o``: its own, else generated: top grasps as in version 1 scenes,
    top and side grasps of the box in any orientation in version 2, across chords of at most
    ``opening_m`` [m] (the gripper's widest opening). Each holds the object by itself (``grasp``
    is its name)."""
    if o.grasps:
        found = [in_world(g.name, o.pose, g.matrices()) for g in o.grasps]
    elif version < 2:
        found = top_grasps(o.position, o.yaw, o.size)
    else:
        found = box_grasps(o.pose, o.size, opening_m)
    return [Candidate(c.name, c.poses, grasp=c.name) for c in found]


def step_candidates(
    scene: Scene, step: Step, config: PlannerConfig, opening_m: float = GRIPPER_OPENING
) -> list[Candidate]:
    """The TCP trajectories (world frame) that would do ``step``: grasps of the object (for a
    gripper opening at most ``opening_m`` [m]), the object's grasps carried to its allowed poses at
    the place location (:mod:`.transfer`), or the named trajectories."""
    if step.action == "pick":
        return object_grasps(scene.object(step.target), scene.version, opening_m)
    if step.action == "reach":
        return [Candidate(n, scene.trajectory(n).matrices()) for n in step.options]
    if step.carries is None:
        raise PlacementError(f"step {step.index}: a place step without the object it sets down")
    obj = scene.object(step.carries)
    return transfer_places(
        scene, obj, scene.place_location(step.target), object_grasps(obj, scene.version, opening_m), config.grasp_yaws
    )
