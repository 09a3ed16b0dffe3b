"""The certificate of a plan: the least travel any plan could have on the cells its method may use.

The bound is the optimum of the forward program of :mod:`placement.planning.bound` over the regions
of the plan's method (:meth:`~placement.planning.methods.base.Method.regions`: the cells where the
maps keep the threshold, or the ``fixed`` baseline's pre-defined placements), ignoring IK and
collision checks, so no plan of that method can travel less. A step's time is at least its travel
time (the task-time model runs rotation and arm motion in parallel with it), so the bound is a lower
bound on the task time too: the certificate gives both gaps (the default method trades a little
travel for less turning where that shortens the task, :mod:`placement.planning.methods.turning`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

from placement.planning.arrays import Cell
from placement.planning.bound import travel_bound
from placement.planning.context import PlanningContext
from placement.planning.methods.base import Method
from placement.planning.results import StepResult
from placement.planning.task_time import steps_seconds


@dataclass(frozen=True)
class Certificate:
    """A plan's lower bound and its gap.

    Attributes:
        lower_bound_s: least travel time [s] of any plan on the method's regions (inf: no such
            plan exists; the task is infeasible for the method whatever IK does).
        travel_s: the plan's travel time [s] (None unless every step is planned).
        regions: what the bound ranges over ("maps" or "fixed placements").
        ms: time spent on the bound [ms] (0 when the method's own program gave it); JSON
            ``timings_ms.bound``.
        task_time_s: the plan's task time [s] (:mod:`placement.planning.task_time`; None unless every
            step is planned).
    """

    lower_bound_s: float
    travel_s: float | None
    regions: str
    ms: float = 0.0
    task_time_s: float | None = None

    @property
    def gap(self) -> float | None:
        """``travel_s / lower_bound_s - 1`` (0 for a plan that travels 0; None without both)."""
        if self.travel_s is None or not math.isfinite(self.lower_bound_s):
            return None
        if self.lower_bound_s <= 0.0:
            return 0.0 if self.travel_s <= 1e-9 else None
        return self.travel_s / self.lower_bound_s - 1.0

    @property
    def task_gap(self) -> float | None:
        """``task_time_s / lower_bound_s - 1`` (None without both, or for a bound of 0)."""
        if self.task_time_s is None or not math.isfinite(self.lower_bound_s) or self.lower_bound_s <= 0.0:
            return None
        return self.task_time_s / self.lower_bound_s - 1.0

    def to_json(self) -> dict[str, Any]:
        gap, task_gap = self.gap, self.task_gap
        return {
            "lower_bound_s": round(self.lower_bound_s, 6) if math.isfinite(self.lower_bound_s) else None,
            "travel_s": None if self.travel_s is None else round(self.travel_s, 6),
            "gap": None if gap is None else round(gap, 6),
            "task_time_s": None if self.task_time_s is None else round(self.task_time_s, 6),
            "task_gap": None if task_gap is None else round(task_gap, 6),
            "regions": self.regions,
            "timings_ms": {"bound": round(self.ms, 3)},
        }


def certify(ctx: PlanningContext, method: Method, start: Cell, steps: list[StepResult]) -> Certificate:
    """The certificate of the plan ``steps`` that ``method`` made from ``start``."""
    t0 = time.perf_counter()
    key = (method.region_kind, start)
    bound_m = ctx.problems.bounds.get(key)
    if bound_m is None:
        n = len(ctx.problems.steps)
        bound_m = travel_bound(ctx, start, [method.regions(ctx, i) for i in range(n)])
        ctx.problems.bounds[key] = bound_m
    ok = bool(steps) and len(steps) == len(ctx.problems.steps) and all(s.ok for s in steps)
    travel = sum(float(s.travel_time_s or 0.0) for s in steps) if ok else None
    task = None
    if ok:
        task = sum(x["step_s"] for x in steps_seconds(ctx.robot, steps, float(ctx.scene.start[2])))
    v = ctx.robot.v_max
    return Certificate(bound_m / v, travel, method.region_kind, (time.perf_counter() - t0) * 1e3, task)


__all__ = ["Certificate", "certify"]
