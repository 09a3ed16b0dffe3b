"""The ``optimal`` yardstick: the whole task at once by dynamic programming.

Each step keeps a candidate set: the base cells on a 3-cell lattice whose 3 x 3
neighbourhood keeps the map threshold, with their best option and yaw, per (arm, grasp)
group the lowest manipulation costs (``CANDIDATES`` per step shared by the groups, at least
``MIN_PER_GROUP`` each); a place may follow only its pick's group (same arm, same grasp). Exact navigation costs link
consecutive candidate sets (one Dijkstra per candidate, stopped once the next
step's candidates are settled), and the DP minimises the task's summed Eq. 6
cost without heuristic, ``sum_i lambda_n nav(r_{i-1}, r_i) + lambda_m / m(r_i)``,
which the one-step heuristic approximates. Chosen placements are IK-checked;
one that fails (or collides, when the planner has a collision check) is removed and the DP rerun.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage

from placement.planning.explain import explain
from placement.planning.methods.stepwise import placed, unreachable_reason
from placement.planning.navigation import extract_path, navigation_cost
from placement.planning.results import StepMaps, StepResult
from placement.planning.search import collision_args
from placement.planning.verify import trajectory_ik

if TYPE_CHECKING:
    from placement.planning.planner import Planner

CANDIDATES = 40
MIN_PER_GROUP = 8
LATTICE = 3
MAX_REPAIRS = 30


def _candidates(planner: Planner, i: int):
    """(flat cells (k,), option index (k,), yaw (k,), value (k,), group (k,)) of step i: per (arm,
    grasp) group (a pick and its place keep both), the lattice cells with the best values."""
    threshold = planner.config.threshold
    nav = planner.world.nav
    opts = planner.problems.options(i)
    groups = sorted({_group(o) for o in opts})
    lattice = np.zeros(nav.shape, bool)
    lattice[::LATTICE, ::LATTICE] = True
    per_group = max(MIN_PER_GROUP, CANDIDATES // max(len(groups), 1))
    out = [[], [], [], [], []]
    for gi, group in enumerate(groups):
        best_val = np.zeros(nav.shape, np.float32)
        best_opt = np.full(nav.shape, -1, np.int64)
        for k, o in enumerate(opts):
            if _group(o) != group:
                continue
            inner = ndimage.minimum_filter(o.value, size=3, mode="constant", cval=0.0) >= threshold
            v = np.where(inner, o.value, 0.0)
            bv, bo = best_val[o.window.slices], best_opt[o.window.slices]
            better = v > bv
            bv[better] = v[better]
            bo[better] = k
        flat = np.flatnonzero(lattice & (best_opt >= 0))
        if flat.size == 0:  # tiny feasible set: fall back to every inner cell
            flat = np.flatnonzero(best_opt >= 0)
        flat = flat[np.argsort(-best_val.flat[flat], kind="stable")[:per_group]]
        yaws = [planner.yaws[opts[best_opt.flat[f]].yaw_at(*divmod(int(f), nav.shape[1]))] for f in flat]
        for part, values in zip(
            out, (flat, best_opt.flat[flat], yaws, best_val.flat[flat].astype(float), np.full(flat.size, gi))
        ):
            part.append(np.asarray(values))
    flat, opt, yaw, value, group = (np.concatenate(p) if p else np.zeros(0) for p in out)
    return (
        flat.astype(np.int64),
        opt.astype(np.int64),
        yaw.astype(float),
        value.astype(float),
        np.array([groups[int(g)] for g in group], dtype=str) if group.size else np.zeros(0, dtype=str),
    )


def _group(o) -> str:
    """The (arm, grasp) an option commits a transfer to, as one string."""
    return f"{o.arm}\n{o.candidate.grasp}"


def _dp(planner: Planner, start_cell, cands, live) -> list[int] | None:
    """Indices into each step's candidates of the cheapest chain from ``start_cell`` (None when no
    chain keeps every transfer's arm and grasp)."""
    cfg, world = planner.config, planner.world
    shape = world.nav.shape
    steps = planner.problems.steps

    def targets(i):
        m = np.zeros(shape, bool)
        m.flat[cands[i][0][live[i]]] = True
        return m

    nav0, _ = navigation_cost(world.factor, world.feasible, start_cell, world.nav.resolution, targets=targets(0))
    cost = cfg.lambda_n * nav0.flat[cands[0][0][live[0]]] + cfg.lambda_m / cands[0][3][live[0]]
    back = []
    for i in range(1, len(cands)):
        tgt = targets(i)
        nxt_cells = cands[i][0][live[i]]
        trans = np.empty((live[i - 1].size, live[i].size))
        for a, j in enumerate(live[i - 1]):
            src = divmod(int(cands[i - 1][0][j]), shape[1])
            c, _ = navigation_cost(world.factor, world.feasible, src, world.nav.resolution, targets=tgt)
            trans[a] = c.flat[nxt_cells]
        if steps[i].pick == i - 1:  # a place: the arm and grasp of its pick
            same = cands[i - 1][4][live[i - 1]][:, None] == cands[i][4][live[i]][None, :]
            trans[~same] = np.inf
        total = cost[:, None] + cfg.lambda_n * trans
        arg = np.argmin(total, axis=0)
        back.append(arg)
        cost = total[arg, np.arange(live[i].size)] + cfg.lambda_m / cands[i][3][live[i]]
    if not np.isfinite(cost).any():
        return None
    choice = [int(np.argmin(cost))]
    for arg in reversed(back):
        choice.append(int(arg[choice[-1]]))
    choice.reverse()
    return [int(live[i][c]) for i, c in enumerate(choice)]


def plan_optimal(planner: Planner, start_cell, keep_maps: bool = False) -> list[StepResult]:
    """The DP plan's steps; on failure a single infeasible step naming the step that failed."""
    world = planner.world
    nav = world.nav
    steps = planner.problems.steps
    t0 = time.perf_counter()
    cands = [_candidates(planner, i) for i in range(len(steps))]
    removed: list[set] = [set() for _ in steps]
    ik_failures = [0] * len(steps)
    for _ in range(MAX_REPAIRS):
        live = [
            np.array([j for j in range(len(c[0])) if j not in removed[i]], dtype=np.int64) for i, c in enumerate(cands)
        ]
        for i, lv in enumerate(live):
            if lv.size == 0:
                if ik_failures[i]:
                    return [_infeasible(steps[i], f"IK failed for all {ik_failures[i]} of its DP candidates")]
                opts = planner.problems.options(i)
                return [
                    _infeasible(steps[i], *explain(planner, steps[i], opts, None, unreachable_reason(planner, opts)))
                ]
        chosen = _dp(planner, start_cell, cands, live)
        if chosen is None:
            return [
                _infeasible(
                    steps[0], "no chain of DP candidates keeps each object's arm and grasp from its pick to its place"
                )
            ]
        out, prev_cell, failed = [], start_cell, None
        q_state = {arm: planner.robot.arm(arm).home.copy() for arm in planner.maps}
        xs, ys = nav.centres()
        for i, j in enumerate(chosen):
            flat, k, yaw, value = (cands[i][0][j], cands[i][1][j], cands[i][2][j], cands[i][3][j])
            o = planner.problems.options(i)[k]
            iy, ix = divmod(int(flat), nav.shape[1])
            base = (float(xs[ix]), float(ys[iy]), float(yaw))
            ik = trajectory_ik(
                planner.robot,
                o.arm,
                o.candidate.poses,
                base,
                q_state[o.arm],
                getattr(planner.maps[o.arm], "witness_q", None),
            )
            clearance = free = None
            if ik.ok and getattr(planner, "collisions", None) is not None:
                check = planner.collisions.check(o.arm, ik.qs, base, **collision_args(planner, steps[i], o))
                clearance, free = float(check.clearance_m), bool(check.free)
            if not ik.ok or free is False:
                failed = (i, j)
                break
            full = None if keep_maps else np.zeros(nav.shape, bool)
            if full is not None:
                full[iy, ix] = True
            navc, pred = navigation_cost(world.factor, world.feasible, prev_cell, nav.resolution, targets=full)
            step = placed(planner, steps[i], o, base, ik.qs, float(navc[iy, ix]), 0.0, float(value), {}, clearance)
            if keep_maps:
                manip = np.max([p.full_value(nav.shape) for p in planner.problems.options(i)], axis=0)
                step.maps = StepMaps(navc, np.zeros(nav.shape), manip, None, extract_path(pred, (iy, ix)))
            out.append(step)
            prev_cell = (iy, ix)
            q_state[o.arm] = ik.q
        if failed is None:
            ms = (time.perf_counter() - t0) * 1e3
            for s in out:
                s.timings_ms = {"total": ms / len(out)}
            return out
        removed[failed[0]].add(failed[1])
        ik_failures[failed[0]] += 1
    worst = int(np.argmax(ik_failures))
    return [
        _infeasible(
            steps[worst],
            f"IK kept failing on the DP's choices ({ik_failures[worst]} failures "
            f"at this step in {MAX_REPAIRS} repairs)",
        )
    ]


def _infeasible(step, reason: str, diagnosis: dict | None = None) -> StepResult:
    return StepResult(step.index, step.action, step.target, status="infeasible", reason=reason, diagnosis=diagnosis)
