"""Whole-task planning by dynamic programming over every feasible base cell: ``optimal`` and ``global``.

Both solve the forward program of :mod:`placement.planning.bound` over the regions of the maps (every
cell where some (arm, grasp) keeps the threshold, per group; a place keeps its pick's group) and
verify the cheapest chain lazily: each step's placement along the chain, in task order, gets IK of
every pose (started from the map's witness, then the arm's home: a placement's answer is its own,
kept by :mod:`placement.planning.checks` across re-plans) and the collision
check, trying the group's options that keep the threshold there by decreasing map value, each at
its best base yaw. A rejected (cell, group) is removed from its step's region, the program is solved
again from that step on, and the loop ends when every step of the chain verifies.

The objective is the task's base travel [m] (``travel_time_s`` times ``v_max``), plus, with
``optimal_manipulability_weight`` > 0, that weight times ``1 / m`` per step (Eq. 6's manipulation
term) as a tie-breaker between cells of similar travel. The model's approximations: base rotation
and arm motion run in parallel with the travel (SPEC section 8) and are not in the objective (they
add time only where a step's rotation or arm motion outlasts its travel: see ``task_time``); a cell
stands for its centre, at the best yaw of the option.

``optimal`` removes exactly the rejected (cell, group) and solves again (``optimal_probe`` > 0:
it verifies the rejected cell's neighbours at once, removing those that fail too; IK and the
collision check cost more than a solve of :class:`~placement.planning.bound.Program`, so the
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
bound (:mod:`placement.planning.bound`), kept for the certificate.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import replace

import numpy as np

from placement.planning.arrays import Cell
from placement.planning.bound import Chain, Layer, Program, linked_steps
from placement.planning.context import PlanningContext
from placement.planning.explain import explain
from placement.planning.methods.base import Method
from placement.planning.methods.outcomes import infeasible, placed, unreachable_reason
from placement.planning.methods.repair import Verified, repair
from placement.planning.navigation import extract_path, navigation_cost
from placement.planning.option import Option
from placement.planning.regions import Group, held_torso, map_regions, reweighted
from placement.planning.results import StepMaps, StepResult
from placement.planning.search import collision_args
from placement.planning.torso import collisions_at, option_map, robot_at, start_torso, torso_first, torso_joint
from placement.planning.verify import TrajectoryIK, trajectory_ik

log = logging.getLogger(__name__)


class DynamicProgram:
    """One plan's program: regions (changed by repairs), layers, the verified and rejected placements."""

    def __init__(self, ctx: PlanningContext, start: Cell, neighbourhood: int = 0, exact_repairs: int | None = None):
        self.ctx, self.start, self.neighbourhood = ctx, start, neighbourhood
        #: rejections removed one (cell, group) at a time before ``neighbourhood`` applies (None: always)
        self.exact_repairs = exact_repairs
        steps = ctx.problems.steps
        self.linked = linked_steps(ctx)
        #: per step, the torso value [m] its region and verification hold the lift at (None: any)
        self.hold = [held_torso(ctx, i) for i in range(len(steps))]
        self.full = [map_regions(ctx, i, held=h) for i, h in enumerate(self.hold)]
        self.regions = [reweighted(ctx, i, r) for i, r in enumerate(self.full)]
        w = ctx.world
        self.program = Program(w.factor, w.feasible, w.nav.resolution, start, self.linked)
        # what verification found, kept by the planner's per-step cache: a later plan of the same
        # scene replays the same program with the IK answers looked up (same plan, without the IK
        # time); the cache of a changed scene starts empty
        #: (step, flat cell, group, the torso value held or None) -> what verification found
        self.verified: dict[tuple[int, int, Group, float | None], Verified | None] = ctx.problems.verdicts
        self.repairs = 0
        self.rejected = [0] * len(steps)
        #: a rejection took its neighbours with it (see :meth:`exact_again`)
        self.coarse = False
        self.solves = 0
        self.first_total = math.inf  # the first solve's optimum [m]
        #: a rejected placement is first moved to the least detour that verifies (:mod:`.repair`)
        self.local = False
        self.repairs_local = 0
        #: the torso value [m] the robot holds at the step being verified (None: no torso settings)
        self.torso: float | None = start_torso(ctx)

    def solve(self, first: int = 0) -> Chain | None:
        """The cheapest chain over the current regions, recomputing the layers from step ``first``
        (the transfer rule applied where it binds: :class:`~placement.planning.bound.Program`)."""
        self.solves += 1
        chain = self.program.solve(self.regions, first)
        if self.solves == 1 and not self.program.loose:  # a chain with loose transfers is no bound
            self.first_total = chain.total if chain is not None else math.inf
        return chain

    @property
    def layers(self) -> list[Layer]:
        """The layers of the last solve."""
        return self.program.layers

    def verify(self, i: int, flat: int, g: int) -> Verified | None:
        """The first of step i's options of group g at ``flat`` that passes IK and the collision check
        (by map value; with torso settings, those at the torso value the robot holds (:attr:`torso`)
        first, see :mod:`placement.planning.torso`)."""
        key = (i, flat, self.regions[i].groups[g], self.hold[i])
        if key in self.verified:
            return self.verified[key]
        ctx = self.ctx
        nav = ctx.world.nav
        iy, ix = divmod(flat, nav.shape[1])
        xs, ys = nav.centres()
        step = ctx.problems.steps[i]
        group = self.regions[i].groups[g]
        opts = self.options(i)
        order = sorted(
            (k for k, o in enumerate(opts) if (o.arm, o.candidate.grasp) == group),
            key=lambda k: -opts[k].value_at(iy, ix),
        )
        hold = self.hold[i]
        order = [
            k
            for k in order
            if opts[k].value_at(iy, ix) >= ctx.threshold(opts[k].arm, opts[k].torso)
            and (hold is None or opts[k].torso == hold)
        ]
        found = None
        checks = ctx.problems.checks
        for k in torso_first(opts, order, self.torso):
            o = opts[k]
            value = o.value_at(iy, ix)
            base = (float(xs[ix]), float(ys[iy]), float(ctx.yaws[o.yaw_at(iy, ix)]))
            ck = (i, hold, k, flat)
            ik = checks.ik.get(ck)
            if ik is None:
                ik = checks.ik[ck] = self._ik(o, base)
            if not ik.ok:
                continue
            clearance = None
            checker = collisions_at(ctx, o.torso)
            if checker is not None:
                check = checks.collision.get(ck)
                if check is None:
                    check = checks.collision[ck] = checker.check(o.arm, ik.qs, base, **collision_args(ctx, step, o))
                if not check.free:
                    continue
                clearance = float(check.clearance_m)
            found = Verified(k, base, ik, clearance, value)
            break
        self.verified[key] = found
        return found

    def _ik(self, o: Option, base: tuple[float, float, float]) -> TrajectoryIK:
        """IK of option ``o``'s poses with the base at ``base``, started from the map's witness, then
        the arm's home and random restarts: not from the arm's configuration after the step before,
        so that the answer is the placement's alone and stays valid when earlier steps change (see
        :mod:`placement.planning.checks`)."""
        witness = getattr(option_map(self.ctx, o), "witness_q", None)
        robot = robot_at(self.ctx, o.torso)
        home = self.ctx.robot.arm(o.arm).home
        return trajectory_ik(robot, o.arm, o.candidate.poses, base, home, witness, self.ctx.config)

    def remove(self, i: int, flat: int, g: int, count: bool = True) -> None:
        """Take the rejected (cell, group) (and its neighbourhood, for ``global``) out of step i's region."""
        reg = self.regions[i]
        masks = reg.masks.copy()
        iy, ix = divmod(flat, masks.shape[2])
        late = count and self.exact_repairs is not None and self.repairs >= self.exact_repairs
        r = self.neighbourhood if late else 0
        self.coarse = self.coarse or r > 0
        masks[g, max(iy - r, 0) : iy + r + 1, max(ix - r, 0) : ix + r + 1] = False
        self.regions[i] = replace(reg, masks=masks)
        if count:
            self.rejected[i] += 1
            self.repairs += 1

    def options(self, i: int) -> list[Option]:
        """The options step i is verified with: those at the held lift value, or all of them."""
        hold = self.hold[i]
        return self.ctx.problems.options(i) if hold is None else self.ctx.problems.held_options(i, hold)

    def release_lift(self) -> Chain | None:
        """Solve again with the lift free (every torso setting, see
        :func:`~placement.planning.bound.map_regions`) at the first step no chain reaches when that
        step held it, else at every step; the rejections made with the lift held stay removed."""
        i = next((k for k, layer in enumerate(self.layers) if not np.isfinite(layer.labels).any()), None)
        free = [i] if i is not None and self.hold[i] is not None else range(len(self.hold))
        for k in free:
            self.hold[k] = None
            self.full[k] = map_regions(self.ctx, k)
        return self.exact_again()

    def exact_again(self) -> Chain | None:
        """Solve again over the maps' regions less only the placements verification rejected, never
        removing neighbours again (when removing them left no chain)."""
        self.exact_repairs, self.coarse = None, False
        self.regions = [reweighted(self.ctx, i, r) for i, r in enumerate(self.full)]
        for (i, flat, group, hold), v in self.verified.items():
            if v is None and hold == self.hold[i] and i < len(self.full) and group in self.full[i].groups:
                self.remove(i, flat, self.full[i].groups.index(group), count=False)
        return self.solve()

    def reject_around(self, i: int, flat: int, g: int) -> None:
        """Verify the cells around a rejected one (``ctx.config.optimal_probe`` cells each way) now and
        remove those that fail too: rejections cluster (at the frontier of reach, beside an
        obstacle), and an IK call costs less than solving the program again for each of them."""
        r = self.ctx.config.optimal_probe
        masks = self.regions[i].masks
        ny, nx = masks.shape[1:]
        iy, ix = divmod(flat, nx)
        for y in range(max(iy - r, 0), min(iy + r + 1, ny)):
            for x in range(max(ix - r, 0), min(ix + r + 1, nx)):
                f = y * nx + x
                if self.regions[i].masks[g, y, x] and self.verify(i, f, g) is None:
                    self.remove(i, f, g)


def solve_verified(dp: DynamicProgram) -> tuple[Chain | None, list[Verified], StepResult | None]:
    """Solve ``dp`` until its cheapest chain verifies: (the chain, each step's verified placement,
    None), or (None, [], the infeasible result saying why)."""
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
            chosen = dp.options(i)[v.option]
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
        chain = dp.solve(failed[0][0])


def plan_dynamic(
    ctx: PlanningContext,
    start: Cell,
    keep_maps: bool,
    neighbourhood: int = 0,
    exact_repairs: int | None = None,
    local: bool = False,
) -> list[StepResult]:
    """The verified cheapest chain's steps; when none is left, a single infeasible step saying why."""
    t0 = time.perf_counter()
    if not ctx.problems.steps:
        return []
    dp = DynamicProgram(ctx, start, neighbourhood, exact_repairs)
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
    if failure is not None or chain is None:
        return [failure] if failure is not None else []
    out = results(ctx, start, dp, chain, picks, keep_maps)
    ms = (time.perf_counter() - t0) * 1e3
    log.debug(
        "dynamic program: %d placements checked, %d rejected, %d solves, %d local repairs, %.0f ms",
        len(dp.verified),
        dp.repairs,
        dp.solves,
        dp.repairs_local,
        ms,
    )
    for s in out:
        s.timings_ms = {"total": ms / len(out)}
    return out


def results(
    ctx: PlanningContext, start: Cell, dp: DynamicProgram, chain: Chain, picks: list[Verified], keep_maps: bool
) -> list[StepResult]:
    """The step results of a verified chain: each step's travel [m] is its label less the previous
    step's and its node cost (the chain's legs are shortest paths from the previous cell)."""
    nav = ctx.world.nav
    out = []
    prev_label, prev_cell = 0.0, start
    for i, (flat, g, v) in enumerate(zip(chain.cells, chain.groups, picks)):
        step = ctx.problems.steps[i]
        o = dp.options(i)[v.option]
        iy, ix = divmod(flat, nav.shape[1])
        node = dp.regions[i].node
        travel = max(chain.labels[i] - prev_label - (0.0 if node is None else float(node[g].flat[flat])), 0.0)
        r = placed(ctx, step, o, v.base, v.ik.qs, travel, 0.0, v.value, {}, v.clearance_m)
        if keep_maps:
            navc, pred = navigation_cost(ctx.world.factor, ctx.world.feasible, prev_cell, nav.resolution)
            manip = np.max([p.full_value(nav.shape) for p in ctx.problems.options(i)], axis=0)
            r.maps = StepMaps(navc, np.zeros(nav.shape), manip, None, extract_path(pred, (iy, ix)))
        out.append(r)
        prev_label, prev_cell = chain.labels[i], (iy, ix)
    return out


def why_not(ctx: PlanningContext, dp: DynamicProgram) -> StepResult:
    """The infeasible result of the first step no chain reaches, and why."""
    steps = ctx.problems.steps
    i = next(k for k, layer in enumerate(dp.layers) if not np.isfinite(layer.labels).any())
    step = steps[i]
    opts = ctx.problems.options(i)
    if not dp.full[i].masks.any():
        reason, diagnosis = explain(ctx, False, step, opts, None, unreachable_reason(ctx, opts))
        return infeasible(step, reason, diagnosis)
    if dp.rejected[i] and not dp.regions[i].masks.any():
        return infeasible(step, f"IK or the collision check rejected all {dp.rejected[i]} placements the maps allow")
    if dp.linked[i]:
        return infeasible(
            step,
            f"no arm and grasp that picks '{step.carries}' reaches '{step.target}' "
            f"(a transfer keeps the arm and the grasp; {dp.rejected[i - 1] + dp.rejected[i]} placements "
            "rejected by IK or the collision check)",
        )
    return infeasible(step, "no collision-free path for the base reaches a placement of this step")


class Optimal(Method):
    """The exact optimum of the task's travel over every feasible cell, verified lazily."""

    name = "optimal"
    uses_heuristic = False

    def plan(self, ctx: PlanningContext, start: Cell, keep_maps: bool) -> list[StepResult]:
        return plan_dynamic(ctx, start, keep_maps, neighbourhood=1, exact_repairs=ctx.config.optimal_max_repairs)


class Global(Optimal):
    """The default: the exact program while rejections are few (``global_exact_repairs``), then a
    rejection removes its 3 x 3 neighbourhood, so poor maps cannot make it slow."""

    name = "global"

    def plan(self, ctx: PlanningContext, start: Cell, keep_maps: bool) -> list[StepResult]:
        cfg = ctx.config
        return plan_dynamic(ctx, start, keep_maps, neighbourhood=1, exact_repairs=cfg.global_exact_repairs, local=True)


__all__ = ["DynamicProgram", "Global", "Optimal", "Verified", "plan_dynamic", "reweighted", "solve_verified"]
