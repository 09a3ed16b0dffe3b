"""Where the base may stand for each step: per (arm, grasp) group, the cells from which one of the
step's options keeps its arm's map threshold (the regions of the whole-task program, see
:mod:`placement.planning.program.forward`), and their node costs for ``optimal_manipulability_weight``."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from placement.planning.arrays import BoolArray, FloatArray
from placement.planning.context import PlanningContext
from placement.planning.problems import Option
from placement.planning.torso import start_torso

#: An (arm, grasp) pair: what a pick commits its place to.
Group = tuple[str, str | None]


@dataclass(frozen=True)
class Regions:
    """Where the base may stand for one step, per (arm, grasp) group.

    Attributes:
        groups: (G,) the groups, in a fixed order.
        masks: (G, ny, nx) bool, the cells of each group.
        node: (G, ny, nx) float [m] cost of standing there (added to the label), or None (all 0).
        settings: (G,) the torso setting [m or rad; a posture's index] each group's options hold, for
            the program that prices the torso (:mod:`placement.planning.program.priced_torso`: a group per
            (arm, grasp, setting), so a (arm, grasp) may repeat); None: any setting.
    """

    groups: tuple[Group, ...]
    masks: BoolArray
    node: FloatArray | None = None
    settings: tuple[float, ...] | None = None

    def union(self) -> BoolArray:
        """(ny, nx) bool: the cells of any group."""
        out: BoolArray = np.zeros(self.masks.shape[1:], bool)
        if len(self.groups):
            np.any(self.masks, axis=0, out=out)
        return out


def map_regions(ctx: PlanningContext, i: int, hold_lift: bool = False, held: float | None = None) -> Regions:
    """Step i's region by the maps: per (arm, grasp) group the cells where one of its options keeps
    the threshold (the cells the map-based methods may stand on), at any torso setting.

    ``hold_lift``: only the options at the torso value the robot starts with (the preset's) when
    they keep the threshold on some feasible cell, all settings otherwise: ``global``'s program does
    not price the lift's motion (a PR2's lift takes 24 s end to end), so it moves it only for a step
    the maps do not serve at the held value (``optimal`` prices it: :mod:`placement.planning.program.priced_torso`). ``held``: that value [m] already found
    by :func:`held_torso` (the options at it only; None: every setting).
    """
    if hold_lift:
        held = held_torso(ctx, i)
    opts = ctx.problems.options(i) if held is None else ctx.problems.held_options(i, held)
    return _regions(ctx.for_step(i), opts)


def held_torso(ctx: PlanningContext, i: int) -> float | None:
    """The torso value [m] the robot starts with if step i's options there keep the threshold on a
    feasible cell (the step is planned with the lift held there, see :func:`map_regions`), else None."""
    held = start_torso(ctx)
    if held is None:
        return None
    opts = ctx.problems.held_options(i, held)
    region = _regions(ctx.for_step(i), opts)
    return held if region.masks.any() else None


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
    groups = sorted({(o.arm, o.candidate.grasp) for o in opts}, key=lambda g: (g[0], str(g[1])))
    index = {g: k for k, g in enumerate(groups)}
    masks = np.zeros((len(groups), *nav.shape), dtype=bool)
    for o in opts:
        masks[index[(o.arm, o.candidate.grasp)]][o.window.slices] |= o.value >= ctx.threshold(o.arm, o.torso)
    masks &= ctx.world.feasible
    return Regions(tuple(groups), masks)


def reweighted(ctx: PlanningContext, i: int, reg: Regions) -> Regions:
    """``reg`` with the node cost ``optimal_manipulability_weight / m`` [m] per (group, cell) (m: the
    group's best map value there), or unchanged when the weight is 0."""
    weight = ctx.config.optimal_manipulability_weight
    if weight <= 0 or not reg.groups:
        return reg
    best = np.zeros(reg.masks.shape, np.float32)
    index = {gr: k for k, gr in enumerate(reg.groups)}
    for o in ctx.problems.options(i):
        k = index[(o.arm, o.candidate.grasp)]
        np.maximum(best[k][o.window.slices], o.value, out=best[k][o.window.slices])
    with np.errstate(divide="ignore"):
        node = np.where(reg.masks, weight / np.maximum(best, 1e-12), 0.0)
    return replace(reg, node=node)


__all__ = ["Group", "Regions", "held_torso", "map_regions", "reweighted"]
