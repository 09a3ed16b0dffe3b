"""Whole-task planning by dynamic programming over every feasible base cell: ``optimal`` and ``global``.

Both solve the forward program of :mod:`placement.planning.program.forward` over the regions of the maps (every
cell where some (arm, grasp) keeps the threshold, per group; a place keeps its pick's group) and
verify the cheapest chain lazily: each step's placement along the chain, in task order, gets IK of
every pose (started from the map's witness, then the arm's home: a placement's answer is its own,
kept by :mod:`placement.planning.verification.verdicts` across re-plans) and the collision
check, trying the group's options that keep the threshold there by decreasing map value, each at
its best base yaw. A rejected (cell, group) is removed from its step's region, the program is solved
again from that step on, and the loop ends when every step of the chain verifies.

The objective is the task's base travel [m] (``travel_time_s`` times ``v_max``), plus, with
``optimal_manipulability_weight`` > 0, that weight times ``1 / m`` per step (Eq. 6's manipulation
term) as a tie-breaker between cells of similar travel. The model's approximations: base rotation
and arm motion run in parallel with the travel (docs/design.md) and are not in the objective (they
add time only where a step's rotation or arm motion outlasts its travel: see ``task_time``); a cell
stands for its centre, at the best yaw of the option.

``optimal`` removes exactly the rejected (cell, group) and solves again (``optimal_probe`` > 0:
it verifies the rejected cell's neighbours at once, removing those that fail too; IK and the
collision check cost more than a solve of :class:`~placement.planning.program.forward.Program`, so the
default is 0); its result is the best verified plan of the discretisation, up to IK being a local
search (a placement is answered once, from the witness, the home and the seeded restarts), as long as at most
``optimal_max_repairs`` placements are rejected; past that (maps far more optimistic than IK, e.g.
beside shelves) each rejection removes its 3 x 3 neighbourhood, so that it still finds a plan
where one verifies, and the certificate's gap says how far it is from the bound.

``global``, the default, solves the program once and repairs the chain locally: a rejected step
moves to the least detour between its neighbours' cells that verifies (:mod:`.repair`), and a
transfer whose cheapest cells share no group is given its pick's group and repaired the same way;
only what local repair cannot fix is removed and solved again (as ``optimal`` does). Its plans
are within a few tenths of a percent of ``optimal``'s on the held-out scenes (docs/bench/optimum.md),
for one solve instead of several. The first program's optimum (when exact) is the plan's lower
bound (:mod:`placement.planning.program.forward`), kept for the certificate.

With torso settings (:mod:`placement.planning.torso`) the two differ in how they choose them.
``global`` holds the torso at the preset's value on every step the maps serve there (the hold rule,
``DynamicProgram.hold``; released only where no chain is left). ``optimal`` prices it: its program
has a group per (arm, grasp, setting), and a move between steps costs the travel plus
``v_max * torso_s`` [m] (:mod:`placement.planning.program.priced_torso`: the sum bounds the task time's
max(base, torso) of a step from above, by at most twice it), each step verified at its group's
setting; the plain program at the preset's setting answers while it provably is that optimum
(:mod:`placement.planning.program.held_first`), so a task that never moves the torso costs what it did.
"""

from __future__ import annotations

import copy
import logging
import math
import time
from dataclasses import replace
from typing import Any

import numpy as np

from placement.planning.arrays import Cell
from placement.planning.context import BudgetSpent, PlanningContext
from placement.planning.methods.base import Method
from placement.planning.methods.explain import NO_PATH, diagnosed, explain, no_path_hint
from placement.planning.methods.outcomes import infeasible, placed, unreachable_reason
from placement.planning.methods.transfer_words import transfer_diagnosis, transfer_reason
from placement.planning.program import (
    Chain,
    DynamicProgram,
    Verified,
    polishes,
    repair,
    reweighted,
    task_seconds,
    time_cells,
    time_yaws,
)
from placement.planning.results import InfeasibleStep, StepMaps, StepResult
from placement.planning.torso import start_torso, torso_joint
from placement.planning.world import extract_path, navigation_cost

log = logging.getLogger(__name__)

#: Rounds of the task-time passes at most: each round moves cells then turns yaws, and the next starts
#: from what it kept (a moved neighbour can make another move or turn pay); they stop when one gains
#: nothing.
POLISH_ROUNDS = 3


def solve_verified(dp: DynamicProgram) -> tuple[Chain | None, list[Verified], InfeasibleStep | None]:
    """Solve ``dp`` until its cheapest chain verifies: (the chain, each step's verified placement,
    None), or (None, [], the infeasible result saying why); when the time budget runs out, (the
    chain, the placements verified along it so far, the first step not verified)."""
    try:
        return _solve_verified(dp)
    except BudgetSpent:  # inside a solve or a repair: the last verified prefix stands
        chain, picks = dp.verified_prefix
        step = dp.ctx.problems.steps[len(picks)]
        return (chain if picks else None), picks, infeasible(step, dp.ctx.budget_words())


def _solve_verified(dp: DynamicProgram) -> tuple[Chain | None, list[Verified], InfeasibleStep | None]:
    ctx = dp.ctx
    steps = ctx.problems.steps
    chain = dp.solve()
    while True:
        if chain is None and dp.coarse:
            # the neighbourhoods took every chain away: back to removing only what was rejected
            chain = dp.exact_again()
            continue
        if chain is None and any(h is not None for h in dp.hold):
            chain = dp.release_lift()  # no plan with the lift held: the first step none reaches may move it
            continue
        if chain is None:
            return None, [], why_not(ctx, dp)
        # every step of the chain is checked before the program is solved again: the rejections of
        # one pass are removed together (one solve from the earliest instead of one per rejection)
        dp.torso = start_torso(ctx)
        failed: list[tuple[int, int, int]] = []
        picks: list[Verified] = []
        for i in range(len(chain.cells)):
            if ctx.out_of_budget():  # the steps verified so far stand: a partial plan
                # up to the first step this pass rejected: ``picks`` skips the rejected ones
                k = failed[0][0] if failed else i
                return chain, picks[:k], infeasible(steps[k], ctx.budget_words())
            flat, g = chain.cells[i], chain.groups[i]
            v = dp.verify(i, flat, g)
            if v is None and dp.local:
                fixed = repair(dp, chain, i)
                if fixed is not None:
                    chain, v = fixed
                    dp.repairs_local += 1
            if v is None:
                failed.append((i, flat, g))
                continue
            picks.append(v)
            if not failed:
                dp.verified_prefix = (chain, list(picks))
            chosen = dp.options(i, chain.groups[i])[v.option]
            dp.torso = chosen.torso if chosen.torso is not None else dp.torso
        if not failed:
            return chain, picks, None
        loose = [f[0] for f in failed if f[0] in dp.program.loose]
        if loose:
            # a place given its pick's group found no cell of it near: that transfer is grouped
            chain = dp.solve(dp.program.group(loose))
            continue
        if dp.solves >= ctx.config.dp_max_solves:
            i = failed[0][0]
            reason = (
                f"IK or the collision check rejected {dp.rejected[i] + 1} placements of this step "
                f"({dp.repairs + len(failed)} in the whole task; the program was solved "
                f"{dp.solves} times, dp_max_solves)"
            )
            return None, [], infeasible(steps[i], reason)
        for f in failed:
            dp.remove(*f)
            if dp.exact_repairs is None or dp.repairs < dp.exact_repairs:
                dp.reject_around(*f)
            if dp.local:  # a repair's rejected candidates: the next chain need not find them again
                dp.forget_rejected(f[0])
        chain = dp.solve(failed[0][0])


def plan_dynamic(
    ctx: PlanningContext,
    start: Cell,
    keep_maps: bool,
    neighbourhood: int = 0,
    exact_repairs: int | None = None,
    local: bool = False,
    priced: bool = False,
) -> list[StepResult]:
    """The verified cheapest chain's steps; when none is left, the plan of the steps before the first
    one no chain reaches and that step, saying why; when the time budget runs out, the steps verified
    so far and the first one not verified
    (``priced``: the torso priced per step, :mod:`placement.planning.program.priced_torso`)."""
    t0 = time.perf_counter()
    if not ctx.problems.steps:
        return []
    try:
        dp = DynamicProgram(ctx, start, neighbourhood, exact_repairs, priced)
    except BudgetSpent:  # the regions of every step took the whole budget
        spent = infeasible(ctx.problems.steps[0], ctx.budget_words())
        return [replace(spent, timings_ms={"total": (time.perf_counter() - t0) * 1e3})]
    dp.local = dp.program.lazy = local
    chain, picks, failure = solve_verified(dp)
    if (
        ctx.config.optimal_manipulability_weight <= 0
        and math.isfinite(dp.first_total)
        and torso_joint(ctx.maps) is None
    ):
        # the first program over the maps' regions is the plan's lower bound: kept, not solved again
        # (not with torso settings: the program held the lift, the bound takes every setting)
        ctx.problems.bounds[("maps", start)] = dp.first_total
    if failure is not None and not failure.timings_ms:
        failure = replace(failure, timings_ms={"total": (time.perf_counter() - t0) * 1e3})
    if chain is None:
        if failure is None:
            return []
        if failure.step == 0:
            return [failure]
        # no chain reaches step i: the steps before it are planned alone (their plan, then the failure)
        head = plan_dynamic(
            prefix_context(ctx, failure.step), start, keep_maps, neighbourhood, exact_repairs, local, priced
        )
        return head if head and not head[-1].ok else [*head, failure]
    out = results(ctx, start, dp, chain, picks, keep_maps)  # the verified steps (all, or before the failure)
    if failure is None and polishes(dp):
        try:
            out = for_task_time(dp, chain, picks, out, keep_maps, move=local)
        except BudgetSpent:  # the verified plan stands without the task-time passes
            pass
    ms = (time.perf_counter() - t0) * 1e3
    log.debug(
        "dynamic program: %d placements checked, %d rejected, %d solves, %d local repairs, %.0f ms",
        len(dp.verified),
        dp.repairs,
        dp.solves,
        dp.repairs_local,
        ms,
    )
    out = [replace(s, timings_ms={"total": ms / len(out)}) for s in out]
    return out if failure is None else [*out, failure]


def for_task_time(
    dp: DynamicProgram, chain: Chain, picks: list[Verified], out: list[StepResult], keep_maps: bool, move: bool
) -> list[StepResult]:
    """The plan ``out`` of the verified ``chain`` after the task-time passes of
    :mod:`~placement.planning.program.turning` (``move``: the cells too), each kept only when it
    shortens the task, for up to :data:`POLISH_ROUNDS` rounds."""
    ctx, start = dp.ctx, dp.start
    best = task_seconds(dp, out)
    settled: dict[int, tuple[object, ...]] = {}  # steps whose cell search found nothing, and what it read
    for _ in range(POLISH_ROUNDS):
        before = best
        if move and not ctx.out_of_budget():
            moved = time_cells(dp, chain, picks, out, settled)
            if moved is not None:
                steps = results(ctx, start, dp, *moved, keep_maps)
                seconds = task_seconds(dp, steps)
                if seconds < best - 1e-9:
                    (chain, picks), out, best = moved, steps, seconds
        if not ctx.out_of_budget():
            turned = time_yaws(dp, chain, picks, out)
            if turned is not None:
                steps = results(ctx, start, dp, chain, turned, keep_maps)
                seconds = task_seconds(dp, steps)
                if seconds < best - 1e-9:
                    picks, out, best = turned, steps, seconds
        if best >= before - 1e-9:
            break
    return out


def prefix_context(ctx: PlanningContext, count: int) -> PlanningContext:
    """``ctx`` with the task cut to its first ``count`` steps (the cached options, IK and collision
    answers shared; the task bounds not: they belong to the whole task)."""
    problems = copy.copy(ctx.problems)
    problems.steps = ctx.problems.steps[:count]
    problems.bounds = {}
    return replace(ctx, problems=problems)


def results(
    ctx: PlanningContext, start: Cell, dp: DynamicProgram, chain: Chain, picks: list[Verified], keep_maps: bool
) -> list[StepResult]:
    """The step results of a verified chain: each step's travel [m] is its label less the previous
    step's, its node cost and its torso term (the chain's legs are shortest paths from the previous cell)."""
    nav = ctx.world.nav
    out: list[StepResult] = []
    prev_label, prev_cell = 0.0, start
    for i, (flat, g, v) in enumerate(zip(chain.cells, chain.groups, picks)):
        step = ctx.problems.steps[i]
        o = dp.options(i, g)[v.option]
        iy, ix = divmod(flat, nav.shape[1])
        node = dp.regions[i].node_at(g, flat)
        travel = max(chain.labels[i] - prev_label - node - dp.torso_m(chain, i), 0.0)
        r = placed(ctx, step, o, v.base, v.ik.qs, travel, 0.0, v.value, {}, v.clearance_m)
        if keep_maps:
            navc, pred = navigation_cost(ctx.world.factor, ctx.world.feasible, prev_cell, nav.resolution)
            manip = np.max([p.full_value(nav.shape) for p in ctx.problems.options(i)], axis=0)
            r = replace(r, maps=StepMaps(navc, np.zeros(nav.shape), manip, None, extract_path(pred, (iy, ix))))
        out.append(r)
        prev_label, prev_cell = chain.labels[i], (iy, ix)
    return out


def why_not(ctx: PlanningContext, dp: DynamicProgram) -> InfeasibleStep:
    """The infeasible result of the first step no chain reaches, and why."""
    steps = ctx.problems.steps
    i = next(k for k, layer in enumerate(dp.layers) if not np.isfinite(layer.labels).any())
    step = steps[i]
    opts = ctx.problems.options(i)
    ctx = ctx.for_step(i)
    if not dp.full[i].any():
        reason, diagnosis = explain(ctx, False, step, opts, None, unreachable_reason(ctx, opts))
        return infeasible(step, reason, diagnosis)
    # the first thing that truly fails: the base's reach, the rejections, the transfer, the chain
    reachable = ctx.problems.reachable.flat
    full = dp.full[i].cells[dp.full[i].masks.any(axis=0)]
    driven = int(reachable[full].sum())
    if driven == 0:
        return diagnosed(ctx, step, opts, NO_PATH, no_path_hint(full.size, 0))
    ik, hits, culprit = ctx.problems.checks.tally(i)
    how = f"{ik + hits} checks: {ik} failed IK, {hits} in collision" + (f", mostly {culprit}" if culprit else "")
    facts: dict[str, Any] = {"tried": ik + hits, "ik_failures": ik, "collision_failures": hits, "culprit": culprit}
    # (cell, group) placements of the step verification rejected (the program removed them all by now:
    # a chain is sought over every group, less only these, before a step is called infeasible)
    rejected = dp.rejected_at(i)
    if rejected and not dp.regions[i].any():
        reason = f"IK or the collision check rejected all {rejected} placements the maps allow ({how})"
        return diagnosed(ctx, step, opts, reason, "another grasp, or room around the target, would help", facts)
    left = dp.regions[i].cells[dp.regions[i].masks.any(axis=0)]
    if rejected and not reachable[left].any():  # the rejections took every cell the base can reach
        reason = f"IK or the collision check rejected the placements the base can reach ({rejected} placements; {how})"
        rest = "; the others lie where the footprint cannot drive" if full.size > driven else ""
        return diagnosed(ctx, step, opts, reason, no_path_hint(full.size, driven) + rest, facts)
    if dp.linked[i]:  # per pair that picks: what stops it at the place (the step-by-step methods' words)
        pick = steps[i - 1]
        places = {g for g, m in zip(dp.full[i].groups, dp.full[i].masks) if m.any()}
        said = f"IK or the collision check rejected the placements the maps allow ({how})"
        failed = {
            g: (said if g in places else "") for g, m in zip(dp.full[i - 1].groups, dp.full[i - 1].masks) if m.any()
        }
        reason = transfer_reason(ctx, pick, step, failed, opts)
        facts["transfers"] = transfer_diagnosis(failed, opts)
        return diagnosed(ctx, step, opts, reason, "another place for the object, or more grasps, would help", facts)
    reason = "no chain of placements of the steps before reaches a placement of this step"
    return diagnosed(ctx, step, opts, reason, no_path_hint(full.size, driven))


class Optimal(Method):
    """The exact optimum of the task's travel over every feasible cell, verified lazily; with torso
    settings, of the travel plus the torso term over every (cell, setting)."""

    name = "optimal"
    uses_heuristic = False

    def plan(self, ctx: PlanningContext, start: Cell, keep_maps: bool) -> list[StepResult]:
        cfg = ctx.config
        return plan_dynamic(ctx, start, keep_maps, neighbourhood=1, exact_repairs=cfg.optimal_max_repairs, priced=True)


class Global(Optimal):
    """The default: the exact program while rejections are few (``global_exact_repairs``), then a
    rejection removes its 3 x 3 neighbourhood, so poor maps cannot make it slow."""

    name = "global"

    def plan(self, ctx: PlanningContext, start: Cell, keep_maps: bool) -> list[StepResult]:
        cfg = ctx.config
        return plan_dynamic(ctx, start, keep_maps, neighbourhood=1, exact_repairs=cfg.global_exact_repairs, local=True)


__all__ = ["DynamicProgram", "Global", "Optimal", "Verified", "plan_dynamic", "reweighted", "solve_verified"]
