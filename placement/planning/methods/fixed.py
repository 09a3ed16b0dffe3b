"""The ``fixed`` baseline: pre-defined placements at the free sides of each table, facing it."""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence

import numpy as np

from placement.errors import PlacementError
from placement.maps.rmap import ReachabilityMap
from placement.planning.arrays import FloatArray
from placement.planning.context import PlanningContext
from placement.planning.methods.ranking import Ranked
from placement.planning.methods.stepwise import StepwiseMethod
from placement.planning.problems import Option, manipulation_maps
from placement.planning.program import Regions
from placement.planning.torso import option_map
from placement.scene import Box, Cylinder
from placement.scene.navgrid import Window

#: id of a world (the scene on the grid) -> (the world, weakly; (fixed_margin, fixed_steps_out) -> its
#: fixed placements), so that every step and the certificate share one computation
_PLACEMENTS: dict[int, tuple[weakref.ref[object], dict[tuple[float, int], list[tuple[int, float]]]]] = {}


def fixed_placements(ctx: PlanningContext) -> list[tuple[int, float]]:
    """:func:`placements_of` ``ctx``, computed once per world and settings."""
    for k in [k for k, (ref, _) in _PLACEMENTS.items() if ref() is None]:
        del _PLACEMENTS[k]
    entry = _PLACEMENTS.get(id(ctx.world))
    if entry is None or entry[0]() is not ctx.world:
        entry = _PLACEMENTS[id(ctx.world)] = (weakref.ref(ctx.world), {})
    key = (float(ctx.config.fixed_margin), int(ctx.config.fixed_steps_out))
    if key not in entry[1]:
        entry[1][key] = placements_of(ctx)
    return list(entry[1][key])


def placements_of(ctx: PlanningContext) -> list[tuple[int, float]]:
    """(flat cell, yaw [rad]) centred on each side of each ``table: true`` obstacle, facing it, the base
    centre the footprint's half-depth (a round base's radius) plus ``fixed_margin`` [m] from the side.

    A round base takes the cell there if it is feasible. A polygon base takes the first cell, from
    there outwards along the side's normal (up to ``fixed_steps_out`` cells further), whose centre
    it fits on at the facing yaw. Sides without such a cell are left out."""
    out = []
    world = ctx.world
    nav = world.nav
    polygon = ctx.robot.footprint is not None
    standoff = world.base.half_depth() + ctx.config.fixed_margin
    xs, ys = nav.centres()
    for ob in ctx.scene.tables:
        sh = ob.shape
        sides: list[tuple[tuple[float, float], float]]
        if isinstance(sh, Box):
            c, s_ = math.cos(sh.yaw), math.sin(sh.yaw)
            half = (float(sh.size[0]) / 2, float(sh.size[1]) / 2)
            sides = [((c, s_), half[0]), ((-c, -s_), half[0]), ((-s_, c), half[1]), ((s_, -c), half[1])]
        elif isinstance(sh, Cylinder):  # four sides along the world axes
            r = float(sh.radius)
            sides = [((1.0, 0.0), r), ((-1.0, 0.0), r), ((0.0, 1.0), r), ((0.0, -1.0), r)]
        else:  # the scene parser allows tables of boxes and cylinders only
            continue
        for (nx_, ny_), h in sides:
            yaw = math.atan2(-ny_, -nx_)
            for step in range(ctx.config.fixed_steps_out + 1 if polygon else 1):
                d = h + standoff + step * nav.resolution
                try:
                    iy, ix = nav.cell(float(sh.center[0]) + nx_ * d, float(sh.center[1]) + ny_ * d)
                except PlacementError:
                    break
                if world.feasible[iy, ix] and (not polygon or world.pose_clear(float(xs[ix]), float(ys[iy]), yaw)):
                    out.append((iy * nav.shape[1] + ix, yaw))
                    break
    return out


def rank_fixed(ctx: PlanningContext, options: Sequence[Option]) -> list[Ranked]:
    """Fixed placements by decreasing manipulability of each (arm, candidate) at the placement's yaw
    (``cost`` = minus that value).

    the paper's baseline chooses "the one with the best manipulability that reaches the grasp": every fixed placement
    the map marks reached (value > 0) is ranked, and IK decides which reaches. The map threshold is
    not applied here: it prunes the continuous search of the other methods, but a fixed placement at a
    table's side is often at the edge of reach, where the manipulability is low (at 5 cm cells the
    PR2's placements 0.75 m from a 0.69 m table's centre score 0.014-0.016 against its threshold's
    0.0235, and IK reaches them)."""
    placements = fixed_placements(ctx)
    values = placement_values(ctx, options, placements)
    ranked = []
    for flat, yaw in placements:
        for k in range(len(options)):
            value = values.get((k, flat, yaw), 0.0)
            if value > 0.0:
                ranked.append((-value, k, flat, yaw))
    ranked.sort(key=lambda r: (r[0], r[1], r[2]))
    return [Ranked(*r) for r in ranked]


def placement_values(
    ctx: PlanningContext, options: Sequence[Option], placements: Sequence[tuple[int, float]]
) -> dict[tuple[int, int, float], float]:
    """(option index, flat cell, yaw [rad]) -> the option's map value with the base there at that yaw
    (dimensionless), for every placement: one pass per (map, yaw) over every option of that map and
    every placement at that yaw (the value of each is the same as its own evaluation's); options the
    gripper rules out (``Option.blocked``) are left out."""
    nav = ctx.world.nav
    by_yaw: dict[float, list[int]] = {}
    for flat, yaw in placements:
        by_yaw.setdefault(yaw, []).append(flat)
    by_map: dict[int, tuple[ReachabilityMap, list[int]]] = {}
    for k, o in enumerate(options):
        if o.blocked is not None:  # the gripper alone collides there: 0 at every placement
            continue
        rmap = option_map(ctx, o)
        by_map.setdefault(id(rmap), (rmap, []))[1].append(k)
    out: dict[tuple[int, int, float], float] = {}
    for yaw, flats in by_yaw.items():
        cells = np.array(sorted(set(flats)), dtype=np.int64)
        window = Window.around(cells, nav.shape, margin=0)
        iy, ix = np.divmod(cells, nav.shape[1])
        for rmap, ks in by_map.values():
            irms = manipulation_maps(
                rmap, [options[k].candidate.poses for k in ks], nav, np.array([yaw]), cells, window
            )
            for k, (v, _) in zip(ks, irms):
                for flat, y, x in zip(cells.tolist(), iy.tolist(), ix.tolist()):
                    out[k, flat, yaw] = float(v[y - window.y0, x - window.x0])
    return out


def fixed_regions(ctx: PlanningContext, i: int) -> Regions:
    """Step i's pre-defined placements that :func:`rank_fixed` ranks, per (arm, grasp) group."""
    opts = ctx.problems.options(i)
    groups = sorted({(o.arm, o.candidate.grasp) for o in opts}, key=lambda g: (g[0], str(g[1])))
    index = {g: k for k, g in enumerate(groups)}
    masks = np.zeros((len(groups), *ctx.world.nav.shape), dtype=bool)
    for r in rank_fixed(ctx, opts):
        o = opts[r.option]
        masks[index[(o.arm, o.candidate.grasp)]].flat[r.cell] = True
    return Regions.of(tuple(groups), masks)


class Fixed(StepwiseMethod):
    """The baseline: the pre-defined placements beside the tables, by manipulability (no weights)."""

    name = "fixed"
    uses_heuristic = False
    uses_navigation = False
    ranks_fixed_placements = True
    region_kind = "fixed placements"

    def regions(self, ctx: PlanningContext, i: int) -> Regions:
        return fixed_regions(ctx, i)

    def prefetch_regions(self, ctx: PlanningContext, i: int) -> None:
        return None  # its placements need no kernel pass

    def rank(
        self, ctx: PlanningContext, options: Sequence[Option], nav_cost: FloatArray, heuristic: FloatArray
    ) -> list[Ranked]:
        return rank_fixed(ctx, options)


__all__ = ["Fixed", "fixed_placements", "fixed_regions", "placement_values", "placements_of", "rank_fixed"]
