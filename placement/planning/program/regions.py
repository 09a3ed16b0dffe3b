"""Where the base may stand for each step: per (arm, grasp) group, the cells from which one of the
step's options keeps its arm's map threshold (the regions of the whole-task program, see
:mod:`placement.planning.program.forward`), and their node costs for ``optimal_manipulability_weight``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from placement.planning.arrays import BoolArray, Float32Array, FloatArray, IntArray
from placement.planning.context import PlanningContext
from placement.planning.problems import Option
from placement.planning.torso import start_torso

#: Steps whose options a program starts ahead of the one it asks for: their kernel passes run in the
#: background while it reads this step's (see StepProblems.prefetch)
PREFETCH_STEPS = 2
#: An (arm, grasp) pair: what a pick commits its place to.
Group = tuple[str, str | None]


@dataclass(frozen=True)
class Regions:
    """Where the base may stand for one step, per (arm, grasp) group, kept on the step's cells only.

    A whole-task program keeps every step's regions (hundreds of steps, up to a group per arm and
    grasp each): on the cells a step's options reach, not on the whole grid.

    Attributes:
        groups: (G,) the groups, in a fixed order.
        cells: (n,) int64 flat cells of the grid, ascending: those any group holds (after removals a
            cell may be held by none).
        masks: (G, n) bool, each group's cells among ``cells``.
        shape: (ny, nx) the grid's shape.
        node: (G, n) float [m] cost of standing there (added to the label), or None (all 0).
        settings: (G,) the torso setting [m or rad; a posture's index] each group's options hold, for
            the program that prices the torso (:mod:`placement.planning.program.priced_torso`: a group per
            (arm, grasp, setting), so a (arm, grasp) may repeat); None: any setting.
    """

    groups: tuple[Group, ...]
    cells: IntArray
    masks: BoolArray
    shape: tuple[int, int]
    node: FloatArray | None = None
    settings: tuple[float, ...] | None = None

    @classmethod
    def of(
        cls,
        groups: tuple[Group, ...],
        masks: BoolArray,
        node: FloatArray | None = None,
        settings: tuple[float, ...] | None = None,
    ) -> Regions:
        """The regions of (G, ny, nx) ``masks`` (and (G, ny, nx) ``node`` [m]) on the whole grid."""
        G, ny, nx = masks.shape
        flat = masks.reshape(G, ny * nx)
        cells = np.flatnonzero(flat.any(axis=0)).astype(np.int64)
        kept = None if node is None else node.reshape(G, ny * nx)[:, cells]
        return cls(groups, cells, flat[:, cells], (ny, nx), kept, settings)

    @classmethod
    def stacked(cls, parts: Sequence[Regions], shape: tuple[int, int]) -> Regions:
        """The groups of ``parts`` (without node costs) one after the other, on the union of their cells;
        their settings concatenated when every part has them."""
        cells = np.unique(np.concatenate([p.cells for p in parts])) if parts else np.zeros(0, np.int64)
        masks = np.zeros((sum(len(p.groups) for p in parts), cells.size), bool)
        row = 0
        for p in parts:
            masks[row : row + len(p.groups), np.searchsorted(cells, p.cells)] = p.masks
            row += len(p.groups)
        sets = [p.settings for p in parts]
        settings = tuple(t for s in sets if s is not None for t in s) if all(s is not None for s in sets) else None
        groups = tuple(g for p in parts for g in p.groups)
        return cls(groups, cells.astype(np.int64), masks, shape, None, settings)

    def any(self) -> bool:
        """Whether some group holds a cell."""
        return bool(self.masks.any())

    def mask(self, groups: Sequence[int] | None = None) -> BoolArray:
        """(ny, nx) bool: the cells of any of ``groups`` (indices; default all)."""
        out: BoolArray = np.zeros(self.shape[0] * self.shape[1], bool)
        rows = self.masks if groups is None else self.masks[list(groups)]
        out[self.cells[rows.any(axis=0)]] = True
        return out.reshape(self.shape)

    def dense(self) -> BoolArray:
        """(G, ny, nx) bool: each group's cells on the whole grid."""
        out = np.zeros((len(self.groups), self.shape[0] * self.shape[1]), bool)
        out[:, self.cells] = self.masks
        return out.reshape(len(self.groups), *self.shape)

    def where(self, flat: int) -> int | None:
        """The position of the flat cell ``flat`` in :attr:`cells` (None: not one of them)."""
        k = int(np.searchsorted(self.cells, flat))
        return k if k < self.cells.size and int(self.cells[k]) == flat else None

    def has(self, g: int, flat: int) -> bool:
        """Whether group g holds the flat cell ``flat``."""
        k = self.where(flat)
        return k is not None and bool(self.masks[g, k])

    def node_at(self, g: int, flat: int) -> float:
        """Group g's node cost [m] at the flat cell ``flat`` (0 without node costs or off its cells)."""
        k = self.where(flat)
        return 0.0 if self.node is None or k is None else float(self.node[g, k])

    def take(self, index: Sequence[int]) -> Regions:
        """The groups ``index`` (indices, in that order) alone, on the same cells."""
        rows = list(index)
        node = None if self.node is None else self.node[rows]
        sets = None if self.settings is None else tuple(self.settings[k] for k in rows)
        return Regions(tuple(self.groups[k] for k in rows), self.cells, self.masks[rows], self.shape, node, sets)

    def without(self, g: int, around: int, r: int = 0) -> Regions:
        """These regions with group g off at the flat cell ``around`` and the cells within ``r`` cells of it
        (a square)."""
        iy, ix = divmod(around, self.shape[1])
        ys, xs = np.divmod(self.cells, self.shape[1])
        near = (np.abs(ys - iy) <= r) & (np.abs(xs - ix) <= r)
        masks = self.masks.copy()
        masks[g, near] = False
        return replace(self, masks=masks)

    def without_cells(self, off: Mapping[int, Sequence[int]]) -> Regions:
        """These regions with each group g of ``off`` off at its flat cells ``off[g]`` (cells not among
        :attr:`cells` are ignored)."""
        masks = self.masks.copy()
        for g, flats in off.items():
            want = np.asarray(flats, np.int64)
            at = np.minimum(np.searchsorted(self.cells, want), max(self.cells.size - 1, 0))
            if self.cells.size:
                masks[g, at[self.cells[at] == want]] = False
        return replace(self, masks=masks)

    def without_group(self, g: int) -> Regions:
        """These regions with group g off everywhere."""
        masks = self.masks.copy()
        masks[g] = False
        return replace(self, masks=masks)

    def within(self, other: Regions) -> bool:
        """Whether every (group, cell) of these regions is one of ``other``'s (same groups and grid)."""
        if self.groups != other.groups or self.shape != other.shape:
            return False
        held = self.masks.any(axis=0)
        at = np.searchsorted(other.cells, self.cells[held])
        at = np.minimum(at, max(other.cells.size - 1, 0))
        if other.cells.size == 0:
            return not held.any()
        if not np.array_equal(other.cells[at], self.cells[held]):
            return False
        return not np.any(self.masks[:, held] & ~other.masks[:, at])


def map_regions(
    ctx: PlanningContext, i: int, hold_lift: bool = False, held: float | None = None, regional: bool = False
) -> Regions:
    """Step i's region by the maps: per (arm, grasp) group the cells where one of its options keeps
    the threshold (the cells the map-based methods may stand on), at any torso setting.

    ``hold_lift``: only the options at the torso value the robot starts with (the preset's) when
    they keep the threshold on some feasible cell, all settings otherwise: ``global``'s program does
    not price the lift's motion (a PR2's lift takes 24 s end to end), so it moves it only for a step
    the maps do not serve at the held value (``optimal`` prices it: :mod:`placement.planning.program.priced_torso`). ``held``: that value [m] already found
    by :func:`held_torso` (the options at it only; None: every setting). ``regional``: every setting,
    from options that say only where the threshold is kept (the same region for less work: the
    certificate's, :meth:`~placement.planning.problems.StepProblems.region_options`).
    """
    if hold_lift:
        held = held_torso(ctx, i)
    opts = ctx.problems.region_options(i, stop=ctx.check_budget) if regional else program_options(ctx, i, held)
    return _regions(ctx.for_step(i), opts)


def program_options(ctx: PlanningContext, i: int, held: float | None = None) -> list[Option]:
    """Step i's options (at torso value ``held`` [m] alone; None: every setting) as a whole-task program
    reads them: its regions need only where each keeps its threshold, and verification the best value
    and yaw of the cells it checks (:meth:`~placement.planning.problems.StepProblems.threshold_options`,
    ``exact_values``); each option's best value everywhere when ``optimal_manipulability_weight``
    prices it. One list per step and setting: a verified placement's option indexes into it."""
    problems = ctx.problems
    if ctx.config.optimal_manipulability_weight > 0:
        return problems.options(i) if held is None else problems.held_options(i, held, ctx.check_budget)
    return problems.threshold_options(i, held, ctx.check_budget)


def prefetch_program_options(ctx: PlanningContext, i: int, held: float | None = None) -> None:
    """Start computing what :func:`program_options` ``(ctx, i, held)`` will give, its kernel passes in
    the background (:meth:`~placement.planning.problems.StepProblems.prefetch`): a program asks for its
    steps one after the other, and each step's arguments are made while the step before is computed."""
    exact = ctx.config.optimal_manipulability_weight > 0
    ctx.problems.prefetch(i, held, exact, ctx.check_budget)


def held_torso(ctx: PlanningContext, i: int) -> float | None:
    """The torso value [m] the robot starts with if step i's options there keep the threshold on a
    feasible cell (the step is planned with the lift held there, see :func:`map_regions`), else None."""
    held = start_torso(ctx)
    if held is None:
        return None
    opts = program_options(ctx, i, held)  # before for_step: its relaxed thresholds read these first
    return held if _regions(ctx.for_step(i), opts).any() else None


def _regions(ctx: PlanningContext, opts: Sequence[Option]) -> Regions:
    """The region of an options list of the problems' cache (computed once per list: the lists are
    kept, and so is the region, which nothing writes to)."""
    cache = ctx.problems.regions
    hit = cache.get(id(opts))
    if hit is None or hit[0] is not opts:  # the list is kept with it: its id is not reused meanwhile
        hit = cache[id(opts)] = (opts, _compute_regions(ctx, opts))
    return hit[1]


def _compute_regions(ctx: PlanningContext, opts: Sequence[Option]) -> Regions:
    nav = ctx.world.nav
    ny, nx = nav.shape
    groups = sorted({(o.arm, o.candidate.grasp) for o in opts}, key=lambda g: (g[0], str(g[1])))
    index = {g: k for k, g in enumerate(groups)}
    if not opts:
        return Regions(tuple(groups), np.zeros(0, np.int64), np.zeros((0, 0), bool), nav.shape)
    # the options' windows overlap (one target): their bounding box, dense, then its cells kept
    y0, x0 = min(o.window.y0 for o in opts), min(o.window.x0 for o in opts)
    y1, x1 = max(o.window.y1 for o in opts), max(o.window.x1 for o in opts)
    box = np.zeros((len(groups), y1 - y0, x1 - x0), dtype=bool)
    for o in opts:
        w = o.window
        box[index[(o.arm, o.candidate.grasp)], w.y0 - y0 : w.y1 - y0, w.x0 - x0 : w.x1 - x0] |= (
            o.value >= ctx.option_threshold(o)
        )
    box &= ctx.world.feasible[y0:y1, x0:x1]
    flat = box.reshape(len(groups), -1)
    local = np.flatnonzero(flat.any(axis=0))
    ly, lx = np.divmod(local, x1 - x0)
    cells = ((ly + y0) * nx + lx + x0).astype(np.int64)  # ascending: row by row in the box and the grid
    return Regions(tuple(groups), cells, flat[:, local], (ny, nx))


def best_values(reg: Regions, opts: Sequence[tuple[int, Option]]) -> Float32Array:
    """(G, n) the best map value of the options ``opts`` ((group index, option) pairs) on each group's
    cells of ``reg`` (0 where none reaches)."""
    best = np.zeros(reg.masks.shape, np.float32)
    ys, xs = np.divmod(reg.cells, reg.shape[1])
    for k, o in opts:
        w = o.window
        inside = np.flatnonzero((ys >= w.y0) & (ys < w.y1) & (xs >= w.x0) & (xs < w.x1))
        best[k, inside] = np.maximum(best[k, inside], o.value[ys[inside] - w.y0, xs[inside] - w.x0])
    return best


def node_costs(reg: Regions, weight: float, best: Float32Array) -> FloatArray:
    """(G, n) the node cost ``weight / m`` [m] on each group's cells of ``reg`` (m: ``best``, its best
    map value there), 0 off them."""
    with np.errstate(divide="ignore"):
        out: FloatArray = np.where(reg.masks, weight / np.maximum(best, 1e-12), 0.0)
    return out


def reweighted(ctx: PlanningContext, i: int, reg: Regions) -> Regions:
    """``reg`` with the node cost ``optimal_manipulability_weight / m`` [m] per (group, cell) (m: the
    group's best map value there), or unchanged when the weight is 0."""
    weight = ctx.config.optimal_manipulability_weight
    if weight <= 0 or not reg.groups:
        return reg
    index = {gr: k for k, gr in enumerate(reg.groups)}
    best = best_values(reg, [(index[(o.arm, o.candidate.grasp)], o) for o in ctx.problems.options(i)])
    return replace(reg, node=node_costs(reg, weight, best))


__all__ = [
    "PREFETCH_STEPS",
    "Group",
    "Regions",
    "best_values",
    "held_torso",
    "map_regions",
    "node_costs",
    "prefetch_program_options",
    "program_options",
    "reweighted",
]
