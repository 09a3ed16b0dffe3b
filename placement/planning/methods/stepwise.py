"""Step-by-step planning (paper section IV): each step's best verified placement, in task order.

Used by ``sequential``, ``single-step`` and ``irm`` (ranked by Eq. 6 with their weights) and by
``fixed`` (ranked by manipulability at the pre-defined placements).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..navigation import extract_path, navigation_cost
from ..option import Option, height_range
from ..ranking import Ranked, combined_map, rank_by_cost
from ..results import Cost, StepMaps, StepResult
from ..steps import Step
from ..verify import trajectory_ik

if TYPE_CHECKING:
    from ..planner import Planner

#: ranker(planner, options, navigation cost, heuristic) -> ranked placements
Ranker = Callable[["Planner", list, np.ndarray, np.ndarray], list[Ranked]]


def rank_eq6(planner: Planner, options: list[Option], nav_cost: np.ndarray,
             heuristic: np.ndarray) -> list[Ranked]:
    """Eq. 6 with the method's weights (see :func:`~placement.planning.ranking.rank_by_cost`)."""
    return rank_by_cost(options, nav_cost, heuristic, planner.config, planner.yaws)


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
    failed = []  # (option, row, column) of placements where IK failed
    tries = 0
    xs, ys = nav.centres()
    for r in ranked:
        if tries >= cfg.ik_tries:
            break
        o = opts[r.option]
        iy, ix = divmod(r.cell, nav.shape[1])
        if not np.isfinite(nav_cost[iy, ix]):
            continue  # a fixed placement the base cannot get to from here
        # the next cell of the same candidate almost always fails the same way: spend the
        # IK budget on distinct placements instead
        if any(fk == r.option and abs(fy - iy) <= 1 and abs(fx - ix) <= 1 for fk, fy, fx in failed):
            continue
        tries += 1
        base = (float(xs[ix]), float(ys[iy]), r.yaw)
        q = trajectory_ik(planner.robot, o.arm, o.candidate.poses, base, prev_q[o.arm])
        if q is None:
            failed.append((r.option, iy, ix))
            continue
        timings["ik"] = (time.perf_counter() - t) * 1e3
        if maps is not None:
            maps.path = extract_path(pred, (iy, ix))
        value = o.value_at(iy, ix) if planner.method != "fixed" else -r.cost
        result = placed(planner, step, o, base, q, float(nav_cost[iy, ix]), float(heur[iy, ix]), value, timings)
        result.maps = maps
        return result, (iy, ix)
    timings["ik"] = (time.perf_counter() - t) * 1e3
    if ranked:
        reason = f"IK failed for the best {tries} distinct placements"
    else:
        reason = unreachable_reason(planner, opts)
    return StepResult(step.index, step.action, step.target, status="infeasible", reason=reason, timings_ms=timings,
                      maps=maps), None


def unreachable_reason(planner: Planner, opts: list[Option]) -> str:
    """Why no placement of a step keeps the threshold, in words."""
    if opts and all(o.out_of_range for o in opts):
        ranges = ", ".join(f"{arm} {lo:.2f}..{hi:.2f} m" for arm, (lo, hi) in
                           ((a, height_range(m)) for a, m in planner.maps.items()))
        z = sorted({round(float(v), 3) for o in opts for v in o.candidate.poses[:, 2, 3]})
        return (f"the TCP poses (heights {', '.join(f'{v:g}' for v in z)} m) are outside the height range of "
                f"the maps ({ranges} above the base frame)")
    return f"no base placement reaches the target with the map threshold {planner.config.threshold}"


def placed(planner: Planner, step: Step, o: Option, base, q: np.ndarray, nav_c: float, heur_c: float,
           value: float, timings: dict) -> StepResult:
    """The result of a verified placement: weighted Eq. 6 terms, joints by name, travel time."""
    cfg = planner.config
    arm = planner.robot.arm(o.arm)
    joints = {name: float(v) for name, v in zip(arm.joints, q)}
    joints.update(planner.robot.fixed_joints)
    cost = Cost(cfg.lambda_n * nav_c, cfg.lambda_m / value, cfg.lambda_nh * heur_c)
    return StepResult(step.index, step.action, step.target, arm=o.arm, grasp=o.candidate.name,
                      base=(base[0], base[1], base[2]), tcp=o.candidate.poses, q=q, joints=joints,
                      manipulability=value, cost=cost, travel_time_s=nav_c / planner.robot.v_max,
                      timings_ms=timings)
