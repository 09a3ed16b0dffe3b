"""Step-by-step planning (paper section IV): each step's best verified placement, in task order.

Used by ``sequential``, ``single-step`` and ``irm`` (ranked by Eq. 6 with their weights) and by
``fixed`` (ranked by manipulability at the pre-defined placements).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from placement.planning.explain import explain
from placement.planning.navigation import extract_path, navigation_cost
from placement.planning.option import Option, height_range
from placement.planning.ranking import Ranked, combined_map, rank_by_cost
from placement.planning.results import Cost, StepMaps, StepResult
from placement.planning.search import search_placement
from placement.planning.steps import Step

if TYPE_CHECKING:
    from placement.planning.planner import Planner

#: ranker(planner, options, navigation cost, heuristic) -> ranked placements
Ranker = Callable[["Planner", list, np.ndarray, np.ndarray], list[Ranked]]


def rank_eq6(
    planner: Planner, options: list[Option], nav_cost: np.ndarray, heuristic: np.ndarray, per_option: int | None = None
) -> list[Ranked]:
    """Eq. 6 with the method's weights (see :func:`~placement.planning.ranking.rank_by_cost`): the
    ``per_option`` cheapest cells of each option and tier (default ``ik_tries``)."""
    cfg = planner.config if per_option is None else replace(planner.config, ik_tries=per_option)
    return rank_by_cost(options, nav_cost, heuristic, cfg, planner.yaws)


def plan_stepwise(planner: Planner, start_cell: tuple[int, int], rank: Ranker, keep_maps: bool) -> list[StepResult]:
    """Plan the steps in order from ``start_cell``, each from the previous placement; a pick and its
    place as one transfer (:func:`plan_transfer`); stops at the first infeasible step (it is the
    last result)."""
    prev_cell = start_cell
    prev_q = {arm: planner.robot.arm(arm).home.copy() for arm in planner.maps}
    steps = planner.problems.steps
    out: list[StepResult] = []
    i = 0
    while i < len(steps):
        step = steps[i]
        if step.action == "pick" and i + 1 < len(steps) and steps[i + 1].pick == i:
            results, cell = plan_transfer(planner, step, steps[i + 1], prev_cell, prev_q, rank, keep_maps)
        else:
            t0 = time.perf_counter()
            result, cell = plan_step(planner, step, prev_cell, prev_q, rank, keep_maps)
            result.timings_ms["total"] = (time.perf_counter() - t0) * 1e3
            results = [result]
        out += results
        if not results[-1].ok:
            break
        prev_cell = cell
        for r in results:
            prev_q[r.arm] = r.q
        i += len(results)
    return out


def plan_transfer(
    planner: Planner, pick: Step, place: Step, prev_cell, prev_q: dict, rank: Ranker, keep_maps: bool
) -> tuple[list[StepResult], tuple[int, int] | None]:
    """A pick and its place with the same arm and grasp.

    The pick may use only the (arm, grasp) pairs with which the maps reach a place pose of the
    object (:meth:`StepProblems.pairs`); the place then uses the pick's pair only. When that place
    does not verify, the pick is planned again without the pair, until a pair verifies both or
    none is left: the pick step is then infeasible, and its reason says, per arm and grasp, what
    failed at which place. Returns the pick's and the place's results (the pick's alone when
    infeasible) and the place's cell."""
    problems = planner.problems
    t0 = time.perf_counter()
    picks = {(o.arm, o.candidate.grasp) for o in problems.options(pick.index)}
    viable = problems.pairs(place.index)
    irms_ms = (time.perf_counter() - t0) * 1e3  # the pick's and the place's IRMs: manipulation work
    failed: dict[tuple, str] = {p: "" for p in picks - viable}  # pair -> its place's failure ("": by the maps)
    while True:
        allowed = picks - failed.keys()
        if not allowed:
            result = StepResult(
                pick.index,
                pick.action,
                pick.target,
                status="infeasible",
                reason=transfer_reason(planner, pick, place, failed),
                diagnosis={"place": place.target, "transfers": transfer_diagnosis(failed)},
                timings_ms={"total": (time.perf_counter() - t0) * 1e3},
            )
            return [result], None
        first, cell = plan_step(planner, pick, prev_cell, prev_q, rank, keep_maps, allowed)
        if not first.ok:
            if failed:
                first.reason += (
                    f" (not tried: {excluded_words(failed)}, which cannot set '{pick.target}' down at '{place.target}')"
                )
            first.timings_ms["total"] = (time.perf_counter() - t0) * 1e3
            return [first], None
        t1 = time.perf_counter()
        pair = (first.arm, first.grasp)
        second, cell = plan_step(planner, place, cell, {**prev_q, first.arm: first.q}, rank, keep_maps, {pair})
        second.timings_ms["total"] = (time.perf_counter() - t1) * 1e3
        if second.ok:
            first.timings_ms["total"] = (t1 - t0) * 1e3
            first.timings_ms["manipulation"] = first.timings_ms.get("manipulation", 0.0) + irms_ms
            return [first, second], cell
        failed[pair] = second.reason or "infeasible"


def excluded_words(failed: dict) -> str:
    """ "arm left: top, top-flipped; arm right: top" for the (arm, grasp) pairs of ``failed``."""
    arms: dict[str, list] = {}
    for arm, grasp in sorted(failed, key=lambda p: (p[0], str(p[1]))):
        arms.setdefault(arm, []).append(str(grasp))
    return "; ".join(f"arm {a}: {', '.join(g)}" for a, g in arms.items())


def transfer_reason(planner: Planner, pick: Step, place: Step, failed: dict) -> str:
    """Why no (arm, grasp) of ``pick`` sets its object down at ``place``, in one line."""
    unreached = {p: r for p, r in failed.items() if not r}
    tried = {p: r for p, r in failed.items() if r}
    parts = []
    if unreached:
        parts.append(
            f"{excluded_words(unreached)}: no base placement reaches a place pose with the map threshold "
            f"{planner.config.threshold:g}"
        )
    for p, r in tried.items():
        parts.append(f"arm {p[0]}, grasp {p[1]}: picked, but the place failed: {r}")
    return (
        f"no grasp of '{pick.target}' lets the arm that picks it set it down at '{place.target}' "
        f"(a transfer keeps the arm and the grasp): {'; '.join(parts)}"
    )


def transfer_diagnosis(failed: dict) -> list[dict]:
    """Per (arm, grasp) pair: why its place failed (JSON)."""
    return [
        {"arm": a, "grasp": g, "failed": r or "no place pose keeps the map threshold"}
        for (a, g), r in sorted(failed.items(), key=lambda kv: (kv[0][0], str(kv[0][1])))
    ]


def plan_step(
    planner: Planner, step: Step, prev_cell, prev_q: dict, rank: Ranker, keep_maps: bool, pairs: set | None = None
) -> tuple[StepResult, tuple[int, int] | None]:
    """The best verified placement of one step (or an infeasible result) and its cell; ``pairs``:
    the (arm, grasp) pairs the step may use (default all)."""
    cfg, problems, world = planner.config, planner.problems, planner.world
    nav = world.nav
    timings: dict[str, float] = {}
    t = time.perf_counter()
    opts = problems.options(step.index)
    if pairs is not None:
        opts = [o for o in opts if (o.arm, o.candidate.grasp) in pairs]
    steer = step.index + 1 < len(problems.steps) and cfg.lambda_nh > 0
    if steer:
        problems.options(step.index + 1)  # the next step's IRMs: manipulation work, cached for that step
    timings["manipulation"] = (time.perf_counter() - t) * 1e3
    # only this step's candidate cells are read from the cost maps (all cells for plots)
    needed = None if keep_maps or planner.method == "fixed" else problems.feasible_region(step.index, opts)
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
        result = placed(
            planner,
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
        result.maps = maps
        result.tried = search.tried
        return result, (iy, ix)
    reason, diagnosis = explain(planner, step, opts, search, "" if ranked else unreachable_reason(planner, opts))
    result = StepResult(
        step.index,
        step.action,
        step.target,
        status="infeasible",
        reason=reason,
        diagnosis=diagnosis,
        timings_ms=timings,
        maps=maps,
    )
    result.tried = search.tried if search else 0
    return result, None


def unreachable_reason(planner: Planner, opts: list[Option]) -> str:
    """Why no placement of a step keeps the threshold, in words."""
    if opts and all(o.out_of_range for o in opts):
        ranges = ", ".join(
            f"{arm} {lo:.2f}..{hi:.2f} m" for arm, (lo, hi) in ((a, height_range(m)) for a, m in planner.maps.items())
        )
        z = sorted({round(float(v), 3) for o in opts for v in o.candidate.poses[:, 2, 3]})
        return (
            f"the TCP poses (heights {', '.join(f'{v:g}' for v in z)} m) are outside the height range of "
            f"the maps ({ranges} above the base frame)"
        )
    return f"no base placement reaches the target with the map threshold {planner.config.threshold}"


def placed(
    planner: Planner,
    step: Step,
    o: Option,
    base,
    qs: np.ndarray,
    nav_c: float,
    heur_c: float,
    value: float,
    timings: dict,
    clearance_m: float | None = None,
) -> StepResult:
    """The result of a verified placement: weighted Eq. 6 terms, joints by name (``qs`` (P, n): the
    arm at every pose of the trajectory), travel time, clearance [m] (None without a collision check)."""
    cfg = planner.config
    arm = planner.robot.arm(o.arm)
    q = qs[-1]
    joints = {name: float(v) for name, v in zip(arm.joints, q)}
    joints.update(planner.robot.fixed_joints)
    cost = Cost(cfg.lambda_n * nav_c, cfg.lambda_m / value, cfg.lambda_nh * heur_c)
    c = o.candidate
    return StepResult(
        step.index,
        step.action,
        step.target,
        arm=o.arm,
        grasp=c.grasp or c.name,
        base=(base[0], base[1], base[2]),
        tcp=c.poses,
        q=q,
        qs=qs,
        joints=joints,
        clearance_m=clearance_m,
        manipulability=value,
        cost=cost,
        travel_time_s=nav_c / planner.robot.v_max,
        timings_ms=timings,
        trajectory=c.name,
        object=step.carries,
        placed_pose=c.object_pose,
        support=c.support,
    )
