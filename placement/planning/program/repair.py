"""Local repair of a whole-task chain: how the default method ``global`` answers a rejected placement.

The dynamic program stands each step on the cell nearest (in travel) to its neighbours' cells, which
is, more often than not, at the frontier of the maps' reach, where IK rejects most cells (the maps
count a 6D cell as reached when any sample inside it reaches; the base stands at the cell's centre).
Solving the whole program again after each rejection costs one Dijkstra per step (and per group
of a transfer) each time. ``global`` keeps the chain's other cells instead and moves the rejected
step to the cell of its region that adds the least travel between its neighbours' cells,
``d(c[i-1], x) + d(x, c[i+1])``, verifying candidates in that order (at most
``global_repair_candidates``): two Dijkstras (one from ``c[i-1]``, one to ``c[i+1]`` on the reversed
grid) and a few IK calls instead of a solve. A transfer's pick and place keep their group. The legs
into and out of the new cell are exact. When no candidate verifies, the caller removes the
rejection and solves again.

The two searches are asked only for the region's cells whose detour cannot exceed the least one by
more than ``WINDOW_M`` (by a lower bound: octile distances times the least slowdown), a window that
grows while none of its cells verifies: the candidates come in the order a search of the whole
region gives, and the searches, directed at a smaller box of targets, settle fewer cells.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from placement.planning.arrays import Cell
from placement.planning.context import PlanningContext
from placement.planning.program.forward import Chain, Regions
from placement.planning.verification import TrajectoryIK

#: the detour [m] beyond the least bound that a repair searches first (doubled while nothing verifies)
WINDOW_M = 0.5


@dataclass(frozen=True)
class Verified:
    """A (step, cell, group) that verified: the option, base pose (x [m], y [m], yaw [rad]), IK,
    clearance [m] (None without a collision check) and map value."""

    option: int
    base: tuple[float, float, float]
    ik: TrajectoryIK
    clearance_m: float | None
    value: float


class RepairView(Protocol):
    """What a repair reads of a plan's program (:class:`~placement.planning.program.state.DynamicProgram`)."""

    ctx: PlanningContext
    start: Cell
    regions: list[Regions]
    linked: list[bool]

    def verify(self, i: int, flat: int, g: int) -> Verified | None: ...


def node_cost(dp: RepairView, i: int, g: int, flat: int) -> float:
    """Step i's node term [m] at cell ``flat`` in group g (0 without one)."""
    return dp.regions[i].node_at(g, flat)


def repair(dp: RepairView, chain: Chain, i: int) -> tuple[Chain, Verified] | None:
    """``chain`` with step i moved to the least detour between its neighbours that verifies, and that
    placement; None when none of the candidates does."""
    ctx, w = dp.ctx, dp.ctx.world
    nx = w.nav.shape[1]
    n = len(chain.cells)
    reg = dp.regions[i]
    g0 = chain.groups[i]
    fixed = dp.linked[i] or (i + 1 < n and dp.linked[i + 1])
    groups = [g0] if fixed else list(range(len(reg.groups)))
    targets = reg.mask(groups)
    if not targets.any():
        return None
    prev_cell = dp.start if i == 0 else divmod(chain.cells[i - 1], nx)
    prev_label = 0.0 if i == 0 else chain.labels[i - 1]
    next_cell = divmod(chain.cells[i + 1], nx) if i + 1 < n else None
    bound = _detour_bound(w.factor, w.feasible, w.nav.resolution, prev_cell, next_cell, targets)
    count = ctx.config.global_repair_candidates
    tried: set[tuple[int, int]] = set()
    reach = float(np.min(bound[targets])) + WINDOW_M
    while len(tried) < count:
        # only the region's cells whose detour bound is within ``reach`` are searched: a cell outside
        # detours more than ``reach`` [m], so those within rank exactly as they would among all
        window = targets & (bound <= reach)
        whole = bool(np.array_equal(window, targets))
        into = ctx.problems.legs(prev_cell, window)
        score = into.copy()
        if next_cell is not None:  # from every candidate to the next step's cell: the legs out, exact
            out_of = ctx.problems.legs(next_cell, window, reverse=True)
            score += out_of
        if not whole:
            score[score > reach] = np.inf
        for flat, g in _best(score, reg, groups, count):
            if (flat, g) in tried:
                continue
            tried.add((flat, g))
            v = dp.verify(i, flat, g)
            if v is None:
                if len(tried) >= count:
                    break
                continue
            labels = list(chain.labels)
            labels[i] = prev_label + float(into.flat[flat]) + node_cost(dp, i, g, flat)
            if i + 1 < n:
                nxt = chain.cells[i + 1]
                new_next = labels[i] + float(out_of.flat[flat]) + node_cost(dp, i + 1, chain.groups[i + 1], nxt)
                shift = new_next - chain.labels[i + 1]
                labels[i + 1 :] = [label + shift for label in chain.labels[i + 1 :]]
            cells, grps = list(chain.cells), list(chain.groups)
            cells[i], grps[i] = flat, g
            return Chain(cells, grps, labels), v
        if whole:
            break
        reach += 2.0 * (reach - float(np.min(bound[targets])))
    return None


def _detour_bound(
    factor: np.ndarray,
    feasible: np.ndarray,
    res: float,
    prev: tuple[int, int],
    nxt: tuple[int, int] | None,
    cells: np.ndarray,
) -> np.ndarray:
    """(ny, nx) a lower bound [m] on ``d(prev, x) + d(x, nxt)`` for every cell x of ``cells`` (ny, nx)
    bool, inf elsewhere: the octile distances (the shortest 8-connected paths with no obstacle) times
    the least slowdown of a feasible cell."""
    fmin = float(np.min(factor[feasible])) if feasible.any() else 1.0
    ys, xs = np.nonzero(cells)
    total = np.zeros(len(ys))
    for cy, cx in (prev, nxt) if nxt is not None else (prev,):
        dy, dx = np.abs(ys - cy), np.abs(xs - cx)
        total += np.maximum(dy, dx) + (math.sqrt(2.0) - 1.0) * np.minimum(dy, dx)
    out = np.full(cells.shape, np.inf)
    # a hair low against rounding: the bound only decides which cells are searched
    out[ys, xs] = total * (res * fmin * (1.0 - 1e-9))
    return out


def _best(score: np.ndarray, reg: Regions, groups: list[int], count: int) -> list[tuple[int, int]]:
    """The ``count`` (flat cell, group) of ``groups`` with the lowest finite ``score`` (ny, nx) on their
    cells of ``reg``, by (score, cell, group) ascending."""
    flats, grps, vals = [], [], []
    finite = np.isfinite(score).reshape(-1)[reg.cells]
    for g in groups:
        f = reg.cells[reg.masks[g] & finite]
        flats.append(f)
        grps.append(np.full(f.size, g))
        vals.append(score.flat[f])
    if not flats:
        return []
    cell, group, value = np.concatenate(flats), np.concatenate(grps), np.concatenate(vals)
    order = np.lexsort((group, cell, value))[:count]
    return [(int(cell[k]), int(group[k])) for k in order]


__all__ = ["RepairView", "Verified", "node_cost", "repair"]
