"""The state the planning stages read: one frozen object per scene, method and update.

The :class:`~placement.planning.planner.Planner` owns a :class:`PlanningContext` and swaps in a new
one when the method changes (another ``config``) or an update applies (another ``scene``,
``world`` and ``problems``); the stages (methods, search, explain, updates) receive it instead of
the planner, so they depend on what they read and never on the planner.
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from placement.collision import SceneCollision
from placement.maps.rmap import ReachabilityMap
from placement.planning.arrays import FloatArray
from placement.planning.problems import Option, Step, StepProblems, Thresholds, held_object, step_objects
from placement.planning.settings import PlannerConfig
from placement.planning.world import World
from placement.robots import Robot
from placement.scene import Scene


class BudgetSpent(Exception):
    """The task's time or memory budget ran out inside a computation that has no partial result (a
    whole-task program's solve, the regions of every step): raised by
    :meth:`PlanningContext.check_budget`, caught by the method, which keeps the steps verified before."""


def resident_gib() -> float | None:
    """The process's resident memory [GiB] now (``/proc/self/statm``), or None where it cannot be read
    (not Linux): the memory budget then does not apply."""
    try:
        with open("/proc/self/statm", "rb") as f:
            pages = int(f.read().split()[1])
    except (OSError, ValueError, IndexError):
        return None
    return pages * _PAGE / 2**30


try:
    _PAGE = os.sysconf("SC_PAGE_SIZE")
except (AttributeError, OSError, ValueError):  # not POSIX
    _PAGE = 4096


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
        thresholds: the map thresholds (map values) per arm and torso setting, resolved at load (see
            :mod:`placement.planning.problems.thresholds`); the same value as ``problems.thresholds``
            unless :meth:`for_step` lowered them.
        torso_checks: torso value [m] -> the collision check of the robot with its lift there
            (built on first use, see :mod:`placement.planning.torso`; updated with ``collisions``).
        deadline: ``time.perf_counter()`` after which the running plan stops (None: none); set by
            :meth:`Planner.plan <placement.planning.planner.Planner.plan>` from ``time_budget_s``.
        memory_limit: the process's resident memory [GiB] past which the running plan stops (None:
            none); set by :meth:`Planner.plan <placement.planning.planner.Planner.plan>` to the memory at
            its start plus ``memory_budget_gib``.
        spent: the budget that ran out, once one did (:meth:`spent_budget`; one list per plan, shared by
            the contexts :meth:`for_step` derives, so that every later check says the same budget).
    """

    scene: Scene
    robot: Robot
    maps: Mapping[str, ReachabilityMap]
    world: World
    problems: StepProblems
    config: PlannerConfig
    yaws: FloatArray
    collisions: SceneCollision | None = None
    thresholds: Thresholds = field(default_factory=Thresholds)
    torso_checks: dict[float, SceneCollision] = field(default_factory=dict)
    deadline: float | None = None
    memory_limit: float | None = None
    spent: list[tuple[str, str]] = field(default_factory=list)

    def for_step(self, i: int) -> PlanningContext:
        """The context step i is planned in: this one, or with every threshold multiplied by
        ``problems.relaxed(i)`` when no option of the step keeps its threshold anywhere."""
        r = self.problems.relaxed(i)
        if r >= 1.0:
            return self
        return replace(
            self,
            config=replace(self.config, threshold=self.config.threshold * r),
            thresholds=self.thresholds.relaxed(r),
        )

    def spent_budget(self) -> tuple[str, str] | None:
        """The budget that has run out, (what it is, how to raise it) in words, or None: the time
        (``deadline``) or the memory (``memory_limit``); once one has run out, that one."""
        if self.spent:
            return self.spent[0]
        if self.deadline is not None and time.perf_counter() > self.deadline:
            self.spent.append(
                (
                    f"the task's time budget of {self.config.time_budget_s:g} s",
                    "raise planner.time_budget_s to plan longer",
                )
            )
        elif self.memory_limit is not None:
            now = resident_gib()
            if now is not None and now > self.memory_limit:
                self.spent.append(
                    (
                        f"the task's memory budget of {self.config.memory_budget_gib:g} GiB",
                        "raise planner.memory_budget_gib to plan further",
                    )
                )
        return self.spent[0] if self.spent else None

    def out_of_budget(self) -> bool:
        """Whether the plan's time or memory budget has run out (:meth:`spent_budget`)."""
        return self.spent_budget() is not None

    def check_budget(self) -> None:
        """Raise :class:`BudgetSpent` when the plan's time or memory budget has run out."""
        if self.out_of_budget():
            raise BudgetSpent(self.budget_words())

    def budget(self) -> tuple[str, str]:
        """The budget that ran out, (what it is, how to raise it) in words: :meth:`spent_budget`'s, or the
        time budget's while none has."""
        return self.spent_budget() or (
            f"the task's time budget of {self.config.time_budget_s:g} s",
            "raise planner.time_budget_s to plan longer",
        )

    def budget_words(self) -> str:
        """Why a step was not planned when :meth:`out_of_budget`."""
        what, how = self.budget()
        return f"{what} ran out before this step was verified ({how})"

    def threshold(self, arm: str, torso: float | None = None) -> float:
        """The map value below which a placement of ``arm`` with the torso at ``torso`` [m or rad] (an
        option's ``torso``; None: the arm's own map) is infeasible (dimensionless)."""
        return self.thresholds.at(arm, torso)

    def option_threshold(self, o: Option) -> float:
        """The map value below which a placement of option ``o`` (its arm at its torso setting) is
        infeasible (dimensionless)."""
        return self.thresholds.of(o)

    def threshold_words(self, arm: str) -> str:
        """``arm``'s threshold in words: one value, or one per torso setting of a map built once per
        setting ("0.0123 at torso 0, 0.0151 at torso 0.4")."""
        return self.thresholds.words(arm)

    def collision_args(self, step: Step, o: Option) -> dict[str, Any]:
        """Keyword arguments of the collision check of option ``o`` of ``step``: a pick's gripper may
        touch the object it grasps; a place carries its object (``held``: it moves with the gripper and
        is no longer where the scene has it); objects picked before are ``gone`` (where earlier places
        set them down is not modelled as an obstacle)."""
        grasped, gone = step_objects(self.problems.steps, step)
        if step.action == "place" and step.carries is not None and o.candidate.object_pose is not None:
            held = held_object(self.scene.object(step.carries), o.candidate)
            return {"grasped": None, "gone": gone, "held": held}
        return {"grasped": grasped, "gone": gone}


__all__ = ["BudgetSpent", "PlanningContext", "resident_gib"]
