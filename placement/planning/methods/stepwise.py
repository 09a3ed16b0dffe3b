"""Step-by-step planning (paper section IV): each step's best verified placement, in task order.

The methods that plan this way (:class:`StepwiseMethod`: ``sequential``, ``single-step`` and
``irm`` ranked by Eq. 6 with their weights, ``fixed`` by manipulability at the pre-defined
placements) differ only in how they rank a step's placements.
"""

from __future__ import annotations

import time
from abc import abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from placement.planning.arrays import Cell, FloatArray
from placement.planning.context import BudgetSpent, PlanningContext
from placement.planning.methods.base import Method
from placement.planning.methods.explain import NO_PATH, diagnosed, explain, no_path_hint
from placement.planning.methods.outcomes import infeasible, placed, unreachable_reason
from placement.planning.methods.ranking import Ranked, combined_map
from placement.planning.methods.search import search_placement
from placement.planning.methods.transfer_words import Pair, excluded_words, transfer_diagnosis, transfer_reason
from placement.planning.problems import Option, Step, per_arm_values
from placement.planning.results import InfeasibleStep, PlacedStep, StepMaps, StepResult
from placement.planning.torso import held_setting, start_torso, torso_seconds
from placement.planning.world import costs_at, extract_path, navigation_cost

#: Steps after the current one whose kernel passes a step-by-step plan starts in the background.
PREFETCH_AHEAD = 2


@dataclass(frozen=True)
class Holding:
    """What the robot holds between the steps of a step-by-step plan.

    Attributes:
        cell: the base's (iy, ix) cell, where the next step's travel starts.
        q: arm -> its joints [rad or m] after its last step (the next IK's seed; home at first).
        torso: the torso value [m or rad; a posture's index] the lift holds (None without torso
            settings): moving it for a step costs time (:func:`torso_ranked`).
    """

    cell: Cell
    q: Mapping[str, FloatArray]
    torso: float | None

    @classmethod
    def start(cls, ctx: PlanningContext, cell: Cell) -> Holding:
        """At ``cell`` with every arm home and the lift where the robot starts."""
        return cls(cell, {arm: ctx.robot.arm(arm).home.copy() for arm in ctx.maps}, start_torso(ctx))

    def after(self, ctx: PlanningContext, step: PlacedStep, cell: Cell) -> Holding:
        """What the robot holds after planned ``step`` at ``cell``."""
        return Holding(cell, {**self.q, step.arm: step.q}, held_setting(ctx, step.joints, self.torso))


class StepwiseMethod(Method):
    """A method that plans the steps in order, each from the previous placement."""

    @abstractmethod
    def rank(
        self, ctx: PlanningContext, options: Sequence[Option], nav_cost: FloatArray, heuristic: FloatArray
    ) -> list[Ranked]:
        """The placements of a step's ``options`` in the order IK tries them (``nav_cost`` and
        ``heuristic``: (ny, nx) [m])."""

    def more(
        self, ctx: PlanningContext, options: Sequence[Option], nav_cost: FloatArray, heuristic: FloatArray
    ) -> Callable[[], list[Ranked]] | None:
        """Every ranked placement, for the search's spread phase (None: the ranking is all there is)."""
        return None

    def plan(self, ctx: PlanningContext, start: Cell, keep_maps: bool) -> list[StepResult]:
        return plan_stepwise(ctx, self, start, keep_maps)


def plan_stepwise(ctx: PlanningContext, method: StepwiseMethod, start_cell: Cell, keep_maps: bool) -> list[StepResult]:
    """Plan the steps in order from ``start_cell``, each from the previous placement; a pick and its
    place as one transfer (:func:`plan_transfer`); stops at the first infeasible step (it is the
    last result)."""
    with ctx.problems.stopping(ctx.check_budget):  # every kernel pass of the plan checks the task's budget
        return _plan_stepwise(ctx, method, start_cell, keep_maps)


def _plan_stepwise(ctx: PlanningContext, method: StepwiseMethod, start_cell: Cell, keep_maps: bool) -> list[StepResult]:
    holding = Holding.start(ctx, start_cell)
    steps = ctx.problems.steps
    out: list[StepResult] = []
    i = 0
    while i < len(steps):
        step = steps[i]
        if ctx.out_of_budget():
            out.append(infeasible(step, ctx.budget_words()))
            break
        try:
            if step.action == "pick" and i + 1 < len(steps) and steps[i + 1].pick == i:
                results, cell = plan_transfer(ctx, method, step, steps[i + 1], holding, keep_maps)
            else:
                t0 = time.perf_counter()
                result, cell = plan_step(ctx, method, step, holding, keep_maps)
                results = [result.timed(total=(time.perf_counter() - t0) * 1e3)]
        except BudgetSpent:  # inside a step's ranking: the steps planned before stand
            out.append(infeasible(step, ctx.budget_words()))
            break
        out += results
        if not results[-1].ok or cell is None:
            break
        for r in results:
            if r.ok:
                holding = holding.after(ctx, r, cell)
        i += len(results)
    return out


def plan_transfer(
    ctx: PlanningContext, method: StepwiseMethod, pick: Step, place: Step, holding: Holding, keep_maps: bool
) -> tuple[list[StepResult], Cell | None]:
    """A pick and its place with the same arm and grasp, from what the robot is ``holding`` before the
    pick (the place may hold the torso at another value).

    The pick may use only the (arm, grasp) pairs with which the maps reach a place pose of the
    object (:meth:`StepProblems.pairs`); the place then uses the pick's pair only. When that place
    does not verify, the pick is planned again without the pair, until a pair verifies both or
    none is left: the place step is then infeasible after the last pick verified (the pick step when
    none was), and its reason says, per arm and grasp, what failed at which place
    (:mod:`.transfer_words`). When no pair the place allows picks but another pair does, that pick is
    kept and the place is the step that fails. Returns the pick's and the place's results (the
    pick's alone when it is infeasible) and the place's cell."""
    problems = ctx.problems
    t0 = time.perf_counter()
    prefetch_from(ctx, pick.index)  # the place's passes run while the pick's options are read
    picks = {(o.arm, o.candidate.grasp) for o in problems.options(pick.index)}
    viable = problems.pairs(place.index)
    irms_ms = (time.perf_counter() - t0) * 1e3  # the pick's and the place's IRMs: manipulation work
    failed: dict[Pair, str] = {p: "" for p in picks - viable}  # pair -> its place's failure ("": by the maps)
    if not viable and picks:
        # no arm and grasp reaches the place anywhere: the place is what fails (as the whole-task methods
        # say), after the pick planned alone
        first, cell = plan_step(ctx, method, pick, holding, keep_maps)
        first = first.timed(total=(time.perf_counter() - t0) * 1e3)
        if not first.ok or cell is None:
            return [first], None
        opts = problems.options(place.index)
        place_ctx = ctx.for_step(place.index)
        reason, diagnosis = explain(place_ctx, False, place, opts, None, unreachable_reason(place_ctx, opts))
        return [first, infeasible(place, reason, diagnosis)], None
    picked: StepResult | None = None  # the last pick verified (its place then failed)

    def no_transfer(at_pick: bool) -> InfeasibleStep:
        """The place (the pick, ``at_pick``, when no pick verified) infeasible: no pair does both."""
        step = pick if at_pick else place
        opts = problems.options(place.index)
        return InfeasibleStep(
            step.index,
            step.action,
            step.target,
            reason=transfer_reason(ctx, pick, place, failed, opts),
            diagnosis={"place": place.target, "transfers": transfer_diagnosis(failed, opts)},
            timings_ms={"total": (time.perf_counter() - t0) * 1e3},
        )

    while True:
        allowed = picks - failed.keys()
        if failed and ctx.out_of_budget():
            return [infeasible(pick, ctx.budget_words())], None
        if not allowed:
            # every pair picked failed at the place: the place is what fails (as the whole-task methods
            # say), after the last pick verified; else the pick itself
            return ([picked] if picked is not None else []) + [no_transfer(picked is None)], None
        first, cell = plan_step(ctx, method, pick, holding, keep_maps, allowed)
        if not first.ok or cell is None:
            if failed and not first.ok and first.tried == 0:
                # no pair the place allows picks (the gripper or the maps rule them out): when a pair the
                # place rules out picks, what truly fails is the transfer, at the place (as the
                # whole-task methods say), after that pick
                alone, _ = plan_step(ctx, method, pick, holding, keep_maps, set(failed))
                if alone.ok:
                    return [alone.timed(total=(time.perf_counter() - t0) * 1e3), no_transfer(False)], None
                first = replace(
                    first,
                    reason=f"{first.reason} (and {excluded_words(failed)}, which cannot set '{pick.target}' down at "
                    f"'{place.target}': {alone.reason})",
                )
            elif failed and not first.ok:
                first = replace(
                    first,
                    reason=first.reason
                    + f" (not tried: {excluded_words(failed)}, which cannot set '{pick.target}' down at '{place.target}')",
                )
            return [first.timed(total=(time.perf_counter() - t0) * 1e3)], None
        t1 = time.perf_counter()
        pair = (first.arm, first.grasp)
        second, cell = plan_step(ctx, method, place, holding.after(ctx, first, cell), keep_maps, {pair})
        second = second.timed(total=(time.perf_counter() - t1) * 1e3)
        if second.ok:
            manipulation = first.timings_ms.get("manipulation", 0.0) + irms_ms
            return [first.timed(total=(t1 - t0) * 1e3, manipulation=manipulation), second], cell
        failed[pair] = second.reason or "infeasible"
        picked = first.timed(total=(t1 - t0) * 1e3)


def prefetch_from(ctx: PlanningContext, i: int) -> None:
    """Start the kernel passes of step i and the :data:`PREFETCH_AHEAD` steps after it in the
    background (their arguments made now, each step's while the kernel runs the one before): a step
    ranks and verifies while the next steps' options are computed, the same options. Steps computed
    or started already are skipped."""
    problems = ctx.problems
    for ahead in range(i, min(i + PREFETCH_AHEAD + 1, len(problems.steps))):
        problems.prefetch(ahead, None, exact=True, stop=ctx.check_budget)


def plan_step(
    ctx: PlanningContext,
    method: StepwiseMethod,
    step: Step,
    holding: Holding,
    keep_maps: bool,
    pairs: set[Pair] | None = None,
) -> tuple[StepResult, Cell | None]:
    """The best verified placement of one step from what the robot is ``holding`` (or an infeasible
    result) and its cell; ``pairs``: the (arm, grasp) pairs the step may use (default all). Another
    torso value than the one held costs its lift time in the Eq. 6 cost as travel (lambda_n times the
    metres the base would drive meanwhile)."""
    ctx = ctx.for_step(step.index)
    cfg, problems, world = ctx.config, ctx.problems, ctx.world
    nav = world.nav
    timings: dict[str, float] = {}
    t = time.perf_counter()
    prefetch_from(ctx, step.index)
    opts = problems.options(step.index)
    if pairs is not None:
        opts = [o for o in opts if (o.arm, o.candidate.grasp) in pairs]
    steer = step.index + 1 < len(problems.steps) and cfg.lambda_nh > 0
    if steer:
        problems.options(step.index + 1)  # the next step's IRMs: manipulation work, cached for that step
    timings["manipulation"] = (time.perf_counter() - t) * 1e3
    # only this step's candidate cells are read from the cost maps (all cells for plots, and for
    # pre-defined placements, which need not lie in the maps' feasible region)
    fixed = method.ranks_fixed_placements
    needed = None if keep_maps or fixed else problems.feasible_region(step.index, opts)
    t = time.perf_counter()
    if needed is None:
        nav_cost, pred = navigation_cost(world.factor, world.feasible, holding.cell, nav.resolution)
    else:  # the candidate cells' costs only (inf elsewhere, as the search leaves them)
        at = np.flatnonzero(needed)
        nav_cost = np.full(nav.shape, np.inf)
        nav_cost.flat[at] = costs_at(world.factor, world.feasible, holding.cell, nav.resolution, at)[0]
        pred = None
    timings["navigation"] = (time.perf_counter() - t) * 1e3
    t = time.perf_counter()
    heur = problems.heuristic(step.index + 1, needed) if steer else np.zeros(nav.shape)
    timings["heuristic"] = (time.perf_counter() - t) * 1e3
    t = time.perf_counter()
    ranked = torso_ranked(ctx, opts, method.rank(ctx, opts, nav_cost, heur), holding.torso, fixed)
    timings["combine"] = (time.perf_counter() - t) * 1e3
    maps = None
    if keep_maps:
        manip = np.max([o.full_value(nav.shape) for o in opts], axis=0) if opts else None
        combined = (
            combined_map(per_arm_values(opts, ctx.threshold, cfg.threshold), nav_cost, heur, cfg) if not fixed else None
        )
        maps = StepMaps(nav_cost, heur, manip, combined)
    t = time.perf_counter()
    more = method.more(ctx, opts, nav_cost, heur)
    search = search_placement(ctx, step, opts, ranked, more, nav_cost, heur, holding.q) if ranked else None
    found = search.found if search is not None else None
    # the whole search, and within it the IK solves and the collision checks
    timings["search"] = (time.perf_counter() - t) * 1e3
    timings["ik"] = search.ik_ms if search else 0.0
    timings["collision"] = search.collision_ms if search else 0.0
    if search is not None and found is not None:
        r = found.ranked
        o = opts[r.option]
        iy, ix = divmod(r.cell, nav.shape[1])
        if maps is not None and pred is not None:
            maps.path = extract_path(pred, (iy, ix))
        value = found.value or (-r.cost if fixed else o.value_at(iy, ix))
        result = placed(
            ctx,
            step,
            o,
            found.base,
            found.ik.qs,
            float(nav_cost[iy, ix]),
            float(heur[iy, ix]),
            value,
            timings,
            found.clearance_m,
        )
        return replace(result, maps=maps, tried=search.tried), (iy, ix)
    region = np.flatnonzero(needed if needed is not None else problems.feasible_region(step.index, opts))
    if not ranked and not fixed and region.size and not np.isfinite(nav_cost.flat[region]).any():
        # the maps reach the target, the base cannot get there from where it is
        words = diagnosed(ctx, step, opts, NO_PATH, no_path_hint(region.size, 0, "where the base is"))
        reason, diagnosis = words.reason, words.diagnosis
    else:
        reason, diagnosis = explain(ctx, fixed, step, opts, search, "" if ranked else unreachable_reason(ctx, opts))
    failure = InfeasibleStep(
        step.index,
        step.action,
        step.target,
        reason=reason,
        diagnosis=diagnosis,
        timings_ms=timings,
        maps=maps,
        tried=search.tried if search else 0,
    )
    return failure, None


def torso_ranked(
    ctx: PlanningContext, opts: Sequence[Option], ranked: list[Ranked], torso: float | None, fixed: bool
) -> list[Ranked]:
    """``ranked`` with each option's torso motion from ``torso`` [m] added to its Eq. 6 cost as
    lambda_n x the metres the base drives at v_max meanwhile, re-sorted (unchanged without torso
    settings). The baselines that weigh no travel (``irm``: lambda_n = 0; ``fixed``, which ranks by
    manipulability alone) keep their order among the placements at the lift's value and try the
    others after them: they move the lift only for a step nothing at its value serves."""
    if torso is None or all(o.torso is None for o in opts):
        return ranked
    moves = [torso_seconds(ctx, torso, o.torso) for o in opts]
    rate = ctx.config.lambda_n * ctx.robot.v_max
    if fixed or rate <= 0:
        return sorted(ranked, key=lambda r: moves[r.option] > 0)
    extra = [rate * m for m in moves]
    out = [Ranked(r.cost + extra[r.option], r.option, r.cell, r.yaw) for r in ranked]
    out.sort(key=lambda r: (r.cost, r.option, r.cell, r.yaw))
    return out


__all__ = ["Holding", "StepwiseMethod", "plan_step", "plan_stepwise", "plan_transfer"]
