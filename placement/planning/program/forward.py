"""The whole task's travel as a forward dynamic program over the base grid: the lower bound and the optimum.

A plan stands, at step i, on a cell of step i's *region*: the cells from which some (arm, grasp) of
the step reaches the map threshold (:func:`map_regions`; the ``fixed`` baseline: its pre-defined
placements). Its travel is the sum of the Eq. 5 shortest-path costs [m] between consecutive cells,
from the start cell. The cheapest such sequence is found exactly by a forward dynamic program, one
multi-source Dijkstra per step seeded with the previous step's labels::

    L_0 = 0 at the start cell
    L_i(c) = min_c' L_{i-1}(c') + nav(c', c) + node_i(c)     for c in region_i, else inf

A place keeps its pick's arm and grasp (one motion holds the object): labels are kept per (arm,
grasp) *group*, and a place's group g is seeded by its pick's labels of group g only (one Dijkstra
per group with labels; other steps seed one Dijkstra with the minimum over groups). ``min L_N`` is
the optimum; with ``node = 0`` and the regions of the maps it is a lower bound on the travel of
every plan whose cells lie in them, whichever IK or collision check rejects some of them.
:class:`Program` solves it with the groups merged first (one Dijkstra per step) and groups only
the transfers whose cheapest cells break the rule: the same optimum, at a fraction of the cost.

Regions, node costs and labels are kept on each step's cells only ((G, n) over the n cells its
options reach, not (G, ny, nx): a program holds every step's, see :class:`Layer`); every label is in
metres of free-space travel (divide by the robot's ``v_max`` for seconds).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np

from placement.planning.arrays import BoolArray, Cell, FloatArray, IntArray
from placement.planning.context import PlanningContext
from placement.planning.program.regions import Group, Regions, held_torso, map_regions
from placement.planning.world import costs_at, side_by_side

#: a layer type (:class:`Layer` or the priced program's)
L = TypeVar("L")
#: what a solve calls before each step; it raises to end the solve
Stop = Callable[[], None]


@dataclass
class Layer:
    """One step's labels, kept on its region's cells only.

    Attributes:
        cells: (n,) int64 the flat cells of the step's region (the union of its groups' masks),
            ascending.
        labels: (G, n) [m] each group's label on ``cells`` (inf where its mask is off or no path
            reaches).
        roots: per Dijkstra of the step, (n,) int64 the flat cell each cell's shortest path starts
            from (a seed: a cell of the previous step's region, or the start cell).
        dijkstra: (G,) which Dijkstra labelled each group (-1: none).
        seed_group: for a step seeded by the minimum over the previous step's groups, (n_prev,) int64
            the group that gave each seed, on the previous layer's ``cells`` (None for a place or the
            first step).

    A program keeps a layer per step for hundreds of steps: on the region's cells a layer costs
    O(G n), not O(G ny nx) and a (ny, nx) predecessor map per Dijkstra.
    """

    cells: IntArray
    labels: FloatArray
    roots: list[IntArray]
    dijkstra: IntArray
    seed_group: IntArray | None

    def index(self, flat: int) -> int:
        """The position of the flat cell ``flat`` in :attr:`cells` (a cell of the region)."""
        return int(np.searchsorted(self.cells, flat))


def region_cells(reg: Regions) -> IntArray:
    """(n,) int64 the flat cells some group of ``reg`` holds, ascending."""
    cells: IntArray = reg.cells[reg.masks.any(axis=0)]
    return cells


def on_cells(reg: Regions, cells: IntArray) -> tuple[BoolArray, FloatArray | None]:
    """``reg``'s (G, n) masks and node costs [m] (None without) on the flat ``cells`` (some of its own)."""
    at = np.searchsorted(reg.cells, cells)
    return reg.masks[:, at], None if reg.node is None else reg.node[:, at]


@dataclass(frozen=True)
class Chain:
    """The cheapest sequence: per step its (flat cell, group index) and the label there [m]."""

    cells: list[int]
    groups: list[int]
    labels: list[float]

    @property
    def total(self) -> float:
        return self.labels[-1] if self.labels else 0.0


def _narrowed(layer: Layer, old: Regions, new: Regions) -> Layer | None:
    """``layer`` (computed over ``old``) for ``new`` when ``new`` only lost cells, else None."""
    if new.node is not old.node or not new.within(old):
        return None
    cells, at = narrowed_cells(layer.cells, new)
    masks, _ = on_cells(new, cells)
    labels = np.where(masks, layer.labels[:, at], math.inf)
    return Layer(cells, labels, [r[at] for r in layer.roots], layer.dijkstra, layer.seed_group)


def narrowed_cells(cells: IntArray, new: Regions) -> tuple[IntArray, IntArray]:
    """The cells of the region ``new`` (a subset of the flat ``cells``) and their positions in ``cells``."""
    kept = region_cells(new)
    return kept, np.searchsorted(cells, kept)


def lowest(labels: FloatArray) -> tuple[FloatArray, IntArray | None]:
    """(n,) the minimum over the groups of (G, n) ``labels`` and (n,) the first group that has it;
    all inf and None without groups."""
    if labels.shape[0] == 0:
        return np.full(labels.shape[1:], math.inf), None
    group = np.argmin(labels, axis=0)  # the first of equal minima, as a strict < over the groups
    return np.take_along_axis(labels, group[None], axis=0)[0], group.astype(np.int64)


def seeds_of(cells: IntArray, labels: FloatArray, width: int) -> tuple[IntArray, FloatArray]:
    """(k, 2) (iy, ix) cells and (k,) costs [m] of the finite ``labels`` (n,) on the flat ``cells`` (n,)
    of a grid ``width`` cells wide, in ascending flat order."""
    finite = np.isfinite(labels)
    flat = cells[finite]
    return np.stack([flat // width, flat % width], axis=1).astype(np.int64), labels[finite]


def kept_layers(
    layers: Sequence[L] | None,
    first: int,
    before: Sequence[Regions] | None,
    regions: Sequence[Regions],
    narrowed: Callable[[L, Regions, Regions], L | None],
) -> list[L]:
    """The layers a new solve keeps: ``layers[:first]``, and step ``first``'s own when its regions only
    lost cells since ``before`` (``narrowed`` gives it then, else None), see :func:`forward`."""
    out = list(layers[:first]) if layers is not None else []
    if layers is not None and before is not None and first < min(len(layers), len(before), len(regions)):
        kept = narrowed(layers[first], before[first], regions[first])
        if kept is not None:
            out.append(kept)
    return out


def pending(done: int, total: int, stop: Stop | None) -> Iterator[int]:
    """The steps ``done`` .. ``total - 1`` a forward pass computes, calling ``stop`` before each."""
    for i in range(done, total):
        if stop is not None:
            stop()
        yield i


class StepLabels:
    """A step's labels as its Dijkstras write them (the arrays of its :class:`Layer`).

    Args:
        reg: the step's regions; grid: (factor (ny, nx), feasible (ny, nx) bool, cell size [m]), as
            :func:`forward` takes them.
    """

    def __init__(self, reg: Regions, grid: tuple[FloatArray, BoolArray, float]):
        self.grid = grid
        self.cells = region_cells(reg)
        #: (G, n) each group's mask on :attr:`cells`; its node costs [m] (None without)
        self.masks, self.node = on_cells(reg, self.cells)
        self.labels = np.full((len(reg.groups), self.cells.size), math.inf)
        self.dijkstra = np.full(len(reg.groups), -1, dtype=np.int64)
        self.roots: list[IntArray] = []

    def search(
        self, seeds: tuple[IntArray, FloatArray], members: Sequence[int], extra: Sequence[float] | None = None
    ) -> bool:
        """One Dijkstra from ``seeds`` ((k, 2) cells, (k,) costs [m]) labelling the groups ``members``
        (their cost plus, per member, ``extra`` [m] (default 0) and their node costs); False when it
        found nothing to label (no seed, no cell), and no Dijkstra is counted."""
        found = self._costs(seeds, members)
        if found is None:
            return False
        self._label(*found, members, extra)
        return True

    def search_all(
        self, seedings: Sequence[tuple[tuple[IntArray, FloatArray], Sequence[int]]], stop: Stop | None = None
    ) -> None:
        """:meth:`search` for each (seeds, members) of ``seedings``, in order; the Dijkstras (a grouped
        place has one per arm and grasp) run side by side on the machine's cores, each in a thread with
        its own work arrays: the same labels as one after the other. ``stop`` is called before each
        (a grouped place of a hundred grasps per object holds 200 of them: a second on a large floor)."""

        def costs(sm: tuple[tuple[IntArray, FloatArray], Sequence[int]]) -> tuple[FloatArray, IntArray] | None:
            if stop is not None:
                stop()
            return self._costs(*sm)

        if len(seedings) < 2:
            found = [costs(sm) for sm in seedings]
        else:
            found = side_by_side(costs, seedings)
        for hit, (_, members) in zip(found, seedings):
            if hit is not None:
                self._label(*hit, members, None)

    def _costs(self, seeds: tuple[IntArray, FloatArray], members: Sequence[int]) -> tuple[FloatArray, IntArray] | None:
        """The Dijkstra of :meth:`search`: (here (n,) [m], root (n,)) on :attr:`cells`, or None."""
        cells, masks = self.cells, self.masks
        seed_cells, costs = seeds
        wanted = np.any(masks[list(members)], axis=0)
        if seed_cells.shape[0] == 0 or not wanted.any():
            return None
        factor, feasible, resolution = self.grid
        here = np.full(cells.size, math.inf)
        root = cells.copy()
        here[wanted], root[wanted] = costs_at(factor, feasible, seed_cells, resolution, cells[wanted], costs)
        return here, root

    def _label(self, here: FloatArray, root: IntArray, members: Sequence[int], extra: Sequence[float] | None) -> None:
        masks = self.masks
        self.roots.append(root)
        for m, k in enumerate(members):
            plus = (0.0 if extra is None else extra[m]) + (0.0 if self.node is None else self.node[k])
            self.labels[k] = np.where(masks[k], here + plus, math.inf)
            self.dijkstra[k] = len(self.roots) - 1


def forward(
    factor: FloatArray,
    feasible: BoolArray,
    resolution: float,
    start: Cell,
    regions: Sequence[Regions],
    linked: Sequence[bool],
    layers: list[Layer] | None = None,
    first: int = 0,
    before: Sequence[Regions] | None = None,
    stop: Stop | None = None,
) -> list[Layer]:
    """The labels of every step (see the module docstring).

    Args:
        factor: (ny, nx) the Eq. 4 slowdown (>= 1); feasible: (ny, nx) bool, the cells the base may
            occupy; resolution: the cell size [m] (see :func:`~placement.planning.world.navigation.navigation_cost`).
        start: (iy, ix) the start cell.
        regions: per step, where the base may stand.
        linked: per step, True for a place that keeps the previous step's group (its pick's).
        layers, first: recompute from step ``first`` on, keeping ``layers[:first]`` (after a
            change of the regions of step ``first`` or later).
        before: the regions ``layers`` were computed with: when step ``first`` only lost cells
            (same groups and node costs, masks a subset), its layer is the old one with those cells
            set to inf (its Dijkstras' costs do not depend on their targets), no Dijkstra.
        stop: called before each step's searches and each search; it raises to end the solve (the
            task's time budget, :meth:`~placement.planning.context.PlanningContext.check_budget`).
    Returns:
        one :class:`Layer` per step; a step no cell reaches has all labels inf, and so do the
        steps after it.
    """
    out = kept_layers(layers, first, before, regions, _narrowed)
    grid, width = (factor, feasible, resolution), feasible.shape[1]
    for i in pending(len(out), len(regions), stop):
        reg = regions[i]
        G = len(reg.groups)
        step = StepLabels(reg, grid)
        seed_group: IntArray | None = None
        if i == 0:
            seedings = [((np.array([start], dtype=np.int64), np.zeros(1)), list(range(G)))]
        elif linked[i]:
            prev = out[i - 1]
            same = {g: k for k, g in enumerate(regions[i - 1].groups)}
            seedings = [
                (seeds_of(prev.cells, prev.labels[same[g]], width), [k]) for k, g in enumerate(reg.groups) if g in same
            ]
        else:
            low, seed_group = lowest(out[i - 1].labels)
            seedings = [(seeds_of(out[i - 1].cells, low, width), list(range(G)))]
        step.search_all(seedings, stop)
        out.append(Layer(step.cells, step.labels, step.roots, step.dijkstra, seed_group))
    return out


def walk(layers: Sequence[Layer], before: Callable[[int, int, int], int]) -> Chain | None:
    """The cheapest chain through ``layers``, from its last step's least label back along each
    Dijkstra's roots (None when the last step has no finite label). ``before(i, g, at)``: the group of
    step i - 1 that seeded step i's group g at the previous layer's cell ``at`` (an index into its
    ``cells``)."""
    if not layers:
        return Chain([], [], [])
    last = layers[-1]
    if last.labels.size == 0 or not np.isfinite(last.labels).any():
        return None
    g, j = divmod(int(np.argmin(last.labels.reshape(-1))), last.cells.size)
    flat = int(last.cells[j])
    cells, groups, labels = [flat], [g], [float(last.labels[g, j])]
    for i in range(len(layers) - 1, 0, -1):
        layer, prev = layers[i], layers[i - 1]
        flat = int(layer.roots[int(layer.dijkstra[g])][layer.index(flat)])
        at = prev.index(flat)
        g = before(i, g, at)
        cells.append(flat)
        groups.append(g)
        labels.append(float(prev.labels[g, at]))
    cells.reverse()
    groups.reverse()
    labels.reverse()
    return Chain(cells, groups, labels)


def backtrack(layers: Sequence[Layer], regions: Sequence[Regions], linked: Sequence[bool]) -> Chain | None:
    """The cheapest chain through ``layers`` (None when the last step has no finite label)."""

    def before(i: int, g: int, at: int) -> int:
        if linked[i]:  # a place keeps its pick's group
            return regions[i - 1].groups.index(regions[i].groups[g])
        seed_group = layers[i].seed_group
        assert seed_group is not None
        return int(seed_group[at])

    return walk(layers, before)


def relaxed(reg: Regions) -> Regions:
    """``reg`` with its groups merged into one (the transfer rule dropped): one Dijkstra per step.

    Only for regions without node costs (a merged group has no single node cost)."""
    return Regions((RELAXED,), reg.cells, np.any(reg.masks, axis=0, keepdims=True), reg.shape)


#: The one group of a :func:`relaxed` region.
RELAXED: Group = ("*", None)


def conflicts(cells: Sequence[int], regions: Sequence[Regions], linked: Sequence[bool]) -> list[int]:
    """The places of a chain of cells whose cell no group of their pick's cell reaches (the steps
    where the transfer rule breaks)."""
    out = []
    for i in range(1, len(cells)):
        if not linked[i]:
            continue
        reg, before = regions[i], regions[i - 1]
        picks = {before.groups[k] for k in range(len(before.groups)) if before.has(k, cells[i - 1])}
        if not any(reg.has(k, cells[i]) and reg.groups[k] in picks for k in range(len(reg.groups))):
            out.append(i)
    return out


def regroup(chain: Chain, regions: Sequence[Regions], linked: Sequence[bool], loose: Sequence[int] = ()) -> Chain:
    """Groups for a chain of cells: per step the first group whose region holds the cell, a place
    and its pick the first group they share; a place of ``loose`` (one of its :func:`conflicts`)
    takes the first group of its pick's cell that the place has, although its cell is not in it
    (its verification fails; the caller moves it, see :mod:`placement.planning.program.repair`)."""
    n = len(chain.cells)
    groups: list[int] = [-1] * n
    for i in range(n - 1, -1, -1):
        if groups[i] >= 0:
            continue
        reg = regions[i]
        here = [k for k in range(len(reg.groups)) if reg.has(k, chain.cells[i])]
        if i > 0 and linked[i]:
            before = regions[i - 1]
            at_pick = [k for k in range(len(before.groups)) if before.has(k, chain.cells[i - 1])]
            if i in loose:
                shared = [reg.groups.index(before.groups[k]) for k in at_pick if before.groups[k] in reg.groups]
            else:
                shared = [k for k in here if reg.groups[k] in before.groups]
                shared = [k for k in shared if before.groups.index(reg.groups[k]) in at_pick]
            k = shared[0]
            groups[i], groups[i - 1] = k, before.groups.index(reg.groups[k])
        else:
            groups[i] = here[0]
    return Chain(chain.cells, groups, chain.labels)


class WholeTaskProgram(Protocol):
    """What the methods ask of a whole-task program (:class:`Program`, the priced
    :class:`~placement.planning.program.priced_torso.TorsoProgram` and
    :class:`~placement.planning.program.held_first.HeldFirst`).

    Attributes:
        lazy: return a chain with conflicting transfers (their places in ``loose``) instead of
            grouping them (only :class:`Program` honours it; the others keep ``loose`` empty).
        loose: the places of the last chain's conflicts left to the caller.
        layers: the last solve's layers, one per step.
        stop: called before each step of a solve; it raises to end it (see :func:`forward`).
    """

    lazy: bool
    loose: list[int]
    stop: Stop | None

    @property
    def layers(self) -> Sequence[Layer]:
        """The last solve's layers, one per step."""
        ...

    def group(self, places: Sequence[int]) -> int:
        """Group these transfers from now on; returns the first step to solve again from."""
        ...

    def solve(self, regions: Sequence[Regions], first: int = 0) -> Chain | None:
        """The cheapest chain over ``regions``, the layers kept before step ``first`` (the regions
        before it unchanged since the last solve); None when no chain exists."""
        ...


class GroupedProgram(ABC):
    """The grouping state a program keeps between solves (the transfer rule applied where it binds).

    Steps start merged (:meth:`merge`: a step's groups as one region, one Dijkstra per step); a
    transfer whose pick and place share no group is *grouped* (its pick and place keep their
    groups) from then on, and the program is solved again from its pick. With node costs every
    step is grouped from the start.
    """

    def __init__(self, linked: Sequence[bool]):
        self.linked = list(linked)
        #: the places whose transfer is grouped
        self.grouped: set[int] = set()
        self.layers: list[Any] = []
        #: the regions and links the layers were computed with (see :func:`forward`'s ``before``)
        self.views: list[Regions] | None = None
        self.linked_view: list[bool] = []
        #: return a chain with conflicts (their places in :attr:`loose`) instead of grouping them
        self.lazy = False
        self.loose: list[int] = []
        #: called before each step of a solve (see :func:`forward`'s ``stop``)
        self.stop: Stop | None = None

    @abstractmethod
    def merge(self, reg: Regions) -> Regions:
        """A step's regions with its groups merged (what a step outside a grouped transfer solves on)."""

    def view(self, regions: Sequence[Regions]) -> tuple[list[Regions], list[bool]]:
        """The regions and links the next solve runs on: merged outside grouped transfers."""
        if any(r.node is not None for r in regions):
            return list(regions), self.linked
        view = [r if i in self.grouped or i + 1 in self.grouped else self.merge(r) for i, r in enumerate(regions)]
        return view, [i in self.grouped for i in range(len(regions))]

    def before(self, linked: Sequence[bool]) -> list[Regions] | None:
        """The views the kept layers were computed on, when they are comparable with ``linked``."""
        return self.views if self.views is not None and list(linked) == self.linked_view else None

    def group(self, places: Sequence[int]) -> int:
        """Group these transfers from now on; returns the first step to solve again from."""
        self.grouped.update(places)
        return min(places) - 1

    @abstractmethod
    def solve(self, regions: Sequence[Regions], first: int = 0) -> Chain | None:
        """The cheapest chain over ``regions``, the layers kept before step ``first``."""


class Program(GroupedProgram):
    """The forward program with the transfer rule applied where it binds.

    Most transfers' cheapest cells keep the rule by themselves (a PR2's arms reach alike), so the
    program starts relaxed: every step's groups merged into one region (one Dijkstra per step).
    A grouped transfer's place costs one Dijkstra per group. The relaxed program is a lower bound of
    the grouped one, so the first chain without conflicts is the exact optimum (ties aside).
    """

    def __init__(self, factor: FloatArray, feasible: BoolArray, resolution: float, start: Cell, linked: Sequence[bool]):
        super().__init__(linked)
        self.grid = (factor, feasible, resolution, start)
        self.layers: list[Layer] = []

    def merge(self, reg: Regions) -> Regions:
        return relaxed(reg)

    @staticmethod
    def _shares(regions: Sequence[Regions], cells: Sequence[int], i: int) -> bool:
        """Whether a group of the pick's cell (step i - 1) is one the place (step i) has at all."""
        before = regions[i - 1]
        return any(
            before.has(k, cells[i - 1]) and before.groups[k] in regions[i].groups for k in range(len(before.groups))
        )

    def solve(self, regions: Sequence[Regions], first: int = 0) -> Chain | None:
        """The cheapest chain over ``regions``, the layers kept before step ``first`` (the regions
        before it unchanged since the last solve)."""
        while True:
            view, linked = self.view(regions)
            self.layers = forward(*self.grid, view, linked, self.layers, first, self.before(linked), self.stop)
            self.views, self.linked_view = view, linked
            chain = backtrack(self.layers, view, linked)
            if chain is None:
                return None
            bad = conflicts(chain.cells, regions, self.linked)
            shared = [i for i in bad if self._shares(regions, chain.cells, i)]
            self.loose = shared if self.lazy and shared == bad else []
            if not bad or self.loose:
                return regroup(chain, regions, self.linked, self.loose)
            first = self.group(bad)  # the earliest conflict's pick: its region is grouped now


def cheapest(
    factor: FloatArray,
    feasible: BoolArray,
    resolution: float,
    start: Cell,
    regions: Sequence[Regions],
    linked: Sequence[bool],
    stop: Stop | None = None,
) -> tuple[Chain | None, list[Layer]]:
    """The cheapest chain over ``regions`` keeping each transfer's group, and the layers of the
    :class:`Program` that found it (``stop``: see :func:`forward`)."""
    program = Program(factor, feasible, resolution, start, linked)
    program.stop = stop
    return program.solve(regions), program.layers


def linked_steps(ctx: PlanningContext) -> list[bool]:
    """Per step: True for a place right after its pick (it keeps the pick's group)."""
    return [s.pick is not None and s.pick == s.index - 1 for s in ctx.problems.steps]


def travel_bound(ctx: PlanningContext, start: Cell, regions: Sequence[Regions] | None = None) -> float:
    """The least travel [m] of any plan standing, at every step, on a cell of its region (default
    :func:`map_regions`), keeping each object's arm and grasp from its pick to its place; inf when
    no such plan exists. Raises :class:`~placement.planning.context.BudgetSpent` when the task's
    time budget runs out first."""
    if regions is None:
        regions = []
        for i in range(len(ctx.problems.steps)):
            ctx.check_budget()
            regions.append(map_regions(ctx, i))
    regs = list(regions)
    if not regs:
        return 0.0
    w = ctx.world
    chain, _ = cheapest(w.factor, w.feasible, w.nav.resolution, start, regs, linked_steps(ctx), ctx.check_budget)
    return chain.total if chain is not None else math.inf


__all__ = [
    "RELAXED",
    "Chain",
    "StepLabels",
    "Group",
    "GroupedProgram",
    "Program",
    "Layer",
    "Regions",
    "backtrack",
    "cheapest",
    "conflicts",
    "forward",
    "held_torso",
    "kept_layers",
    "linked_steps",
    "lowest",
    "map_regions",
    "narrowed_cells",
    "on_cells",
    "pending",
    "region_cells",
    "regroup",
    "relaxed",
    "seeds_of",
    "walk",
    "travel_bound",
    "WholeTaskProgram",
]
