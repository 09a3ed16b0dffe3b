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

Regions and node costs are (G, ny, nx) stacks; every label is in metres of free-space travel (divide
by the robot's ``v_max`` for seconds).
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
from placement.planning.world import extract_path, navigation_cost

#: a layer type (:class:`Layer` or the priced program's)
L = TypeVar("L")
#: what a solve calls before each step; it raises to end the solve
Stop = Callable[[], None]


@dataclass
class Layer:
    """One step's labels: ``labels`` (G, ny, nx) [m] (inf off the region); ``pred[k]`` the
    predecessor map of the k-th Dijkstra of the step and ``dijkstra[g]`` which one labelled group g
    (-1: none); ``seed_group`` (ny, nx) int, for a step seeded by the minimum over the previous
    step's groups, the group that gave each seed (None for a place or the first step)."""

    labels: FloatArray
    pred: list[IntArray]
    dijkstra: IntArray
    seed_group: IntArray | None


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
    if new.groups != old.groups or new.node is not old.node or new.masks.shape != old.masks.shape:
        return None
    if np.any(new.masks & ~old.masks):
        return None
    return Layer(np.where(new.masks, layer.labels, math.inf), layer.pred, layer.dijkstra, layer.seed_group)


def _lowest(labels: FloatArray, shape: tuple[int, ...]) -> tuple[FloatArray, IntArray | None]:
    """(ny, nx) the minimum over the groups of (G, ny, nx) ``labels`` and the first group that has it
    (``min`` and ``argmin`` over axis 0, one pass per group: numpy's strided argmin is slower);
    all inf and None without groups."""
    if labels.shape[0] == 0:
        return np.full(shape, math.inf), None
    low = labels[0].copy()
    group = np.zeros(shape, dtype=np.int64)
    for g in range(1, labels.shape[0]):
        better = labels[g] < low
        low[better] = labels[g][better]
        group[better] = g
    return low, group


def _seeds(labels: FloatArray) -> tuple[IntArray, FloatArray]:
    """(k, 2) cells and (k,) costs of the finite entries of a (ny, nx) label map."""
    cells = np.argwhere(np.isfinite(labels))
    return cells.astype(np.int64), labels[cells[:, 0], cells[:, 1]]


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


def search_from(
    factor: FloatArray,
    feasible: BoolArray,
    resolution: float,
    seeds: tuple[IntArray, FloatArray],
    reg: Regions,
    members: Sequence[int],
) -> tuple[FloatArray, IntArray] | None:
    """One Dijkstra of a step: from ``seeds`` ((k, 2) cells, (k,) costs [m]) until every cell of the
    groups ``members`` of ``reg`` is settled; (cost (ny, nx) [m], predecessors), or None when there
    is no seed or no such cell."""
    cells, costs = seeds
    targets: BoolArray = np.zeros(feasible.shape, bool)
    np.any(reg.masks[list(members)], axis=0, out=targets)
    if cells.shape[0] == 0 or not targets.any():
        return None
    cost, pred = navigation_cost(factor, feasible, cells, resolution, costs, targets)
    # a program keeps one predecessor map per Dijkstra of every step (hundreds on long tasks): the
    # flat indices of a grid of at most MAX_GRID_CELLS fit 32 bits, half the memory
    return cost, pred.astype(np.int32)


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
        stop: called before each step's searches; it raises to end the solve (the task's time
            budget, :meth:`~placement.planning.context.PlanningContext.check_time`).
    Returns:
        one :class:`Layer` per step; a step no cell reaches has all labels inf, and so do the
        steps after it.
    """
    out = kept_layers(layers, first, before, regions, _narrowed)
    shape = feasible.shape
    for i in pending(len(out), len(regions), stop):
        reg = regions[i]
        G = len(reg.groups)
        labels = np.full((G, *shape), math.inf)
        dijkstra = np.full(G, -1, dtype=np.int64)
        preds: list[IntArray] = []
        seed_group: IntArray | None = None
        if i == 0:
            seedings = [((np.array([start], dtype=np.int64), np.zeros(1)), list(range(G)))]
        elif linked[i]:
            prev = out[i - 1].labels
            same = {g: k for k, g in enumerate(regions[i - 1].groups)}
            seedings = [(_seeds(prev[same[g]]), [k]) for k, g in enumerate(reg.groups) if g in same]
        else:
            low, seed_group = _lowest(out[i - 1].labels, shape)
            seedings = [(_seeds(low), list(range(G)))]
        for seeds, members in seedings:
            found = search_from(factor, feasible, resolution, seeds, reg, members)
            if found is None:
                continue
            cost, pred = found
            preds.append(pred)
            for k in members:
                node = 0.0 if reg.node is None else reg.node[k]
                labels[k] = np.where(reg.masks[k], cost + node, math.inf)
                dijkstra[k] = len(preds) - 1
        out.append(Layer(labels, preds, dijkstra, seed_group))
    return out


def _root(pred: IntArray, flat: int) -> int:
    """The source cell (flat) of the shortest path that ends at ``flat``."""
    iy, ix = extract_path(pred, divmod(flat, pred.shape[1]))[0]
    return int(iy) * int(pred.shape[1]) + int(ix)


def backtrack(layers: Sequence[Layer], regions: Sequence[Regions], linked: Sequence[bool]) -> Chain | None:
    """The cheapest chain through ``layers`` (None when the last step has no finite label)."""
    if not layers:
        return Chain([], [], [])
    last = layers[-1].labels
    if last.size == 0 or not np.isfinite(last).any():
        return None
    k = int(np.argmin(last.reshape(-1)))
    g, flat = divmod(k, last.shape[1] * last.shape[2])
    cells, groups, labels = [flat], [g], [float(last.reshape(last.shape[0], -1)[g, flat])]
    for i in range(len(layers) - 1, 0, -1):
        layer = layers[i]
        root = _root(layer.pred[int(layer.dijkstra[g])], flat)
        if linked[i]:
            g = regions[i - 1].groups.index(regions[i].groups[g])
        else:
            assert layer.seed_group is not None
            g = int(layer.seed_group.flat[root])
        flat = root
        prev = layers[i - 1].labels
        cells.append(flat)
        groups.append(g)
        labels.append(float(prev.reshape(prev.shape[0], -1)[g, flat]))
    cells.reverse()
    groups.reverse()
    labels.reverse()
    return Chain(cells, groups, labels)


def relaxed(reg: Regions) -> Regions:
    """``reg`` with its groups merged into one (the transfer rule dropped): one Dijkstra per step.

    Only for regions without node costs (a merged group has no single node cost)."""
    return Regions((RELAXED,), reg.union()[None])


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
        picks = {before.groups[k] for k in range(len(before.groups)) if before.masks[k].flat[cells[i - 1]]}
        if not any(reg.masks[k].flat[cells[i]] and reg.groups[k] in picks for k in range(len(reg.groups))):
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
        here = [k for k in range(len(reg.groups)) if reg.masks[k].flat[chain.cells[i]]]
        if i > 0 and linked[i]:
            before = regions[i - 1]
            at_pick = [k for k in range(len(before.groups)) if before.masks[k].flat[chain.cells[i - 1]]]
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
            before.masks[k].flat[cells[i - 1]] and before.groups[k] in regions[i].groups
            for k in range(len(before.groups))
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
            ctx.check_time()
            regions.append(map_regions(ctx, i))
    regs = list(regions)
    if not regs:
        return 0.0
    w = ctx.world
    chain, _ = cheapest(w.factor, w.feasible, w.nav.resolution, start, regs, linked_steps(ctx), ctx.check_time)
    return chain.total if chain is not None else math.inf


__all__ = [
    "RELAXED",
    "Chain",
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
    "map_regions",
    "pending",
    "regroup",
    "relaxed",
    "search_from",
    "travel_bound",
    "WholeTaskProgram",
]
