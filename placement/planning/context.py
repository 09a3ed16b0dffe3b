"""The state the planning stages read: one frozen object per scene, method and update.

The :class:`~placement.planning.planner.Planner` owns a :class:`PlanningContext` and swaps in a new
one when the method changes (another ``config``) or an update applies (another ``scene``,
``world`` and ``problems``); the stages (methods, search, explain, updates) receive it instead of
the planner, so they depend on what they read and never on the planner.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from placement.collision import SceneCollision
from placement.maps.rmap import ReachabilityMap
from placement.planning.arrays import FloatArray
from placement.planning.config import PlannerConfig
from placement.planning.problems import StepProblems
from placement.planning.world import World
from placement.robots import Robot
from placement.scene import Scene


@dataclass(frozen=True)
class PlanningContext:
    """What planning a scene reads.

    Attributes:
        scene: the scene (as updated). robot: the robot of its preset.
        maps: arm -> reachability map (the mapped arms only).
        world: the scene's navigation layers. problems: the per-step cache (IRMs, heuristics).
        config: the method's configuration (its weights over the scene's ``planner:`` block).
        yaws: (K,) base yaws tried per cell [rad].
        collisions: the scene collision checker, or None (planning without collision checks).
        thresholds: arm -> its map threshold (map value), resolved at load (see
            :mod:`placement.planning.thresholds`); an arm not in it uses ``config.threshold``.
        torso_checks: torso value [m] -> the collision check of the robot with its lift there
            (built on first use, see :mod:`placement.planning.torso`; updated with ``collisions``).
    """

    scene: Scene
    robot: Robot
    maps: Mapping[str, ReachabilityMap]
    world: World
    problems: StepProblems
    config: PlannerConfig
    yaws: FloatArray
    collisions: SceneCollision | None = None
    thresholds: Mapping[str, float] = field(default_factory=dict)
    torso_checks: dict[float, SceneCollision] = field(default_factory=dict)

    def threshold(self, arm: str) -> float:
        """The map value below which a placement of ``arm`` is infeasible (dimensionless)."""
        return self.thresholds.get(arm, self.config.threshold)


__all__ = ["PlanningContext"]
