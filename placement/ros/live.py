"""The state behind ``placement ros serve``, without ROS: one live planner fed by changes.

What a robot sends becomes a change of the scene, applied all or nothing, each answered by a
:class:`Outcome` (applied or refused, why, how long it took):

* a whole scene (a scene file's text, or a :class:`~placement.scene.Scene`) replaces the task;
* the robot's occupancy map (``/map``, its values as :class:`~placement.scene.occupancy.GridValues`)
  replaces the scene's ``occupancy_map`` (the live map wins over the file's from then on, also for
  later scenes);
* an object moved, the start moved: the same updates as ``placement query --stream``
  (:mod:`placement.planning.updates`), so a re-plan equals a fresh query of the changed scene.

A new scene or map makes a new :class:`~placement.planning.Planner` (about 0.1 s with the kernels
compiled: the maps stay open in the process's cache); moves update the live one. A refused change
leaves everything as it was.
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from placement.errors import PlacementError
from placement.planning import Planner, PlanResult, StepResult
from placement.scene import Scene, SceneError, check_scene, parse_scene
from placement.scene.grid_values import OCCUPIED_PERCENT, GridValues
from placement.scene.limits import MAX_SCENE_BYTES, default_bounds
from placement.scene.model import TaskStep, Trajectory
from placement.scene.occupancy import DEFAULT_UNKNOWN_COST
from placement.scene.poses import quaternion_matrix
from placement.validation import one_line, parse_yaml

#: The name a scene received as text gets in the plan document (a file's is its stem).
TEXT_SCENE_NAME = "scene"
#: The trajectory name a single-pose reach question gets (a free name is made from it).
REACH_NAME = "reach_goal"
#: [rad] an object of a version 1 scene may only turn about z: a quaternion tilting it more is refused.
TILT_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Outcome:
    """What became of one change: ``status`` "applied" or "refused"; ``source`` where it came from
    (a topic name); ``error`` the one-line reason of a refusal; ``updated`` what changed;
    ``timings_ms`` per stage [ms]."""

    source: str
    status: str
    error: str | None = None
    updated: tuple[str, ...] = ()
    timings_ms: dict[str, float] = field(default_factory=dict)

    @property
    def applied(self) -> bool:
        return self.status == "applied"

    def to_json(self) -> dict[str, Any]:
        doc: dict[str, Any] = {"source": self.source, "status": self.status}
        if self.error is not None:
            doc["error"] = self.error
        if self.updated:
            doc["updated"] = list(self.updated)
        doc["timings_ms"] = {k: round(v, 3) for k, v in self.timings_ms.items()}
        return doc


def first_line(exc: BaseException) -> str:
    """The first line of an error's message (its type when it has none)."""
    return one_line((str(exc).splitlines() or [type(exc).__name__])[0])


def scene_from_text(text: str, origin_dir: str | Path, source: str = "~/scene") -> Scene:
    """A scene file's text as a :class:`Scene` named :data:`TEXT_SCENE_NAME`, relative paths against
    ``origin_dir``; :class:`SceneError` (one line) for anything that is not a valid scene."""
    size = len(text.encode("utf-8", "surrogatepass"))
    if size > MAX_SCENE_BYTES:
        raise SceneError(f"{source}: {size:,} bytes, more than the {MAX_SCENE_BYTES:,} a scene may hold")
    if not text.strip():
        raise SceneError(f"{source}: the scene is empty")
    return parse_scene(parse_yaml(text, source, SceneError), origin_dir, TEXT_SCENE_NAME, source=source)


@dataclass(frozen=True)
class MapPolicy:
    """How a live map's values become occupancy, unless the scene's ``occupancy_map`` says: unknown
    cells ``occupied``, ``free`` or ``cost`` (``unknown_cost`` times a free cell's travel cost), and
    cells at or above ``occupied_percent`` occupied."""

    unknown: str = "occupied"
    occupied_percent: int = OCCUPIED_PERCENT
    unknown_cost: float = DEFAULT_UNKNOWN_COST


def with_occupancy(scene: Scene, grid: GridValues, policy: MapPolicy = MapPolicy()) -> Scene:
    """``scene`` on the live map ``grid`` instead of its own occupancy map (whose choices for unknown
    cells and the arm, when it has one, hold for the live map; else ``policy``'s); bounds made anew
    unless the scene file gave them. :class:`SceneError` when the scene does not fit (e.g. its start)."""
    own = scene.occupancy
    if own is not None:
        occupancy = replace(
            grid.occupancy(own.unknown, policy.occupied_percent, own.unknown_cost), arm_height=own.arm_height
        )
    else:
        occupancy = grid.occupancy(policy.unknown, policy.occupied_percent, policy.unknown_cost)
    changed = replace(scene, occupancy=occupancy, occupancy_map=None)
    if not scene.bounds_given:
        changed = replace(changed, bounds=default_bounds(changed))
    return check_scene(changed, str(scene.source or scene.name))


def upright_yaw(q: npt.ArrayLike, what: str) -> float:
    """The yaw [rad] of the unit quaternion ``q`` [x, y, z, w], which must turn about z only."""
    R = quaternion_matrix(np.asarray(q, dtype=float))
    tilt = math.acos(min(1.0, max(-1.0, float(R[2, 2]))))
    if tilt > TILT_TOLERANCE:
        raise PlacementError(
            f"{what}: the orientation tilts {math.degrees(tilt):.3g} deg from upright; a version 1 scene's "
            "objects and the base turn about z only (send a version 2 scene for tilted objects)"
        )
    return math.atan2(float(R[1, 0]), float(R[0, 0]))


class LivePlanner:
    """One planner for a stream of changes (see the module docstring).

    Args:
        maps: the reachability maps (None: each scene's ``maps``, else the default).
        method: the planning method.
        robot: the robot preset every scene is planned for (None: each scene's own).
        origin_dir: the folder relative paths in scene texts are resolved against.
        policy: how the live map's values become occupancy (:class:`MapPolicy`).
    """

    def __init__(
        self,
        maps: str | Path | None = None,
        method: str = "global",
        robot: str | None = None,
        origin_dir: str | Path = ".",
        policy: MapPolicy = MapPolicy(),
    ):
        self.maps = None if maps is None else Path(maps)
        self.method = method
        self.robot = robot
        self.origin_dir = Path(origin_dir)
        self.policy = policy
        self.planner: Planner | None = None
        self.scene: Scene | None = None  # as given, without the live map
        self.grid: GridValues | None = None  # the live map, once one came

    def _planner(self, scene: Scene, grid: GridValues | None) -> Planner:
        """The planner of ``scene`` on the live map ``grid``: the live one with the new scene when it serves
        (same robot and maps, which stay open), else a new one."""
        if self.robot is not None:
            scene = replace(scene, robot_preset=self.robot)
        if grid is not None:
            scene = with_occupancy(scene, grid, self.policy)
        if self.planner is not None and self.planner.serves(scene, self.maps):
            self.planner.replace_scene(scene)
            return self.planner
        return Planner(scene, self.method, self.maps)

    def _outcome(self, source: str, fn: Any, *args: Any) -> Outcome:
        t = time.perf_counter()
        try:
            updated = fn(*args)
        except PlacementError as exc:
            return Outcome(source, "refused", first_line(exc), timings_ms={"total": (time.perf_counter() - t) * 1e3})
        return Outcome(source, "applied", None, tuple(updated), {"total": (time.perf_counter() - t) * 1e3})

    def set_scene(self, scene: Scene | str, source: str = "~/scene") -> Outcome:
        """Replace the task with ``scene`` (a :class:`Scene` or a scene file's text)."""

        def apply() -> list[str]:
            s = scene_from_text(scene, self.origin_dir, source) if isinstance(scene, str) else scene
            self.planner = self._planner(s, self.grid)
            self.scene = s
            return ["scene"]

        return self._outcome(source, apply)

    def set_map(self, grid: GridValues, source: str = "/map") -> Outcome:
        """Plan on the live map ``grid`` from now on (kept for later scenes too)."""

        def apply() -> list[str]:
            if self.scene is not None:
                self.planner = self._planner(self.scene, grid)
            self.grid = grid
            return ["map"]

        return self._outcome(source, apply)

    def _live(self) -> Planner:
        if self.planner is None:
            raise PlacementError("no scene yet: publish a scene file's text on ~/scene (or start with a SCENE)")
        return self.planner

    def _update(self, change: dict[str, Any]) -> list[str]:
        """``change`` applied to the live planner, and kept in :attr:`scene` (a later map or robot
        change rebuilds the planner from it)."""
        planner = self._live()
        report = planner.update(change)
        assert self.scene is not None  # a planner has its scene
        self.scene = replace(self.scene, objects=planner.scene.objects, start=planner.scene.start)
        return list(report["updated"])

    def move_object(self, name: str, position: npt.ArrayLike, orientation: npt.ArrayLike, source: str) -> Outcome:
        """Move object ``name`` to ``position`` (3,) [m] turned by ``orientation`` (4,) [x, y, z, w]."""

        def apply() -> list[str]:
            planner = self._live()
            item: dict[str, Any] = {"name": name, "position": [float(v) for v in np.asarray(position)]}
            if planner.scene.version >= 2:
                item["orientation"] = [float(v) for v in np.asarray(orientation)]
            else:
                item["yaw"] = upright_yaw(orientation, source)
            return self._update({"objects": [item]})

        return self._outcome(source, apply)

    def move_start(self, x: float, y: float, yaw: float, source: str) -> Outcome:
        """Start the task from base pose (x [m], y [m], yaw [rad])."""

        def apply() -> list[str]:
            return self._update({"start": [x, y, yaw]})

        return self._outcome(source, apply)

    def plan(self) -> PlanResult:
        """The plan of the live scene (PlacementError when there is none, or its start is blocked)."""
        return self._live().plan()

    def reach(self, position: npt.ArrayLike, orientation: npt.ArrayLike) -> StepResult:
        """The best base placement for one TCP pose (``position`` (3,) [m], ``orientation`` (4,)
        [x, y, z, w], world frame) from the live scene's start, IK and collisions verified: the scene's
        task replaced by one reach of that pose, planned over the live planner's open robot and maps
        (a copy of it: the live planner keeps its scene)."""
        live = self._live()
        scene = live.scene
        names = {t.name for t in scene.trajectories}
        name = next(n for n in (f"{REACH_NAME}{'' if i == 0 else i}" for i in range(len(names) + 1)) if n not in names)
        pose = np.concatenate([np.asarray(position, dtype=float), np.asarray(orientation, dtype=float)])[None, :]
        one = replace(
            scene,
            version=max(scene.version, 2),
            trajectories=(*scene.trajectories, Trajectory(name, pose)),
            task=(TaskStep(reach=(name,)),),
        )
        asked = copy.copy(live)
        asked.replace_scene(one)
        return asked.plan().steps[0]
