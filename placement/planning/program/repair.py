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
rejection and solves again. A group whose probe finds it hopeless
(:meth:`~placement.planning.program.state.DynamicProgram.gives_up`, asked once a repair rejected
:data:`REPAIR_PROBE_AFTER` of its cells) gets no further candidates: the next cells along the detour
fail as the last did, and the caller drops the group (the lab with 100 published grasps per object:
456 verifications -> 209, the kitchen 347 -> 214; the same plans on the building scenes).

The two searches are asked only for the region's cells whose detour cannot exceed the least one by
more than ``WINDOW_M`` (by a lower bound: octile distances times the least slowdown), a window that
grows while none of its cells verifies: the candidates come in the order a search of the whole
region gives, and the searches, directed at a smaller box of targets, settle fewer cells. From a cell
far from the region (``FAR`` times its extent; a building's corridor away) a search settles about the
same cells for a window as for the whole region, so it is asked for the whole region once and serves
every window: on the office floor's published-grasp task its repairs searched 8 times for 130 ms, now
twice for 30 ms. All work on the region's cells, not on (ny, nx) grids.
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
#: rejections of a group after which a repair asks its probe (fewer than a plan's: a repair's cells
#: lie along one detour, and fail together)
REPAIR_PROBE_AFTER = 4
#: a search from a cell at least this many times the region's extent away covers the whole region at
#: once (see :func:`repair`)
FAR = 4.0


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

    def gives_up(self, i: int, g: int, late: bool = False, after: int = ...) -> bool: ...


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
    held = np.flatnonzero(reg.masks[groups].any(axis=0))  # positions in reg.cells
    if not held.size:
        return None
    cells = reg.cells[held]  # flat, ascending
    prev_cell = dp.start if i == 0 else divmod(chain.cells[i - 1], nx)
    prev_label = 0.0 if i == 0 else chain.labels[i - 1]
    next_cell = divmod(chain.cells[i + 1], nx) if i + 1 < n else None
    fmin = float(np.min(w.factor[w.feasible])) if w.feasible.any() else 1.0
    res = w.nav.resolution
    bound = _octile(prev_cell, cells, nx) + (0.0 if next_cell is None else _octile(next_cell, cells, nx))
    # a hair low against rounding: the bound only decides which cells are searched
    bound *= res * fmin * (1.0 - 1e-9)
    least = float(np.min(bound))
    count = ctx.config.global_repair_candidates
    tried: set[tuple[int, int]] = set()
    reach = least + WINDOW_M
    extent = _extent(cells, nx)
    # a search from afar settles about the same cells for the whole region as for a window of it:
    # one search then serves every window (its costs are exact on every target either way)
    far = {c: float(np.min(_octile(c, cells, nx))) >= FAR * extent for c in (prev_cell, next_cell) if c is not None}

    def leg(cell: tuple[int, int], window: np.ndarray, reverse: bool) -> np.ndarray:
        if far[cell]:
            out = ctx.problems.legs(cell, cells, reverse).copy()
            out[~window] = np.inf
            return out
        out = np.full(cells.size, np.inf)
        out[window] = ctx.problems.legs(cell, cells[window], reverse)
        return out

    given_up: set[int] = set()  # groups a probe found hopeless during this repair
    while len(tried) < count:
        # only the region's cells whose detour bound is within ``reach`` are searched: a cell outside
        # detours more than ``reach`` [m], so those within rank exactly as they would among all
        window = bound <= reach
        whole = bool(window.all())
        into = leg(prev_cell, window, False)
        score = into.copy()
        out_of = None
        if next_cell is not None:  # from every candidate to the next step's cell: the legs out, exact
            out_of = leg(next_cell, window, True)
            score += out_of
        if not whole:
            score[score > reach] = np.inf
        for k, g in _best(score, reg, held, groups, count):
            flat = int(cells[k])
            if (flat, g) in tried or g in given_up:
                continue
            tried.add((flat, g))
            v = dp.verify(i, flat, g)
            if v is None:
                if dp.gives_up(i, g, after=REPAIR_PROBE_AFTER):
                    # its probe verified nothing around the region: the next cells of the group, a
                    # step further along the same detour, fail as this one did (a forearm over the
                    # table's edge), and the caller drops the group
                    given_up.add(g)
                    if len(given_up) == len(groups):
                        return None
                if len(tried) >= count:
                    break
                continue
            labels = list(chain.labels)
            labels[i] = prev_label + float(into[k]) + node_cost(dp, i, g, flat)
            if out_of is not None:
                nxt = chain.cells[i + 1]
                new_next = labels[i] + float(out_of[k]) + node_cost(dp, i + 1, chain.groups[i + 1], nxt)
                shift = new_next - chain.labels[i + 1]
                labels[i + 1 :] = [label + shift for label in chain.labels[i + 1 :]]
            cells_, grps = list(chain.cells), list(chain.groups)
            cells_[i], grps[i] = flat, g
            return Chain(cells_, grps, labels), v
        if whole:
            break
        reach += 2.0 * (reach - least)
    return None


def _octile(cell: tuple[int, int], flats: np.ndarray, nx: int) -> np.ndarray:
    """(n,) the octile distance [cells] from ``cell`` (iy, ix) to each flat cell of ``flats`` (n,): the
    shortest 8-connected path with no obstacle, a lower bound on the travel in cells."""
    ys, xs = np.divmod(flats, nx)
    dy, dx = np.abs(ys - cell[0]), np.abs(xs - cell[1])
    out: np.ndarray = np.maximum(dy, dx) + (math.sqrt(2.0) - 1.0) * np.minimum(dy, dx)
    return out


def _extent(flats: np.ndarray, nx: int) -> float:
    """The larger side [cells] of the bounding box of the flat cells ``flats`` (n > 0,)."""
    ys, xs = np.divmod(flats, nx)
    return float(max(np.ptp(ys), np.ptp(xs), 1))


def _best(score: np.ndarray, reg: Regions, held: np.ndarray, groups: list[int], count: int) -> list[tuple[int, int]]:
    """The ``count`` (index into ``held``, group) of ``groups`` with the lowest finite ``score`` (n,) on
    their cells among ``reg.cells[held]``, by (score, cell, group) ascending."""
    idx, grps, vals = [], [], []
    finite = np.isfinite(score)
    for g in groups:
        k = np.flatnonzero(reg.masks[g, held] & finite)
        idx.append(k)
        grps.append(np.full(k.size, g))
        vals.append(score[k])
    if not idx:
        return []
    at, group, value = np.concatenate(idx), np.concatenate(grps), np.concatenate(vals)
    # ``held`` ascends with the cells: ordering by index is ordering by cell
    order = np.lexsort((group, at, value))[:count]
    return [(int(at[k]), int(group[k])) for k in order]


__all__ = ["RepairView", "Verified", "node_cost", "repair"]
