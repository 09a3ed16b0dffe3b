"""The verified chain polished for the task time: the turn between placements counts.

The whole-task program (:mod:`placement.planning.program.forward`) chooses the cells by travel, and a cell
stands for the base yaw with its best map value. In the task-time model
(:mod:`placement.planning.task_time`) the base turns while it travels: a step's base time is
``max(travel / v_max, |turn| / omega_max)``, beside the arm's and the torso's time. Where a leg is
short (a pick and its place at one table), a placement half a turn from the previous one costs
seconds that the least travel does not pay back. Two passes over a verified chain (its arms and
grasps fixed) take some of them back:

* :func:`time_cells` (``global`` only: ``optimal`` keeps the least travel): each step in turn may
  move to a cell of its region within :data:`CELL_WINDOW_M` of its own, at that cell's best yaw,
  where ``max(travel in, turn in, arm) + max(travel out, turn out, arm')`` is less (exact legs from
  the neighbours' cells; the arm's time is the verified plan's, an estimate); the candidates are
  verified as the program verifies (IK, collisions) in that order, at most :data:`CELL_TRIES` per step.
* :func:`time_yaws`: each placement's yaw among those at which its option keeps half the step's
  threshold and the footprint fits: the sequence with the least sum of ``max(travel, turn, arm)``
  (:func:`best_yaws`, exact over the steps); changed placements are verified, a step whose new yaw
  fails is pinned to its verified one and the sequence chosen again.

The caller keeps a pass's plan only when its task time, with the new IK, is lower; the certificate's
bound, on the travel of any plan over the maps' cells, bounds the task time too. ``time_polish: 0``
keeps the least travel at each cell's best map yaw; with ``face_target`` > 0 the facing yaws are kept
(the user asked for them) and neither pass runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from placement.planning.arrays import FloatArray
from placement.planning.facing import cell_yaws
from placement.planning.program.forward import Chain
from placement.planning.program.repair import Verified, node_cost
from placement.planning.program.state import DynamicProgram
from placement.planning.results import StepResult
from placement.planning.task_time import steps_seconds

#: [s] a changed yaw costs this much more than the verified one at equal time (ties keep the plan).
CHANGE_COST_S = 1e-9
#: [m] how far (along x and y) a step's cell may move in :func:`time_cells`.
CELL_WINDOW_M = 1.0
#: Cells verified per step in :func:`time_cells`, best first.
CELL_TRIES = 4
#: Share of the step's threshold a turned placement's map value must keep in :func:`time_yaws` (IK
#: and the collision check decide, as for a step planned with its threshold relaxed).
YAW_THRESHOLD_SHARE = 0.5


def polishes(dp: DynamicProgram) -> bool:
    """Whether the passes run: ``time_polish`` on and ``face_target`` off."""
    cfg = dp.ctx.config
    return bool(cfg.time_polish) and cfg.face_target <= 0


def _turn(a: FloatArray, b: FloatArray) -> FloatArray:
    """|b - a| the shorter way round [rad], broadcast."""
    out: FloatArray = np.abs((b - a + math.pi) % (2 * math.pi) - math.pi)
    return out


def best_yaws(
    start_yaw: float, travel_s: Sequence[float], arm_s: Sequence[float], candidates: Sequence[FloatArray], omega: float
) -> list[int]:
    """For each step, the index into its candidate yaws ``candidates[i]`` (K_i,) [rad] of the sequence
    with the least sum of ``max(travel_s[i], |yaw_i - yaw_(i-1)| / omega, arm_s[i])`` [s], the first
    yaw turning from ``start_yaw`` [rad]; ``omega`` [rad/s]. Candidate 0 of each step is its kept yaw:
    any other costs :data:`CHANGE_COST_S` more, so ties keep it. Exact (dynamic programming over the
    steps, O(sum K_i K_(i+1)))."""
    if not candidates:
        return []
    back: list[np.ndarray] = []
    prev = np.array([start_yaw])
    cost = np.zeros(1)
    for i, cand in enumerate(candidates):
        cand = np.asarray(cand, dtype=float)
        step = np.maximum(np.maximum(travel_s[i], _turn(prev[:, None], cand[None, :]) / omega), arm_s[i])
        step[:, 1:] += CHANGE_COST_S
        total = cost[:, None] + step
        arg = np.argmin(total, axis=0)
        back.append(arg)
        cost = total[arg, np.arange(cand.size)]
        prev = cand
    j = int(np.argmin(cost))
    out = [j]
    for arg in reversed(back[1:]):
        j = int(arg[j])
        out.append(j)
    return out[::-1]


def task_seconds(dp: DynamicProgram, steps: Sequence[StepResult]) -> float:
    """The task time [s] of planned steps, from the scene's start yaw (see :mod:`.task_time`)."""
    return sum(x["step_s"] for x in steps_seconds(dp.ctx.robot, steps, float(dp.ctx.scene.start[2])))


def _arm_seconds(dp: DynamicProgram, steps: Sequence[StepResult]) -> list[float]:
    return [x["arm_s"] for x in steps_seconds(dp.ctx.robot, steps, float(dp.ctx.scene.start[2]))]


def _group_best(dp: DynamicProgram, i: int, g: int, flats: np.ndarray) -> np.ndarray:
    """(n,) the base yaw index of the best map value over step i's options of group g at each flat
    cell of ``flats`` (n,) (-1 where none reaches)."""
    group = dp.regions[i].groups[g]
    best = np.zeros(flats.size, np.float32)
    yaw = np.full(flats.size, -1, dtype=np.int64)
    opts = dp.options(i, g)
    members = [opts[k] for k in dp.members(opts, group)]
    values, yaws = dp.ctx.problems.exact_values(members, flats)
    for v, k in zip(values, yaws):  # the first option of an equal value keeps the cell, as before
        better = v > best
        best[better] = v[better]
        yaw[better] = k[better]
    return yaw


def _leg_seconds(
    travel_m: FloatArray, yaw_a: float, yaw_b: FloatArray, arm_s: float, v: float, omega: float
) -> FloatArray:
    """The step time [s] of legs of ``travel_m`` [m] between yaws ``yaw_a`` and ``yaw_b`` [rad] (either
    order: the turn is the same) with the arm's ``arm_s`` [s]: max(travel / v, turn / omega, arm)."""
    out: FloatArray = np.maximum(np.maximum(travel_m / v, _turn(np.full(1, yaw_a), yaw_b) / omega), arm_s)
    return out


def time_cells(
    dp: DynamicProgram,
    chain: Chain,
    picks: Sequence[Verified],
    steps: Sequence[StepResult],
    settled: dict[int, tuple[object, ...]] | None = None,
) -> tuple[Chain, list[Verified]] | None:
    """The chain with steps moved to nearby cells where that shortens the task (see the module
    docstring), and their placements; None when no step moved. ``settled`` (kept by the caller
    across rounds): per step, what it read (its neighbours' cells, groups, placements, legs and arm
    times) when it last found no shorter cell; a step that reads the same again is not searched again
    (it would find the same: every input of its search is in that key)."""
    ctx = dp.ctx
    robot = ctx.robot
    nav = ctx.world.nav
    nx = nav.shape[1]
    n = len(picks)
    arm_s = _arm_seconds(dp, steps)
    cells, groups, labels, chosen = list(chain.cells), list(chain.groups), list(chain.labels), list(picks)
    r = int(round(CELL_WINDOW_M / nav.resolution))
    moved = False
    for i in range(n):
        if ctx.out_of_budget():
            break
        g = groups[i]
        prev_yaw = float(ctx.scene.start[2]) if i == 0 else chosen[i - 1].base[2]
        prev_label = 0.0 if i == 0 else labels[i - 1]
        last = i + 1 == n
        around = range(max(i - 1, 0), min(i + 2, n))
        key = (
            tuple((cells[j], groups[j], chosen[j].option, chosen[j].base) for j in around),
            tuple(labels[j] - (0.0 if j == 0 else labels[j - 1]) for j in around),
            tuple(arm_s[j] for j in around),
        )
        if settled is not None and settled.get(i) == key:
            continue
        # legs whose travel outlasts the turn and the arm: the chain's cell already has the least
        # travel between its neighbours (the program's optimum), so no cell can shorten them
        here = chosen[i].base[2]
        into_s = (labels[i] - prev_label - node_cost(dp, i, g, cells[i])) / robot.v_max
        slack = max(_turn(np.full(1, prev_yaw), np.full(1, here))[0] / robot.omega_max, arm_s[i]) > into_s
        if not last:
            out_s = (labels[i + 1] - labels[i] - node_cost(dp, i + 1, groups[i + 1], cells[i + 1])) / robot.v_max
            turn_out = _turn(np.full(1, here), np.full(1, chosen[i + 1].base[2]))[0] / robot.omega_max
            slack = slack or max(turn_out, arm_s[i + 1]) > out_s
        if not slack:
            if settled is not None:
                settled[i] = key
            continue
        iy0, ix0 = divmod(cells[i], nx)
        reg = dp.regions[i]
        ys, xs = np.divmod(reg.cells[reg.masks[g]], nx)
        near = (np.abs(ys - iy0) <= r) & (np.abs(xs - ix0) <= r)
        flats = np.union1d(reg.cells[reg.masks[g]][near], [cells[i]]).astype(np.int64)  # ascending
        prev_cell = dp.start if i == 0 else divmod(cells[i - 1], nx)
        into = ctx.problems.legs(prev_cell, flats)
        out_of = None if last else ctx.problems.legs(divmod(cells[i + 1], nx), flats, reverse=True)

        def cost(
            at: np.ndarray,
            yaw: FloatArray,
            i: int = i,
            into: FloatArray = into,
            out_of: FloatArray | None = out_of,
            prev: float = prev_yaw,
        ) -> FloatArray:
            """The step time [s] into and out of step i at ``flats[at]`` with base yaws ``yaw`` [rad]."""
            t = _leg_seconds(into[at], prev, yaw, arm_s[i], robot.v_max, robot.omega_max)
            if out_of is not None:
                nxt = chosen[i + 1].base[2]
                t = t + _leg_seconds(out_of[at], nxt, yaw, arm_s[i + 1], robot.v_max, robot.omega_max)
            return t

        here_at = int(np.searchsorted(flats, cells[i]))
        current = float(cost(np.array([here_at]), np.array([chosen[i].base[2]]))[0])
        # the cost with no turn bounds it at every yaw: a cell whose legs alone take the current time
        # is never tried (the tries below stop there), and needs no map value
        floor = np.maximum(into / robot.v_max, arm_s[i])
        if out_of is not None:
            floor = floor + np.maximum(out_of / robot.v_max, arm_s[i + 1])
        near = np.flatnonzero(np.isfinite(floor) & (floor < current - 1e-6))
        yaw = _group_best(dp, i, g, flats[near])
        ok = near[yaw >= 0]
        predicted = cost(ok, ctx.yaws[yaw[yaw >= 0]])
        for k in np.argsort(predicted, kind="stable")[:CELL_TRIES]:
            if predicted[k] >= current - 1e-6:
                break
            at = int(ok[k])
            flat = int(flats[at])
            if flat == cells[i]:
                continue
            found = dp.verify(i, flat, g)
            if found is None or float(cost(np.array([at]), np.array([found.base[2]]))[0]) >= current - 1e-6:
                continue
            labels[i] = prev_label + float(into[at]) + node_cost(dp, i, g, flat)
            if out_of is not None:
                new_next = labels[i] + float(out_of[at]) + node_cost(dp, i + 1, groups[i + 1], cells[i + 1])
                shift = new_next - labels[i + 1]
                labels[i + 1 :] = [label + shift for label in labels[i + 1 :]]
            cells[i], chosen[i], moved = flat, found, True
            break
        if settled is not None and chosen[i] is picks[i] and cells[i] == chain.cells[i]:
            settled[i] = key  # no shorter cell: the same search finds none again
    return (Chain(cells, groups, labels), chosen) if moved else None


def time_yaws(
    dp: DynamicProgram, chain: Chain, picks: Sequence[Verified], steps: Sequence[StepResult]
) -> list[Verified] | None:
    """The chain's placements with yaws chosen for the task time (see the module docstring), or None
    when no yaw changed or the time budget is spent."""
    ctx = dp.ctx
    robot = ctx.robot
    arm_s = _arm_seconds(dp, steps)
    travel_s = [float(s.travel_time_s) if s.ok else 0.0 for s in steps]
    nav = ctx.world.nav
    xs, ys = nav.centres()
    yaws: list[FloatArray] = []
    values: list[FloatArray] = []
    for i, v in enumerate(picks):
        o = dp.options(i, chain.groups[i])[v.option]
        iy, ix = divmod(chain.cells[i], nav.shape[1])
        value, fits = cell_yaws(ctx, o, float(xs[ix]), float(ys[iy]), chain.cells[i])
        thr = YAW_THRESHOLD_SHARE * ctx.for_step(i).option_threshold(o)
        keep = fits & (value >= thr) & (value > 0) & (_turn(ctx.yaws, np.full(1, v.base[2])) > 1e-9)
        yaws.append(np.concatenate([[v.base[2]], ctx.yaws[keep]]))  # the kept yaw is candidate 0
        values.append(np.concatenate([[v.value], value[keep].astype(float)]))
    pinned: set[int] = set()
    tried: dict[tuple[int, int], Verified | None] = {}
    chosen = list(picks)
    for _ in range(len(picks) + 1):
        cands = [y[:1] if i in pinned else y for i, y in enumerate(yaws)]
        choice = best_yaws(float(ctx.scene.start[2]), travel_s, arm_s, cands, robot.omega_max)
        chosen, failed = [], False
        for i, (v, j) in enumerate(zip(picks, choice)):
            if j == 0:
                chosen.append(v)
                continue
            if ctx.out_of_budget():
                return None
            if (i, j) not in tried:
                base = (v.base[0], v.base[1], float(yaws[i][j]))
                tried[i, j] = dp.check_at(i, chain.groups[i], v.option, base, float(values[i][j]))
            found = tried[i, j]
            if found is None:
                pinned.add(i)
                failed = True
                chosen.append(v)
            else:
                chosen.append(found)
        if not failed:
            break
    return None if all(c is p for c, p in zip(chosen, picks)) else chosen
