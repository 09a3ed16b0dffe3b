"""The planner of a scene: its robot, maps, world layers and per-step cache, and the methods over them.

The stages, in the order a query runs them (one module each)::

    scene/ (parse) -> world.py (rasterise) -> problems.py (candidates, IRMs, cache)
      -> navigation.py / heuristic.py (cost maps) -> ranking.py (Eq. 6)
      -> verify.py (IK) -> results.py (typed results, JSON)

``methods/`` holds the methods as functions over these stages; ``updates.py`` applies scene
changes to a live planner.
"""

from __future__ import annotations

import os
from pathlib import Path

from placement.collision import SceneCollision
from placement.errors import MapError, PlacementError
from placement.maps.rmap import ReachabilityMap, open_map
from placement.planning.config import METHODS, PlannerConfig
from placement.planning.footprints import BaseShape
from placement.planning.manipulation import base_yaws
from placement.planning.methods.fixed import rank_fixed
from placement.planning.methods.optimal import plan_optimal
from placement.planning.methods.stepwise import plan_stepwise, rank_eq6
from placement.planning.prepare import prefetch_slices, warm_checks, warm_kernels
from placement.planning.problems import StepProblems
from placement.planning.results import PlanResult, robot_info
from placement.planning.updates import apply_update
from placement.planning.world import World, build_world
from placement.robots import Robot, load_robot
from placement.scene import Scene, load_scene
from placement.storage import open_store


def default_maps_path(scene: Scene, robot: Robot) -> Path:
    """Where a scene without ``maps:`` finds its maps: ``maps/<robot name>`` in the scene file's
    directory or the nearest parent that has one, else in the working directory (MapError listing
    the places looked at when none has it)."""
    looked = []
    if scene.source is not None:
        d = Path(os.path.abspath(scene.source)).parent
        for folder in (d, *d.parents):
            looked.append(folder / "maps" / robot.name)
            if looked[-1].exists():
                return looked[-1]
    cwd = Path("maps") / robot.name
    if cwd.exists():
        return cwd
    looked.append(Path(os.path.abspath(cwd)))
    raise MapError(
        f"no maps for robot '{robot.name}': the scene has no 'maps' key and none of "
        f"{', '.join(str(p) for p in dict.fromkeys(looked))} exists (build them with `make maps` or "
        "`placement maps build`, or pass --maps)"
    )


def mapped_arms(path: Path, robot: Robot) -> list[str]:
    """The robot's arms that the map at ``path`` holds (MapError if none)."""
    store = open_store(path)
    try:
        arms = [a for a in robot.arms if a in (store.root.get("arms") or [])]
    finally:
        store.close()
    if not arms:
        raise MapError(f"{path}: no map for any arm of robot '{robot.name}' (arms: {', '.join(robot.arms)})")
    return arms


class Planner:
    """A long-lived planner for one scene.

    Args:
        scene: a :class:`Scene` or the path of a scene file.
        method: one of :data:`METHODS` (see :meth:`PlannerConfig.for_method`).
        maps: reachability map path (default: the scene's ``maps``, else :func:`default_maps_path`).
        collisions: check every IK solution against the scene and the robot itself (URDF collision
            shapes, see :mod:`placement.collision`); False plans as the paper does, without.

    Attributes (read them; change them through :meth:`set_method` and :meth:`update`):
        scene, robot, maps (arm -> map), base_config (the scene's configuration), config (the
        method's), method, world, yaws ((K,) base yaws [rad]), problems (the per-step cache),
        collisions (the :class:`~placement.collision.SceneCollision` checker, or None).
    """

    def __init__(
        self,
        scene: Scene | str | Path,
        method: str = "sequential",
        maps: str | Path | None = None,
        collisions: bool = True,
    ):
        self.scene: Scene = scene if isinstance(scene, Scene) else load_scene(scene)
        self.base_config = PlannerConfig.from_overrides(self.scene.planner)
        self.set_method(method)
        self.robot: Robot = load_robot(self.scene.robot_preset)
        map_path = Path(maps or self.scene.maps or default_maps_path(self.scene, self.robot))
        self.maps: dict[str, ReachabilityMap] = {
            arm: open_map(map_path, arm, self.robot) for arm in mapped_arms(map_path, self.robot)
        }
        self.collisions = (
            SceneCollision(self.robot, self.scene, padding=self.base_config.collision_padding) if collisions else None
        )
        self.yaws = base_yaws(self.base_config.yaw_steps)
        base = BaseShape.of(self.robot, self.base_config.footprint_padding, self.yaws)
        self.world: World = build_world(self.scene, base, self.base_config)
        self.problems = StepProblems(self.scene, self.world, self.maps, self.base_config, self.yaws)
        # once per planner: kernels loaded and slices read here, not in the first step
        warm_kernels(self.problems, self.robot)
        prefetch_slices(self.problems)
        warm_checks(self)

    def set_method(self, method: str) -> None:
        """Switch the method (its weights); maps, world and caches are kept."""
        self.config = self.base_config.for_method(method)
        self.method = method

    def update(self, change: dict) -> dict:
        """Apply a scene change, redoing only what it invalidates; on error nothing changes.

        See :mod:`placement.planning.updates` for the vocabulary. Returns
        ``{"updated": [...], "timings_ms": {...}}``.
        """
        return apply_update(self, change)

    def replace_state(self, scene: Scene, world: World, problems: StepProblems) -> None:
        """Swap in a changed scene with its world and cache (all checked by the caller)."""
        self.scene, self.world, self.problems = scene, world, problems
        if self.collisions is not None:
            self.collisions.update(scene)

    def start_cell(self) -> tuple[int, int]:
        """The grid cell of the scene's start pose (PlacementError if it is outside or blocked)."""
        x, y, yaw = self.scene.start
        try:
            cell = self.world.nav.cell(x, y)
        except PlacementError:
            raise PlacementError(f"start pose ({x}, {y}) is outside the scene bounds") from None
        if self.robot.footprint is not None:
            if not self.world.pose_clear(x, y, yaw):
                raise PlacementError(
                    f"start pose ({x:.2f}, {y:.2f}, {yaw:.2f} rad) is inside an obstacle or the base "
                    f"footprint comes closer than footprint_padding "
                    f"{self.base_config.footprint_padding} m to one"
                )
            if not self.world.feasible[cell]:
                raise PlacementError(
                    f"start pose ({x:.2f}, {y:.2f}): the base footprint does not fit at the centre "
                    f"of its grid cell at any of the {len(self.yaws)} base yaws"
                )
        elif not self.world.feasible[cell]:
            raise PlacementError(
                f"start pose ({x:.2f}, {y:.2f}) is inside an obstacle or closer than the base "
                f"footprint radius {self.robot.footprint_radius} m to one"
            )
        return cell

    def plan(self, keep_maps: bool = False) -> PlanResult:
        """Plan every step from the scene's start pose; with ``keep_maps`` each step's layers are
        kept in ``StepResult.maps`` (for plots)."""
        start = self.start_cell()
        if self.method == "optimal":
            steps = plan_optimal(self, start, keep_maps)
        else:
            steps = plan_stepwise(self, start, rank_fixed if self.method == "fixed" else rank_eq6, keep_maps)
        return PlanResult(self.scene.name, self.method, robot_info(self.robot, self.maps), steps)


def plan(scene: Scene | str | Path, method: str = "sequential", maps: str | Path | None = None) -> dict:
    """Plan a scene's whole task (SPEC section 9): the JSON document of SPEC section 7 as a dict."""
    return Planner(scene, method, maps).plan().to_json()


__all__ = ["METHODS", "Planner", "default_maps_path", "mapped_arms", "plan"]
