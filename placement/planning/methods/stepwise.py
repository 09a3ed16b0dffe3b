"""Step-by-step planning (paper section IV): each step's best verified placement, in task order.

Used by ``sequential``, ``single-step`` and ``irm`` (ranked by Eq. 6 with their weights) and by
``fixed`` (ranked by manipulability at the pre-defined placements).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..explain import explain
from ..navigation import extract_path, navigation_cost
from ..option import Option, height_range
from ..ranking import Ranked, combined_map, rank_by_cost
from ..results import Cost, StepMaps, StepResult
from ..search import search_placement
from ..steps import Step

if TYPE_CHECKING:
    from ..planner import Planner

#: ranker(planner, options, navigation cost, heuristic) -> ranked placements
Ranker = Callable[["Planner", list, np.ndarray, np.ndarray], list[Ranked]]


def rank_eq6(planner: Planner, options: list[Option], nav_cost: np.ndarray,
             heuristic: np.ndarray, per_option: int | None = None) -> list[Ranked]:
    """Eq. 6 with the method's weights (see :func:`~placement.planning.ranking.rank_by_cost`): the
    ``per_option`` cheapest cells of each option and tier (default ``ik_tries``)."""
    cfg = planner.config if per_option is None else replace(planner.config, ik_tries=per_option)
    return rank_by_cost(options, nav_cost, heuristic, cfg, planner.yaws)


def plan_stepwise(planner: Planner, start_cell: tuple[int, int], rank: Ranker, keep_maps: bool) -> list[StepResult]:
    """Plan the steps in order from ``start_cell``, each from the previous placement; stops at the
    first infeasible step (it is the last result)."""
    prev_cell = start_cell
    prev_q = {arm: planner.robot.arm(arm).home.copy() for arm in planner.maps}
    out = []
    for step in planner.problems.steps:
        t0 = time.perf_counter()
        result, cell = plan_step(planner, step, prev_cell, prev_q, rank, keep_maps)
        result.timings_ms["total"] = (time.perf_counter() - t0) * 1e3
        out.append(result)
        if not result.ok:
            break
        prev_cell = cell
        prev_q[result.arm] = result.q
    return out


def plan_step(planner: Planner, step: Step, prev_cell, prev_q: dict, rank: Ranker,
              keep_maps: bool) -> tuple[StepResult, tuple[int, int] | None]:
    """The best verified placement of one step (or an infeasible result) and its cell."""
    cfg, problems, world = planner.config, planner.problems, planner.world
    nav = world.nav
    timings: dict[str, float] = {}
    t = time.perf_counter()
    opts = problems.options(step.index)
    steer = step.index + 1 < len(problems.steps) and cfg.lambda_nh > 0
    if steer:
        problems.options(step.index + 1)  # the next step's IRMs: manipulation work, cached for that step
    timings["manipulation"] = (time.perf_counter() - t) * 1e3
    # only this step's candidate cells are read from the cost maps (all cells for plots)
    needed = None if keep_maps or planner.method == "fixed" else problems.feasible_region(step.index)
    t = time.perf_counter()
    nav_cost, pred = navigation_cost(world.factor, world.feasible, prev_cell, nav.resolution, targets=needed)
    timings["navigation"] = (time.perf_counter() - t) * 1e3
    t = time.perf_counter()
    heur = problems.heuristic(step.index + 1, needed) if steer else np.zeros(nav.shape)
    timings["heuristic"] = (time.perf_counter() - t) * 1e3
    t = time.perf_counter()
    ranked = rank(planner, opts, nav_cost, heur)
    timings["combine"] = (time.perf_counter() - t) * 1e3
    maps = None
    if keep_maps:
        manip = np.max([o.full_value(nav.shape) for o in opts], axis=0) if opts else None
        combined = combined_map(opts, nav_cost, heur, cfg) if planner.method != "fixed" else None
        maps = StepMaps(nav_cost, heur, manip, combined)
    t = time.perf_counter()
    more = None
    if rank is rank_eq6:  # every ranked placement, for the spread phase of the search
        def more():
            return rank_eq6(planner, opts, nav_cost, heur, per_option=cfg.ik_cap)
    found = search = None
    if ranked:
        search = search_placement(planner, step, opts, ranked, more, nav_cost, heur, prev_q)
        found = search.found
    # the whole search, and within it the IK solves and the collision checks
    timings["search"] = (time.perf_counter() - t) * 1e3
    timings["ik"] = search.ik_ms if search else 0.0
    timings["collision"] = search.collision_ms if search else 0.0
    if found is not None:
        r = found.ranked
        o = opts[r.option]
        iy, ix = divmod(r.cell, nav.shape[1])
        if maps is not None:
            maps.path = extract_path(pred, (iy, ix))
        value = found.value or (o.value_at(iy, ix) if planner.method != "fixed" else -r.cost)
        result = placed(planner, step, o, found.base, found.ik.qs, float(nav_cost[iy, ix]), float(heur[iy, ix]),
                        value, timings, found.clearance_m)
        result.maps = maps
        result.tried = search.tried
        return result, (iy, ix)
    reason, diagnosis = explain(planner, step, opts, search, "" if ranked else unreachable_reason(planner, opts))
    result = StepResult(step.index, step.action, step.target, status="infeasible", reason=reason,
                        diagnosis=diagnosis, timings_ms=timings, maps=maps)
    result.tried = search.tried if search else 0
    return result, None


def unreachable_reason(planner: Planner, opts: list[Option]) -> str:
    """Why no placement of a step keeps the threshold, in words."""
    if opts and all(o.out_of_range for o in opts):
        ranges = ", ".join(f"{arm} {lo:.2f}..{hi:.2f} m" for arm, (lo, hi) in
                           ((a, height_range(m)) for a, m in planner.maps.items()))
        z = sorted({round(float(v), 3) for o in opts for v in o.candidate.poses[:, 2, 3]})
        return (f"the TCP poses (heights {', '.join(f'{v:g}' for v in z)} m) are outside the height range of "
                f"the maps ({ranges} above the base frame)")
    return f"no base placement reaches the target with the map threshold {planner.config.threshold}"


def placed(planner: Planner, step: Step, o: Option, base, qs: np.ndarray, nav_c: float, heur_c: float,
           value: float, timings: dict, clearance_m: float | None = None) -> StepResult:
    """The result of a verified placement: weighted Eq. 6 terms, joints by name (``qs`` (P, n): the
    arm at every pose of the trajectory), travel time, clearance [m] (None without a collision check)."""
    cfg = planner.config
    arm = planner.robot.arm(o.arm)
    q = qs[-1]
    joints = {name: float(v) for name, v in zip(arm.joints, q)}
    joints.update(planner.robot.fixed_joints)
    cost = Cost(cfg.lambda_n * nav_c, cfg.lambda_m / value, cfg.lambda_nh * heur_c)
    return StepResult(step.index, step.action, step.target, arm=o.arm, grasp=o.candidate.name,
                      base=(base[0], base[1], base[2]), tcp=o.candidate.poses, q=q, qs=qs, joints=joints,
                      clearance_m=clearance_m,
                      manipulability=value, cost=cost, travel_time_s=nav_c / planner.robot.v_max,
                      timings_ms=timings)
