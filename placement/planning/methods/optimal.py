"""The ``optimal`` yardstick: the whole task at once by dynamic programming.

Each step keeps a candidate set: the base cells on a lattice (every ``optimal_lattice`` cells) whose
3 x 3 neighbourhood keeps the map threshold, with their best option and yaw, per (arm, grasp)
group the lowest manipulation costs (``optimal_candidates`` per step shared by the groups, at least
``optimal_min_per_group`` each); a place may follow only its pick's group (same arm, same grasp).
Exact navigation costs link consecutive candidate sets (one Dijkstra per candidate, stopped once
the next step's candidates are settled), and the DP minimises the task's summed Eq. 6 cost without
heuristic, ``sum_i lambda_n nav(r_{i-1}, r_i) + lambda_m / m(r_i)``, which the one-step heuristic
approximates. Chosen placements are IK-checked; one that fails (or collides, when the context has a
collision check) is removed and the DP rerun (at most ``optimal_max_repairs`` times).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from placement.planning.arrays import BoolArray, Cell, FloatArray, IntArray
from placement.planning.context import PlanningContext
from placement.planning.explain import explain
from placement.planning.methods.base import Method
from placement.planning.methods.outcomes import infeasible, placed, unreachable_reason
from placement.planning.navigation import extract_path, navigation_cost
from placement.planning.option import Option
from placement.planning.results import StepMaps, StepResult
from placement.planning.search import collision_args
from placement.planning.verify import trajectory_ik


@dataclass(frozen=True)
class Candidates:
    """One step's DP candidates, all (k,): flat cells, option indices, base yaws [rad], map values
    (dimensionless) and (arm, grasp) groups."""

    cells: IntArray
    option: IntArray
    yaw: FloatArray
    value: FloatArray
    group: list[str]


def dp_candidates(ctx: PlanningContext, i: int) -> Candidates:
    """Step i's candidates: per (arm, grasp) group (a pick and its place keep both), the lattice
    cells with the best values."""
    cfg = ctx.config
    nav = ctx.world.nav
    opts = ctx.problems.options(i)
    groups = sorted({option_group(o) for o in opts})
    lattice = np.zeros(nav.shape, bool)
    lattice[:: cfg.optimal_lattice, :: cfg.optimal_lattice] = True
    per_group = max(cfg.optimal_min_per_group, cfg.optimal_candidates // max(len(groups), 1))
    cells: list[IntArray] = []
    option: list[IntArray] = []
    yaws: list[float] = []
    values: list[FloatArray] = []
    group: list[str] = []
    for g in groups:
        best_val = np.zeros(nav.shape, np.float32)
        best_opt = np.full(nav.shape, -1, np.int64)
        for k, o in enumerate(opts):
            if option_group(o) != g:
                continue
            inner = ndimage.minimum_filter(o.value, size=3, mode="constant", cval=0.0) >= cfg.threshold
            v = np.where(inner, o.value, 0.0)
            bv, bo = best_val[o.window.slices], best_opt[o.window.slices]
            better = v > bv
            bv[better] = v[better]
            bo[better] = k
        flat = np.flatnonzero(lattice & (best_opt >= 0))
        if flat.size == 0:  # tiny feasible set: fall back to every inner cell
            flat = np.flatnonzero(best_opt >= 0)
        flat = flat[np.argsort(-best_val.flat[flat], kind="stable")[:per_group]]
        cells.append(flat.astype(np.int64))
        option.append(best_opt.flat[flat].astype(np.int64))
        yaws += [float(ctx.yaws[opts[best_opt.flat[f]].yaw_at(*divmod(int(f), nav.shape[1]))]) for f in flat]
        values.append(best_val.flat[flat].astype(float))
        group += [g] * flat.size
    return Candidates(
        np.concatenate(cells) if cells else np.zeros(0, np.int64),
        np.concatenate(option) if option else np.zeros(0, np.int64),
        np.array(yaws, dtype=float),
        np.concatenate(values) if values else np.zeros(0),
        group,
    )


def option_group(o: Option) -> str:
    """The (arm, grasp) an option commits a transfer to, as one string."""
    return f"{o.arm}\n{o.candidate.grasp}"


def cheapest_chain(
    ctx: PlanningContext, start_cell: Cell, cands: list[Candidates], live: list[IntArray]
) -> list[int] | None:
    """Indices into each step's candidates of the cheapest chain from ``start_cell`` (None when no
    chain keeps every transfer's arm and grasp)."""
    cfg, world = ctx.config, ctx.world
    shape = world.nav.shape
    steps = ctx.problems.steps

    def targets(i: int) -> BoolArray:
        m = np.zeros(shape, bool)
        m.flat[cands[i].cells[live[i]]] = True
        return m

    nav0, _ = navigation_cost(world.factor, world.feasible, start_cell, world.nav.resolution, targets=targets(0))
    cost = cfg.lambda_n * nav0.flat[cands[0].cells[live[0]]] + cfg.lambda_m / cands[0].value[live[0]]
    back = []
    for i in range(1, len(cands)):
        tgt = targets(i)
        nxt_cells = cands[i].cells[live[i]]
        trans = np.empty((live[i - 1].size, live[i].size))
        for a, j in enumerate(live[i - 1]):
            src = divmod(int(cands[i - 1].cells[j]), shape[1])
            c, _ = navigation_cost(world.factor, world.feasible, src, world.nav.resolution, targets=tgt)
            trans[a] = c.flat[nxt_cells]
        if steps[i].pick == i - 1:  # a place: the arm and grasp of its pick
            before = np.array(cands[i - 1].group, dtype=str)[live[i - 1]]
            after = np.array(cands[i].group, dtype=str)[live[i]]
            trans[~(before[:, None] == after[None, :])] = np.inf
        total = cost[:, None] + cfg.lambda_n * trans
        arg = np.argmin(total, axis=0)
        back.append(arg)
        cost = total[arg, np.arange(live[i].size)] + cfg.lambda_m / cands[i].value[live[i]]
    if not np.isfinite(cost).any():
        return None
    choice = [int(np.argmin(cost))]
    for arg in reversed(back):
        choice.append(int(arg[choice[-1]]))
    choice.reverse()
    return [int(live[i][c]) for i, c in enumerate(choice)]


def plan_optimal(ctx: PlanningContext, start_cell: Cell, keep_maps: bool = False) -> list[StepResult]:
    """The DP plan's steps; on failure a single infeasible step naming the step that failed."""
    world, cfg = ctx.world, ctx.config
    nav = world.nav
    steps = ctx.problems.steps
    t0 = time.perf_counter()
    cands = [dp_candidates(ctx, i) for i in range(len(steps))]
    removed: list[set[int]] = [set() for _ in steps]
    ik_failures = [0] * len(steps)
    for _ in range(cfg.optimal_max_repairs):
        live = [
            np.array([j for j in range(len(c.cells)) if j not in removed[i]], dtype=np.int64)
            for i, c in enumerate(cands)
        ]
        for i, lv in enumerate(live):
            if lv.size == 0:
                if ik_failures[i]:
                    return [infeasible(steps[i], f"IK failed for all {ik_failures[i]} of its DP candidates")]
                opts = ctx.problems.options(i)
                reason, diagnosis = explain(ctx, False, steps[i], opts, None, unreachable_reason(ctx, opts))
                return [infeasible(steps[i], reason, diagnosis)]
        chosen = cheapest_chain(ctx, start_cell, cands, live)
        if chosen is None:
            return [
                infeasible(
                    steps[0], "no chain of DP candidates keeps each object's arm and grasp from its pick to its place"
                )
            ]
        out: list[StepResult] = []
        prev_cell, failed = start_cell, None
        q_state = {arm: ctx.robot.arm(arm).home.copy() for arm in ctx.maps}
        xs, ys = nav.centres()
        for i, j in enumerate(chosen):
            c = cands[i]
            o = ctx.problems.options(i)[int(c.option[j])]
            iy, ix = divmod(int(c.cells[j]), nav.shape[1])
            base = (float(xs[ix]), float(ys[iy]), float(c.yaw[j]))
            witness = getattr(ctx.maps[o.arm], "witness_q", None)
            ik = trajectory_ik(ctx.robot, o.arm, o.candidate.poses, base, q_state[o.arm], witness, cfg)
            clearance = free = None
            if ik.ok and ctx.collisions is not None:
                check = ctx.collisions.check(o.arm, ik.qs, base, **collision_args(ctx, steps[i], o))
                clearance, free = float(check.clearance_m), bool(check.free)
            if not ik.ok or free is False:
                failed = (i, j)
                break
            full = None if keep_maps else np.zeros(nav.shape, bool)
            if full is not None:
                full[iy, ix] = True
            navc, pred = navigation_cost(world.factor, world.feasible, prev_cell, nav.resolution, targets=full)
            value = float(c.value[j])
            step = placed(ctx, steps[i], o, base, ik.qs, float(navc[iy, ix]), 0.0, value, {}, clearance)
            if keep_maps:
                manip = np.max([p.full_value(nav.shape) for p in ctx.problems.options(i)], axis=0)
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
        infeasible(
            steps[worst],
            f"IK kept failing on the DP's choices ({ik_failures[worst]} failures "
            f"at this step in {cfg.optimal_max_repairs} repairs)",
        )
    ]


class Optimal(Method):
    """The yardstick: every step's placement at once, by dynamic programming over candidate sets."""

    name = "optimal"

    def plan(self, ctx: PlanningContext, start: Cell, keep_maps: bool) -> list[StepResult]:
        return plan_optimal(ctx, start, keep_maps)


__all__ = ["Candidates", "Optimal", "cheapest_chain", "option_group", "dp_candidates", "plan_optimal"]
