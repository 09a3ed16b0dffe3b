"""The certificate of a plan: the least travel any plan could have on the cells its method may use.

The bound is the optimum of the forward program of :mod:`placement.planning.program.forward` over the regions
of the plan's method (:meth:`~placement.planning.methods.base.Method.regions`: the cells where the
maps keep the threshold, or the ``fixed`` baseline's pre-defined placements), ignoring IK and
collision checks, so no plan of that method can travel less. A step's time is at least its travel
time (the task-time model runs rotation and arm motion in parallel with it), so the bound is a lower
bound on the task time too: the certificate gives both gaps (the default method trades a little
travel for less turning where that shortens the task, :mod:`placement.planning.program.turning`).
"""

from __future__ import annotations

import math
import time
from typing import Protocol

from placement.planning.arrays import Cell
from placement.planning.context import BudgetSpent, PlanningContext
from placement.planning.program.forward import travel_bound
from placement.planning.program.regions import PREFETCH_STEPS, Regions
from placement.planning.results import Certificate, StepResult
from placement.planning.task_time import steps_seconds


class RegionSource(Protocol):
    """What a certificate needs of a method: the cells it may stand on per step, and their name."""

    @property
    def region_kind(self) -> str:
        """What :meth:`regions` ranges over ("maps" or "fixed placements")."""
        ...

    def regions(self, ctx: PlanningContext, i: int) -> Regions:
        """Step ``i``'s regions."""
        ...

    def prefetch_regions(self, ctx: PlanningContext, i: int) -> None:
        """Start what :meth:`regions` ``(ctx, i)`` will compute (its kernel passes in the background)."""
        ...


def certify(ctx: PlanningContext, method: RegionSource, start: Cell, steps: list[StepResult]) -> Certificate:
    """The certificate of the plan ``steps`` that ``method`` made from ``start``."""
    t0 = time.perf_counter()
    key = (method.region_kind, start)
    bound_m = ctx.problems.bounds.get(key)
    stopped = None
    if bound_m is None:
        try:
            with ctx.problems.stopping(ctx.check_budget):  # every kernel pass the regions need, too
                regions = []
                n = len(ctx.problems.steps)
                for i in range(n):
                    ctx.check_budget()
                    for ahead in range(i, min(i + PREFETCH_STEPS + 1, n)):
                        method.prefetch_regions(ctx, ahead)
                    regions.append(method.regions(ctx, i))
                bound_m = travel_bound(ctx, start, regions)
            ctx.problems.bounds[key] = bound_m
        except BudgetSpent:
            bound_m, stopped = math.nan, f"not computed: {ctx.budget()[0]} ran out"
    ok = bool(steps) and len(steps) == len(ctx.problems.steps) and all(s.ok for s in steps)
    travel = sum(float(s.travel_time_s) for s in steps if s.ok) if ok else None
    task = None
    if ok:
        task = sum(x["step_s"] for x in steps_seconds(ctx.robot, steps, float(ctx.scene.start[2])))
    v = ctx.robot.v_max
    return Certificate(bound_m / v, travel, method.region_kind, (time.perf_counter() - t0) * 1e3, task, stopped)


__all__ = ["Certificate", "RegionSource", "certify"]
