"""The methods that rank placements by Eq. 6 with their weights: ``sequential`` (all three terms),
``single-step`` (no heuristic towards the next step) and ``irm`` (manipulation only)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

from placement.planning.arrays import FloatArray
from placement.planning.context import PlanningContext
from placement.planning.methods.ranking import Ranked, rank_by_cost
from placement.planning.methods.stepwise import StepwiseMethod
from placement.planning.problems import Option, per_arm_values


def rank_eq6(
    ctx: PlanningContext,
    options: Sequence[Option],
    nav_cost: FloatArray,
    heuristic: FloatArray,
    per_option: int | None = None,
) -> list[Ranked]:
    """Eq. 6 with the context's weights (see :func:`~placement.planning.methods.ranking.rank_by_cost`): the
    ``per_option`` cheapest cells of each option and tier (default ``ik_tries``), each option's
    cells kept by its own threshold (its arm's, at its torso setting)."""
    cfg = ctx.config if per_option is None else replace(ctx.config, ik_tries=per_option)
    values = per_arm_values(options, ctx.threshold, cfg.threshold)
    return rank_by_cost(values, nav_cost, heuristic, cfg, ctx.yaws, ctx.check_budget)


class Eq6Method(StepwiseMethod):
    """Stepwise planning over the placements ranked by Eq. 6; when the best ``ik_tries`` do not
    verify, the search spreads over up to ``ik_cap`` per option and tier."""

    def rank(
        self, ctx: PlanningContext, options: Sequence[Option], nav_cost: FloatArray, heuristic: FloatArray
    ) -> list[Ranked]:
        return rank_eq6(ctx, options, nav_cost, heuristic)

    def more(
        self, ctx: PlanningContext, options: Sequence[Option], nav_cost: FloatArray, heuristic: FloatArray
    ) -> Callable[[], list[Ranked]] | None:
        def every() -> list[Ranked]:
            return rank_eq6(ctx, options, nav_cost, heuristic, per_option=ctx.config.ik_cap)

        return every


class Sequential(Eq6Method):
    """The paper's method: navigation, manipulation and the heuristic towards the next step."""

    name = "sequential"


class SingleStep(Eq6Method):
    """Navigation and manipulation, each step on its own (no heuristic)."""

    name = "single-step"
    uses_heuristic = False


class Irm(Eq6Method):
    """Manipulation only: the best inverse reachability map value the base can get to."""

    name = "irm"
    uses_heuristic = False
    uses_navigation = False


__all__ = ["Eq6Method", "Irm", "Sequential", "SingleStep", "rank_eq6"]
