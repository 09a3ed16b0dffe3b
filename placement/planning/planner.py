"""The planner of a scene: its robot, maps, world and per-step problems, and the methods over them.

The default path (``placement query SCENE``, method ``global``), one concept package each::

    Planner(scene)               robot and maps opened, thresholds resolved (problems.thresholds)
      world/                     the scene on the base grid: occupancy, distance, feasible cells per
                                 base yaw, the speed model (Eq. 4); the window on a building's map
      problems/                  per step: TCP trajectories (grasps, transfers), an Option per
                                 (arm, candidate, torso setting) with its manipulation map, cached
    Planner.plan()
      methods/optimal.py         ``global``: the whole task at once, over
        program/                 the regions of every step -> the forward program (exact least
                                 travel, Eq. 5 Dijkstras) -> verification of the chosen chain, a
                                 rejected placement repaired locally -> turns polished for the
                                 task time -> the certificate (lower bound on the travel)
        verification/            IK of every pose, collision verdicts, the robot's configuration
      results.py                 a PlacedStep or an InfeasibleStep per step, PlanResult (its to_json()
                                 is the plan document)

The step-by-step methods (the paper's ``sequential``, ``single-step``, ``irm`` and ``fixed``,
``methods/stepwise.py``) rank each step's cells by Eq. 6 (``methods/ranking.py``, with the heuristic
towards the next step, ``world/heuristic.py``) and search them with IK (``methods/search.py``). The
planner owns the state the stages read, one frozen :class:`~placement.planning.context.PlanningContext`,
and passes it to them; no stage sees the planner. ``updates.py`` computes the state after a scene
change, which the planner swaps in.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from placement.collision import SceneCollision
from placement.compile_clock import compile_seconds
from placement.errors import MapError, PlacementError
from placement.maps.opening import open_map
from placement.maps.rmap import ReachabilityMap
from placement.planning.arrays import Cell, FloatArray
from placement.planning.context import PlanningContext, resident_gib
from placement.planning.methods import DEFAULT_METHOD, METHODS, Method, method_named
from placement.planning.prepare import PREFETCH_SHARE, prefetch_polar, prefetch_slices, warm_checks, warm_kernels
from placement.planning.problems import StepProblems, Thresholds, base_yaws
from placement.planning.program import certify
from placement.planning.results import PlanResult, robot_info
from placement.planning.settings import PlannerConfig
from placement.planning.updates import apply_update
from placement.planning.world import BaseShape, World, windowed_world
from placement.robots import Robot, load_robot
from placement.scene import Scene, load_scene
from placement.storage import map_identity, open_store

log = logging.getLogger(__name__)


def default_maps_path(scene: Scene, robot: Robot) -> Path:
    """Where a scene without ``maps:`` finds its maps: ``maps/<robot name>`` in the scene file's
    directory or the nearest parent that has one, else in the working directory (MapError listing
    the places looked at when none has it)."""
    looked: list[Path] = []
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
        method: one of :data:`METHODS` (see :mod:`placement.planning.methods`).
        maps: reachability map path (default: the scene's ``maps``, else :func:`default_maps_path`).
        collisions: check every IK solution against the scene and the robot itself (URDF collision
            shapes, see :mod:`placement.collision`); False plans as the paper does, without.
        warm: call :meth:`warm` now (False: build only, e.g. to inspect the problems).

    Attributes (read them; change them through :meth:`set_method` and :meth:`update`):
        context: the :class:`~placement.planning.context.PlanningContext` the stages read; its
        fields are also attributes of the planner: scene, robot, maps (arm -> map), world, problems
        (the per-step cache), config (the method's), yaws ((K,) base yaws [rad]), collisions (the
        :class:`~placement.collision.SceneCollision` checker, or None), thresholds (arm -> map
        threshold) and setting_thresholds ((arm, torso value) -> map threshold of a map built once per
        torso setting), both views of the context's one
        :class:`~placement.planning.problems.thresholds.Thresholds`. base_config: the scene's configuration (its ``threshold`` the smallest of them). method: the :class:`~placement.planning.methods.base.Method` strategy
        (``method.name`` its name). map_path: the folder of the open maps.
    """

    def __init__(
        self,
        scene: Scene | str | Path,
        method: str = DEFAULT_METHOD,
        maps: str | Path | None = None,
        collisions: bool = True,
        warm: bool = True,
    ):
        began = time.perf_counter()
        compiled = compile_seconds()
        scene = scene if isinstance(scene, Scene) else load_scene(scene)
        # the planner block is checked before the maps are opened: its errors come first
        PlannerConfig.from_overrides(
            scene.planner, f"{scene.source}: planner" if scene.source is not None else "planner"
        )
        self.method: Method = method_named(method)
        robot = load_robot(scene.robot_preset)
        self.map_path = map_path = Path(maps or scene.maps or default_maps_path(scene, robot))
        self._map_identity = map_identity(map_path)
        rmaps = {arm: open_map(map_path, arm, robot) for arm in mapped_arms(map_path, robot)}
        self.maps_reopened = 0
        self._collisions = collisions
        self._contextualise(scene, robot, rmaps)
        if warm:
            self.warm()
        #: [s] what building this planner took (scene, robot, maps, world, warm-up; not compiling kernels
        #: on a cold cache, paid once per install): part of a task's time when it was built for that
        #: task (see :meth:`plan`'s ``spent_s``)
        self.construction_s = time.perf_counter() - began - (compile_seconds() - compiled)

    def warm(self) -> None:
        """Ready the planner for a fast first step: the kernels loaded (once per process), every map
        slice and witness slice the task's candidates use read, one witness lookup and one collision
        check per arm. The constructor calls it unless given ``warm=False``; planning without it
        gives the same plans, its first step paying for what this does."""
        warm_kernels(self.context.problems, self.robot)
        budget = PREFETCH_SHARE * self.context.config.time_budget_s
        if prefetch_slices(self.context.problems, budget):
            prefetch_polar(self.context, budget / 2)
        warm_checks(self.context)

    def _contextualise(self, scene: Scene, robot: Robot, rmaps: dict[str, ReachabilityMap]) -> None:
        """Make the planning state of ``scene`` over the open ``robot`` and maps ``rmaps``, and swap it in
        (only once all of it is made)."""
        where = f"{scene.source}: planner" if scene.source is not None else "planner"
        cfg = PlannerConfig.from_overrides(scene.planner, where)
        thresholds, cfg = Thresholds.resolve(cfg, rmaps)
        base_config = cfg
        checker = SceneCollision(robot, scene, padding=cfg.collision_padding) if self._collisions else None
        yaws = base_yaws(cfg.yaw_steps)
        base = BaseShape.of(robot, cfg.footprint_padding, yaws)
        world = windowed_world(scene, base, cfg, robot.v_max)
        problems = StepProblems(scene, world, rmaps, cfg, yaws, robot.gripper.max_opening, thresholds, checker)
        context = PlanningContext(
            scene, robot, rmaps, world, problems, self.method.configure(cfg), yaws, checker, thresholds
        )
        self.base_config, self.context = base_config, context

    def serves(self, scene: Scene, maps: str | Path | None = None) -> bool:
        """Whether :meth:`replace_scene` can take ``scene``: it names this planner's robot preset, and its
        maps (``maps``, else the scene's, else the default) are the ones open here."""
        if scene.robot_preset != self.scene.robot_preset:
            return False
        return Path(maps or scene.maps or default_maps_path(scene, self.robot)) == self.map_path

    def replace_scene(self, scene: Scene) -> None:
        """Plan ``scene`` from now on, with the robot and the maps open here (see :meth:`serves`):
        about 10 to 50 ms where a new planner opens its maps again. On error nothing changes."""
        if scene.robot_preset != self.scene.robot_preset:
            raise PlacementError(
                f"scene for robot '{scene.robot_preset}', but this planner's maps are of '{self.scene.robot_preset}'"
            )
        self._contextualise(scene, self.robot, dict(self.maps))

    # the context's fields, read-only
    @property
    def scene(self) -> Scene:
        return self.context.scene

    @property
    def robot(self) -> Robot:
        return self.context.robot

    @property
    def maps(self) -> Mapping[str, ReachabilityMap]:
        return self.context.maps

    @property
    def world(self) -> World:
        return self.context.world

    @property
    def problems(self) -> StepProblems:
        return self.context.problems

    @property
    def config(self) -> PlannerConfig:
        return self.context.config

    @property
    def thresholds(self) -> Mapping[str, float]:
        """arm -> its map threshold (map value), resolved at load from the scene's ``threshold`` or
        ``threshold_quantile`` (see :mod:`placement.planning.problems.thresholds`): the arm's own map's, which for
        a map with torso settings is the reference setting's (the preset's held value). A map built once
        per torso setting has one per setting (:attr:`setting_thresholds`); a shifted map's settings all
        keep the arm's. ``context.threshold(arm, torso)`` gives an option's."""
        return self.context.thresholds.arms

    @property
    def setting_thresholds(self) -> Mapping[tuple[str, float], float]:
        """(arm, torso value [rad]) -> the map threshold of that setting of a map built once per torso
        setting: the quantile of that setting's own map (empty when the scene gave ``threshold``, and
        for maps without torso settings or shifted ones)."""
        return self.context.thresholds.settings

    @property
    def yaws(self) -> FloatArray:
        return self.context.yaws

    @property
    def collisions(self) -> SceneCollision | None:
        return self.context.collisions

    @collisions.setter
    def collisions(self, checker: SceneCollision | None) -> None:
        """Plan with another collision check (anything with ``check`` as the scene checker's; None: none)."""
        self.context = replace(self.context, collisions=checker)

    def set_method(self, method: str) -> None:
        """Switch the method (its weights); maps, world and caches are kept."""
        strategy = method_named(method)
        self.context = replace(self.context, config=strategy.configure(self.base_config))
        self.method = strategy

    def follow_maps(self) -> bool:
        """Reopen the maps if they were rebuilt at :attr:`map_path` since this planner opened them (a
        build renames a new map over the old: the chunks read from now on are the new map's, which
        the old metadata would call corrupt). True when they were; MapError (naming the path) when
        the new map cannot be opened, and the planner stays on the maps it had. :meth:`plan` and
        :meth:`update` call it first."""
        now = map_identity(self.map_path)
        if now == self._map_identity:
            return False
        robot = self.robot
        try:
            rmaps = {arm: open_map(self.map_path, arm, robot) for arm in mapped_arms(self.map_path, robot)}
        except PlacementError as exc:
            raise MapError(
                f"the maps at {self.map_path} changed since this planner opened them and cannot be opened again: {exc}"
            ) from None
        self._contextualise(self.scene, robot, rmaps)
        self._map_identity = now
        self.maps_reopened += 1
        log.warning("the maps at %s were rebuilt since this planner opened them: reopened", self.map_path)
        return True

    def update(self, change: Any) -> dict[str, Any]:
        """Apply a scene change, redoing only what it invalidates; on error nothing changes.

        See :mod:`placement.planning.updates` for the vocabulary. Returns
        ``{"updated": [...], "timings_ms": {...}}`` (and ``"maps": "reopened"`` when the maps were
        rebuilt under the planner, see :meth:`follow_maps`).
        """
        reopened = self.follow_maps()
        self.context, report = apply_update(self.context, change)
        if reopened:
            report["maps"] = "reopened"
        return report

    def start_cell(self) -> Cell:
        """The grid cell of the scene's start pose (PlacementError if it is outside or blocked)."""
        x, y, yaw = self.scene.start
        try:
            cell = self.world.nav.cell(x, y)
        except PlacementError:
            raise PlacementError(f"start pose ({x}, {y}) is outside the planning grid") from None
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

    def plan(self, keep_maps: bool = False, spent_s: float = 0.0) -> PlanResult:
        """Plan every step from the scene's start pose; with ``keep_maps`` each step's layers are
        kept in ``StepResult.maps`` (for plots). ``spent_s``: seconds of the task's time budget
        already spent on it (a query that built this planner for the task passes
        :attr:`construction_s`): the plan and its certificate end within the rest."""
        self.follow_maps()
        start = self.start_cell()
        deadline = time.perf_counter() + self.context.config.time_budget_s - max(0.0, float(spent_s))
        now = resident_gib()
        limit = None if now is None else now + self.context.config.memory_budget_gib
        timed = replace(self.context, deadline=deadline, memory_limit=limit, spent=[])
        steps = self.method.plan(timed, start, keep_maps)
        cert = certify(timed, self.method, start, steps)
        return PlanResult(self.scene.name, self.method.name, robot_info(self.robot, self.maps), steps, None, cert)


def plan(scene: Scene | str | Path, method: str = DEFAULT_METHOD, maps: str | Path | None = None) -> PlanResult:
    """Plan a scene's whole task once: what ``Planner(scene, method, maps).plan()`` returns (its
    ``to_json()`` is the document of ``placement query --json``, :doc:`design`); building the planner
    counts against the task's ``time_budget_s``."""
    planner = Planner(scene, method, maps)
    return planner.plan(spent_s=planner.construction_s)


__all__ = ["DEFAULT_METHOD", "METHODS", "Planner", "default_maps_path", "mapped_arms", "plan"]
