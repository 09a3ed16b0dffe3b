"""The IK search over a step's ranked placements: best-first, then spread, under a time budget.

Phase 1 tries the ranked placements in order (up to ``ik_tries`` distinct ones, skipping the cells
next to a failure of the same option), exactly as the planner always did: when the best placements
verify, the result is the first verified one in rank order. When none of those verifies, phase 2
does not give up: it takes every ranked placement (``more``), groups them by option, region around
the target (bearing sector and distance band), and base yaw sector, and tries them round-robin over
the groups, best first within each, so the tries spread over options, regions, yaws and distances.
It learns from failures: a placement next to a failed one of the same option and a similar yaw is
deferred to the end, and one whose target lies in the same direction but farther than a failure whose
TCP fell short along its reach is dropped (reaching farther cannot help). It stops at the first
verified placement, when the ``ik_budget_ms`` time budget (of the IK solves and collision checks), the
task's ``time_budget_s`` or the ``ik_cap`` tries are used up, or when every candidate was tried. The constants (``search_*``, ``ik_*``) come from the
:class:`~placement.planning.settings.PlannerConfig` of the context.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from placement.planning.arrays import BasePose, Cell, FloatArray
from placement.planning.context import PlanningContext
from placement.planning.facing import facing_yaw
from placement.planning.methods.ranking import Ranked, combined_cost
from placement.planning.problems import Option, Step, yaw_values
from placement.planning.settings import PlannerConfig
from placement.planning.torso import option_collisions, option_map, option_robot
from placement.planning.verification import TrajectoryIK, base_matrix, trajectory_ik
from placement.robots import Robot


@dataclass
class Failure:
    """A placement that did not verify: ``kind`` "ik" or "collision"; for IK the failed pose's
    index and residual (position [m], rotation [rad]); for a collision the culprit pair."""

    option: int
    cell: Cell
    yaw: float
    kind: str
    pose: int | None = None
    residual_m: float = math.inf
    residual_rad: float = math.inf
    culprit: str | None = None


@dataclass
class Found:
    """The verified placement: its ranked entry, base (x [m], y [m], yaw [rad]), IK and clearance [m]."""

    ranked: Ranked
    base: BasePose
    ik: TrajectoryIK
    clearance_m: float | None
    value: float | None = None  # its map value when it is not the cell's best yaw


@dataclass
class Search:
    """What the search did: the placement found (or None), the failures, and why it stopped
    ("found", "all" candidates tried, the "budget" of IK time spent, the "task"'s time budget spent,
    "cap" of tries reached)."""

    found: Found | None = None
    failures: list[Failure] = field(default_factory=list)
    stop: str = "all"
    ik_ms: float = 0.0  # time in IK solves [ms]
    collision_ms: float = 0.0  # time in collision checks [ms]

    @property
    def tried(self) -> int:
        return len(self.failures) + (self.found is not None)

    def culprits(self) -> Counter[str]:
        return Counter(f.culprit for f in self.failures if f.kind == "collision" and f.culprit)


def wrap_angle(a: float) -> float:
    """``a`` [rad] wrapped into [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


class Learner:
    """The failures' lessons: neighbours to defer, directions to drop (``yaw_step`` [rad] between
    base yaws)."""

    def __init__(self, yaw_step: float, robot: Robot, config: PlannerConfig):
        self.yaw_step, self.robot, self.config = yaw_step, robot, config
        self.failed: list[tuple[int, int, int, float]] = []  # option, iy, ix, yaw
        self.short: list[tuple[int, int, float, float, float]] = []  # option, pose, yaw, bearing, distance

    def add(self, f: Failure, o: Option, base: BasePose, ik: TrajectoryIK | None) -> None:
        self.failed.append((f.option, *f.cell, f.yaw))
        if ik is None or f.pose is None or ik.best_q is None or f.residual_m < self.config.search_shortfall_m:
            return
        target = o.candidate.poses[f.pose, :3, 3]
        h = target[:2] - np.asarray(base[:2])
        # the TCP of the best attempt, by pinocchio (only for failures that can teach)
        reached = (base_matrix(*base) @ self.robot.tcp_pose(o.arm, ik.best_q))[:3, 3]
        e = target - reached
        d = float(np.hypot(*h))
        # the TCP fell short along the horizontal reach direction: farther is hopeless
        if d > 0 and float(e[:2] @ h) / d >= self.config.search_shortfall_cos * float(np.linalg.norm(e)):
            self.short.append((f.option, f.pose, base[2], math.atan2(h[1], h[0]) - base[2], d))

    def near_failure(self, k: int, iy: int, ix: int, yaw: float, any_yaw: bool) -> bool:
        return any(
            fk == k
            and abs(fy - iy) <= 1
            and abs(fx - ix) <= 1
            and (any_yaw or abs(wrap_angle(yaw - fyaw)) <= 2 * self.yaw_step + 1e-9)
            for fk, fy, fx, fyaw in self.failed
        )

    def hopeless(self, k: int, o: Option, base: BasePose) -> bool:
        same = self.config.search_same_direction_rad
        for fk, pose, fyaw, bearing, d in self.short:
            if fk != k or abs(wrap_angle(base[2] - fyaw)) > same:
                continue
            h = o.candidate.poses[pose, :2, 3] - np.asarray(base[:2])
            if np.hypot(*h) >= d and abs(wrap_angle(math.atan2(h[1], h[0]) - base[2] - bearing)) <= same:
                return True
        return False


def other_yaws(
    ctx: PlanningContext, opts: Sequence[Option], nav_cost: FloatArray, heuristic: FloatArray
) -> tuple[list[Ranked], dict[tuple[int, int, float], float]]:
    """Every (cell, base yaw) of every option that keeps its arm's map threshold other than each cell's
    best yaw, ranked by Eq. 6 with its own map value; and {(option, cell, yaw): value}."""
    cfg, nav = ctx.config, ctx.world.nav
    nx = nav.shape[1]
    xs, ys = nav.centres()
    out: list[Ranked] = []
    values: dict[tuple[int, int, float], float] = {}
    for k, o in enumerate(opts):
        thr = np.float32(ctx.option_threshold(o))
        local = np.flatnonzero(o.value.ravel() >= thr)
        cells = o.window.to_global(local, nx)
        iy, ix = np.divmod(cells, nx)
        ok = np.isfinite(nav_cost[iy, ix]) & np.isfinite(heuristic[iy, ix])
        cells, iy, ix, best = cells[ok], iy[ok], ix[ok], o.yaw_index.ravel()[local][ok]
        if cells.size == 0:
            continue
        v = yaw_values(option_map(ctx, o), o.candidate.poses, xs[ix], ys[iy], ctx.yaws)
        v[np.arange(cells.size), best] = 0.0
        n, j = np.nonzero(v >= thr)
        cost = combined_cost(cfg, nav_cost[iy[n], ix[n]], v[n, j].astype(float), heuristic[iy[n], ix[n]])
        for c, cell, yaw, val in zip(cost, cells[n], ctx.yaws[j], v[n, j]):
            out.append(Ranked(float(c), k, int(cell), float(yaw)))
            values[(k, int(cell), float(yaw))] = float(val)
    out.sort(key=lambda r: (r.cost, r.option, r.cell, r.yaw))
    return out, values


def search_placement(
    ctx: PlanningContext,
    step: Step,
    opts: Sequence[Option],
    ranked: Sequence[Ranked],
    more: Callable[[], list[Ranked]] | None,
    nav_cost: FloatArray,
    heuristic: FloatArray,
    prev_q: Mapping[str, FloatArray],
) -> Search:
    """Try ``ranked`` placements of ``step`` (then ``more()``, every ranked placement, and when
    ``more`` is given every other base yaw that keeps the threshold) until one verifies by IK
    (and the collision check, when the context has one); see the module docstring."""
    cfg, nav = ctx.config, ctx.world.nav
    xs, ys = nav.centres()
    collisions = ctx.collisions
    out = Search()
    learn = Learner(2 * math.pi / max(len(ctx.yaws), 1), ctx.robot, cfg)
    tried: set[tuple[int, int, float]] = set()

    def over() -> bool:
        # the budget is the verification's (IK and collision checks): ranking every placement for the
        # spread phase takes as long as the maps are large, and counted against it, a slower machine or
        # a cold process stopped a step that verifies at its next try (a building's first pick)
        return out.ik_ms + out.collision_ms > cfg.ik_budget_ms

    def attempt(r: Ranked, o: Option, iy: int, ix: int) -> bool:
        tried.add((r.option, r.cell, r.yaw))
        x, y = float(xs[ix]), float(ys[iy])
        face = facing_yaw(ctx, o, x, y, r.cell, r.yaw)
        if face is not None and verify_at(r, o, iy, ix, *face):
            return True
        return verify_at(r, o, iy, ix, r.yaw, None)

    def verify_at(r: Ranked, o: Option, iy: int, ix: int, yaw: float, value: float | None) -> bool:
        """IK and the collision check of ranked placement ``r`` at base yaw ``yaw`` [rad] (``value``: its
        map value when it is not the ranked yaw)."""
        base = (float(xs[ix]), float(ys[iy]), yaw)
        witness = getattr(option_map(ctx, o), "witness_q", None)
        t = time.perf_counter()
        ik = trajectory_ik(option_robot(ctx, o), o.arm, o.candidate.poses, base, prev_q[o.arm], witness, cfg)
        out.ik_ms += (time.perf_counter() - t) * 1e3
        if not ik.ok:
            f = Failure(r.option, (iy, ix), yaw, "ik", ik.failed_pose, ik.residual_m, ik.residual_rad)
            out.failures.append(f)
            learn.add(f, o, base, ik)
            return False
        clearance = None
        if collisions is not None:
            t = time.perf_counter()
            checker = option_collisions(ctx, o)
            assert checker is not None
            check = checker.check(o.arm, ik.qs, base, **ctx.collision_args(step, o))
            out.collision_ms += (time.perf_counter() - t) * 1e3
            clearance = float(check.clearance_m)
            if not check.free:
                f = Failure(r.option, (iy, ix), yaw, "collision", culprit=check.culprit)
                out.failures.append(f)
                learn.add(f, o, base, None)
                return False
        out.found = Found(r, base, ik, clearance, value)
        out.stop = "found"
        return True

    def spent() -> bool:
        if out.tried >= cfg.ik_cap:
            out.stop = "cap"
        elif over():
            out.stop = "budget"
        elif ctx.out_of_budget():
            out.stop = "task"
        else:
            return False
        return True

    def task_over() -> bool:
        """Whether the task's budget has run out (the search then stops, saying so)."""
        if ctx.out_of_budget():
            out.stop = "task"
            return True
        return False

    def usable(r: Ranked) -> Cell | None:
        iy, ix = divmod(r.cell, nav.shape[1])
        # a fixed placement the base cannot get to from here, or one tried already
        return None if (not np.isfinite(nav_cost[iy, ix]) or (r.option, r.cell, r.yaw) in tried) else (iy, ix)

    def spread(candidates: Sequence[Ranked]) -> bool:
        """Round-robin over the groups of ``candidates`` (see the module docstring); True when
        the search is over (found, or out of time or tries)."""
        groups: dict[tuple[int, int, int, int], list[tuple[Ranked, Cell]]] = {}
        for n, r in enumerate(candidates):
            # hundreds of thousands with a hundred grasps per object: sorting them may outlast the task
            if n % 4096 == 4095 and task_over():
                return True
            cell = usable(r)
            if cell is not None:
                groups.setdefault(round_robin_group(cfg, opts[r.option], r, cell, xs, ys), []).append((r, cell))
        queues = list(groups.values())  # each in rank order; groups by their best placement's rank
        deferred = []
        while queues:
            for q in queues:
                r, cell = q.pop(0)
                o = opts[r.option]
                if learn.hopeless(r.option, o, (float(xs[cell[1]]), float(ys[cell[0]]), r.yaw)):
                    continue
                if learn.near_failure(r.option, *cell, r.yaw, any_yaw=False):
                    deferred.append((r, cell))
                    continue
                if spent() or attempt(r, o, *cell):
                    return True
            queues = [q for q in queues if q]
        for r, cell in sorted(deferred, key=lambda rc: (rc[0].cost, rc[0].option, rc[0].cell)):
            o = opts[r.option]
            base = (float(xs[cell[1]]), float(ys[cell[0]]), r.yaw)
            if not learn.hopeless(r.option, o, base) and (spent() or attempt(r, o, *cell)):
                return True
        return False

    for r in ranked:  # phase 1: best first
        if out.tried >= cfg.ik_tries or spent():
            break
        cell = usable(r)
        # the next cell of the same candidate almost always fails the same way
        if cell is None or learn.near_failure(r.option, *cell, r.yaw, any_yaw=True):
            continue
        if attempt(r, opts[r.option], *cell):
            return out
    if out.stop in ("budget", "cap", "task"):
        return out
    out.stop = "all"
    if task_over() or spread(more() if more is not None else ranked) or more is None or task_over():
        return out
    extra, values = other_yaws(ctx, opts, nav_cost, heuristic)
    if not spread(extra) and out.stop == "all" and over():
        out.stop = "budget"
    if out.found is not None and out.found.value is None:
        r = out.found.ranked
        out.found.value = values[(r.option, r.cell, r.yaw)]
    return out


def round_robin_group(
    cfg: PlannerConfig, o: Option, r: Ranked, cell: Cell, xs: FloatArray, ys: FloatArray
) -> tuple[int, int, int, int]:
    """Round-robin group of a placement: option, bearing sector and distance band around the target,
    base yaw sector (``search_sectors`` per turn, bands ``search_band_m`` wide)."""
    sectors = cfg.search_sectors
    t = o.candidate.poses[-1, :3, 3]
    dx, dy = float(xs[cell[1]] - t[0]), float(ys[cell[0]] - t[1])
    sector = int((math.atan2(dy, dx) + math.pi) / (2 * math.pi) * sectors) % sectors
    yaw_sector = int((r.yaw + math.pi) / (2 * math.pi) * sectors) % sectors
    return r.option, sector, int(math.hypot(dx, dy) / cfg.search_band_m), yaw_sector
