"""The whole-task program with the torso priced: ``optimal``'s program over (cell, torso setting).

With torso settings (a lift, a revolute torso, postures: :mod:`placement.maps.torso`) ``optimal``
keeps a step's labels per (arm, grasp, setting) *group* (:func:`torso_regions`: each setting's
options, thresholded at that setting's threshold), and a move between consecutive steps from
setting t to t' costs the base travel [m] plus the torso term ``T(t, t') = v_max * torso_s(t, t')``
[m] (:func:`~placement.planning.torso.torso_seconds`: |t' - t| / velocity for a lift or a revolute
torso, the slowest joint's time for postures), the metres the base would drive meanwhile::

    L_0(g, t, c) = T(t_0, t) + nav(start, c)                     t_0: the preset's setting
    L_i(g', t', c') = min over (g, t, c) of L_{i-1}(g, t, c) + T(t, t') + nav(c, c') + node_i(g', t', c')

over the cells c' of group (g', t')'s region; a place keeps its pick's arm and grasp (g' = g), not
its setting (the object is carried while the torso moves). One multi-source Dijkstra per (step,
target setting), seeded with the minimum over the previous step's groups and settings of label +
T (k settings: k Dijkstras per step; the first step one, offset per setting; a grouped transfer's
place one per (arm, grasp, setting)). As in :class:`~placement.planning.program.forward.Program` the groups
of a step are merged per setting first, and a transfer is grouped only where its cheapest cells
share no arm and grasp: the same optimum.

The approximation: the task-time model runs the base and the torso in parallel (a step lasts
max(base, torso, arm) [s], :mod:`placement.planning.task_time`); the program adds them. Per step
``travel + T >= v_max * max(travel / v_max, torso_s)`` and ``<= 2 v_max * max(...)``: the objective
is an upper bound of the (base travel, torso) part of the task time, at most twice it, exact for a
step that moves only one of them. Base rotation and arm motion stay out, as in the plain program.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from placement.planning.arrays import BoolArray, Cell, FloatArray, IntArray
from placement.planning.context import PlanningContext
from placement.planning.program.forward import (
    RELAXED,
    Chain,
    GroupedProgram,
    Layer,
    StepLabels,
    Stop,
    kept_layers,
    lowest,
    narrowed_cells,
    on_cells,
    pending,
    seeds_of,
    walk,
)
from placement.planning.program.regions import Group, Regions, best_values, map_regions, node_costs
from placement.planning.torso import torso_seconds

#: (setting before, setting after) -> the torso term [m]
Term = Callable[[float, float], float]


@dataclass
class TorsoLayer(Layer):
    """A :class:`~placement.planning.program.forward.Layer` of the priced program: ``seed_from[k]`` (n_prev,)
    int64, for the k-th Dijkstra, the previous step's group (index into its view) whose label gave
    each seed, on the previous layer's ``cells`` (None for the first step); ``seed_group`` is unused
    (None)."""

    seed_from: list[IntArray | None] = field(default_factory=list)


def torso_term(ctx: PlanningContext) -> Term:
    """The torso term T(a, b) [m]: ``v_max`` times the torso's time [s] from setting a to b."""
    v = ctx.robot.v_max
    return lambda a, b: v * torso_seconds(ctx, a, b)


def torso_regions(ctx: PlanningContext, i: int) -> Regions:
    """Step i's region per (arm, grasp, setting): each setting's :func:`map_regions` (its options
    only, each at its setting's threshold), stacked in the order of ``ctx.problems.settings``."""
    parts = [map_regions(ctx, i, held=t) for t in ctx.problems.settings if t is not None]
    reg = Regions.stacked(parts, ctx.world.nav.shape)
    sets = [t for t in ctx.problems.settings if t is not None]
    return replace(reg, settings=tuple(t for t, r in zip(sets, parts) for _ in r.groups))


def torso_reweighted(ctx: PlanningContext, i: int, reg: Regions) -> Regions:
    """``reg`` (of :func:`torso_regions`) with the node cost ``optimal_manipulability_weight / m`` [m]
    per (group, cell), m the group's best map value there at its setting; unchanged for weight 0."""
    weight = ctx.config.optimal_manipulability_weight
    if weight <= 0 or not reg.groups or reg.settings is None:
        return reg
    index = {(g, t): k for k, (g, t) in enumerate(zip(reg.groups, reg.settings))}
    best = best_values(
        reg,
        [
            (index[((o.arm, o.candidate.grasp), t)], o)
            for t in sorted(set(reg.settings))
            for o in ctx.problems.held_options(i, t)
        ],
    )
    return replace(reg, node=node_costs(reg, weight, best))


def settings_of(reg: Regions) -> tuple[float, ...]:
    """(G,) each group's setting (a region of :func:`torso_regions` or its view)."""
    if reg.settings is None:
        raise ValueError("a region of the priced torso program needs its groups' settings")
    return reg.settings


def merged(reg: Regions) -> Regions:
    """``reg`` with its groups merged per setting (the transfer rule dropped, the settings kept):
    one group per setting, in ascending order."""
    sets = settings_of(reg)
    order = sorted(set(sets))
    masks = np.zeros((len(order), reg.cells.size), bool)
    for k, t in enumerate(order):
        members = [j for j, s in enumerate(sets) if s == t]
        np.any(reg.masks[members], axis=0, out=masks[k])
    return Regions((RELAXED,) * len(order), reg.cells, masks, reg.shape, None, tuple(order))


def _narrowed(layer: TorsoLayer, old: Regions, new: Regions) -> TorsoLayer | None:
    """``layer`` (computed over ``old``) for ``new`` when ``new`` only lost cells, else None."""
    if new.settings != old.settings or new.node is not old.node or not new.within(old):
        return None
    cells, at = narrowed_cells(layer.cells, new)
    masks, _ = on_cells(new, cells)
    labels = np.where(masks, layer.labels[:, at], math.inf)
    return TorsoLayer(cells, labels, [r[at] for r in layer.roots], layer.dijkstra, None, layer.seed_from)


def _per_setting(
    prev: FloatArray, before: Sequence[float], sources: Sequence[int]
) -> list[tuple[float, FloatArray, IntArray]]:
    """Per setting of the groups ``sources``: (the setting, (n,) the minimum of (G, n) ``prev`` over its
    groups, the first group that has it)."""
    out = []
    for s in sorted({before[j] for j in sources}):
        members = np.array([j for j in sources if before[j] == s], dtype=np.int64)
        low, k = lowest(prev[members])
        assert k is not None
        out.append((s, low, members[k]))
    return out


def _seeded(
    lows: Sequence[tuple[float, FloatArray, IntArray]], t: float, term: Term, cells: IntArray, width: int
) -> tuple[IntArray, FloatArray, IntArray]:
    """The seeds of a Dijkstra towards setting t: (k, 2) cells, (k,) costs min over the settings s of
    ``lows`` (on the previous step's flat ``cells``) of low_s + T(s, t) [m], and (n_prev,) the group
    that gave each cell's cost."""
    s, low, frm = lows[0]
    low, frm = low + term(s, t), frm.copy()
    for s, other, came in lows[1:]:
        cand = other + term(s, t)
        better = cand < low
        low[better] = cand[better]
        frm[better] = came[better]
    seed_cells, costs = seeds_of(cells, low, width)
    return seed_cells, costs, frm


def forward(
    grid: tuple[FloatArray, BoolArray, float, Cell],
    start_torso: float,
    term: Term,
    regions: Sequence[Regions],
    linked: Sequence[bool],
    layers: list[TorsoLayer] | None = None,
    first: int = 0,
    before: Sequence[Regions] | None = None,
    stop: Stop | None = None,
) -> list[TorsoLayer]:
    """The labels of every step (the module docstring's program).

    Args:
        grid: (factor (ny, nx), feasible (ny, nx) bool, cell size [m], start cell (iy, ix)), as
            :func:`~placement.planning.program.forward.forward` takes them.
        start_torso: the setting the robot starts at; term: the torso term [m].
        regions: per step, the groups (with settings) and where the base may stand.
        linked: per step, True for a place whose groups are seeded by its pick's of the same arm
            and grasp only.
        layers, first, before: recompute from step ``first`` on (see
            :func:`~placement.planning.program.forward.forward`).
        stop: called before each step's searches; it raises to end the solve.
    Returns:
        one :class:`TorsoLayer` per step (all inf from the first step no cell reaches).
    """
    factor, feasible, resolution, start = grid
    out = kept_layers(layers, first, before, regions, _narrowed)
    grid3, width = (factor, feasible, resolution), feasible.shape[1]
    for i in pending(len(out), len(regions), stop):
        reg = regions[i]
        sets = settings_of(reg)
        G = len(reg.groups)
        step = StepLabels(reg, grid3)
        froms: list[IntArray | None] = []
        # (seed cells (k, 2), seed costs (k,), their source groups, the groups labelled)
        seedings: list[tuple[IntArray, FloatArray, IntArray | None, list[int]]] = []
        if i == 0:
            seedings.append((np.array([start], dtype=np.int64), np.zeros(1), None, list(range(G))))
        else:
            prev, prev_reg = out[i - 1], regions[i - 1]
            before_sets = settings_of(prev_reg)
            everyone = list(range(len(prev_reg.groups)))
            wanted = [k for k in range(G) if step.masks[k].any()]  # a group without cells needs no search
            if linked[i]:  # a place: its pick's groups of the same arm and grasp, any setting
                lows_of: dict[Group, list[tuple[float, FloatArray, IntArray]]] = {}
                for k in wanted:
                    g = reg.groups[k]
                    if g not in lows_of:
                        sources = [j for j in everyone if prev_reg.groups[j] == g]
                        lows_of[g] = _per_setting(prev.labels, before_sets, sources) if sources else []
                    if lows_of[g]:
                        seedings.append((*_seeded(lows_of[g], sets[k], term, prev.cells, width), [k]))
            elif everyone and wanted:
                lows = _per_setting(prev.labels, before_sets, everyone)
                for t in sorted({sets[k] for k in wanted}):
                    seedings.append((*_seeded(lows, t, term, prev.cells, width), [k for k in range(G) if sets[k] == t]))
        for seed_cells, costs, frm, members in seedings:
            # the first step's settings share its search, each offset by the torso's move to it
            extra = [term(start_torso, sets[k]) for k in members] if i == 0 else None
            if step.search((seed_cells, costs), members, extra):
                froms.append(frm)
        out.append(TorsoLayer(step.cells, step.labels, step.roots, step.dijkstra, None, froms))
    return out


def backtrack(layers: Sequence[TorsoLayer]) -> Chain | None:
    """The cheapest chain through ``layers``, its groups indices into each step's view (None when
    the last step has no finite label)."""

    def before(i: int, g: int, at: int) -> int:
        frm = layers[i].seed_from[int(layers[i].dijkstra[g])]
        assert frm is not None
        return int(frm[at])

    return walk(layers, before)


class TorsoProgram(GroupedProgram):
    """The priced program (module docstring) with the transfer rule applied where it binds: steps
    start merged per setting; a transfer whose pick and place (cell, setting) share no arm and grasp
    is grouped and the program solved again from its pick (with node costs every step is grouped).
    ``lazy`` is not supported (``loose`` stays empty); a chain's groups index its regions' groups."""

    def __init__(
        self, grid: tuple[FloatArray, BoolArray, float, Cell], linked: Sequence[bool], start_torso: float, term: Term
    ):
        super().__init__(linked)
        self.grid, self.start_torso, self.term = grid, start_torso, term
        self.layers: list[TorsoLayer] = []

    def merge(self, reg: Regions) -> Regions:
        return merged(reg)

    def solve(self, regions: Sequence[Regions], first: int = 0) -> Chain | None:
        """The cheapest chain over ``regions`` (of :func:`torso_regions`), the layers kept before step
        ``first``."""
        while True:
            view, linked = self.view(regions)
            before = self.before(linked)
            self.layers = forward(
                self.grid, self.start_torso, self.term, view, linked, self.layers, first, before, self.stop
            )
            self.views, self.linked_view = view, linked
            chain = backtrack(self.layers)
            if chain is None:
                return None
            groups, bad = _full_groups(chain, view, regions, self.linked)
            if not bad:
                return Chain(chain.cells, groups, chain.labels)
            first = self.group(bad)


def _full_groups(
    chain: Chain, view: Sequence[Regions], regions: Sequence[Regions], linked: Sequence[bool]
) -> tuple[list[int], list[int]]:
    """The chain's groups as indices into ``regions`` (a merged step: the first group of its setting
    holding the cell; a merged transfer: the first arm and grasp its pick and place share at their
    cells and settings), and the places where they share none."""
    n = len(chain.cells)
    groups, bad = [-1] * n, []
    for i in range(n - 1, -1, -1):
        if groups[i] >= 0:
            continue
        if view[i] is regions[i]:
            groups[i] = chain.groups[i]
            continue
        here = _at(regions[i], view[i], chain, i)
        if not (i > 0 and linked[i]):
            groups[i] = here[0]
            continue
        pick = {regions[i - 1].groups[k]: k for k in reversed(_at(regions[i - 1], view[i - 1], chain, i - 1))}
        shared = [k for k in here if regions[i].groups[k] in pick]
        if not shared:
            bad.append(i)
            groups[i], groups[i - 1] = here[0], 0
            continue
        groups[i], groups[i - 1] = shared[0], pick[regions[i].groups[shared[0]]]
    return groups, sorted(bad)


def _at(reg: Regions, view: Regions, chain: Chain, i: int) -> list[int]:
    """The groups of ``reg`` at the setting of the chain's step i (merged in ``view``) that hold its cell."""
    t = settings_of(view)[chain.groups[i]]
    sets = settings_of(reg)
    return [k for k in range(len(reg.groups)) if sets[k] == t and reg.has(k, chain.cells[i])]


__all__ = [
    "Term",
    "TorsoLayer",
    "TorsoProgram",
    "backtrack",
    "forward",
    "merged",
    "settings_of",
    "torso_regions",
    "torso_reweighted",
    "torso_term",
]
