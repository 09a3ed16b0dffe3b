"""IRMs after the base-feasible cells changed (obstacles added or removed): only the cells whose
allowed base yaws changed are touched, the rest of each map is kept.

A cell's IRM value depends on the cell, its allowed yaws, the map and the trajectory only, so
keeping the values of cells whose allowed yaws stayed the same, zeroing the cells that became
infeasible and evaluating the others gives exactly the maps a fresh computation would (tested
against one).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from placement.maps.rmap import ReachabilityMap
from placement.planning.arrays import YAW_INDEX, Float32Array, FloatArray, IntArray, YawIndexArray
from placement.planning.problems.manipulation import cells_within, manipulation_maps, pose_reach
from placement.planning.problems.option import Option
from placement.planning.world import World
from placement.scene.navgrid import Window


def _moved(src: Option, dst_window: Window, cells: IntArray, nx: int, value: Float32Array, yaw: YawIndexArray) -> None:
    """Copy ``src``'s values at flat ``cells`` into ``value``/``yaw`` over ``dst_window``."""
    iy, ix = np.divmod(cells, nx)
    value[iy - dst_window.y0, ix - dst_window.x0] = src.value[iy - src.window.y0, ix - src.window.x0]
    yaw[iy - dst_window.y0, ix - dst_window.x0] = src.yaw_index[iy - src.window.y0, ix - src.window.x0]


def refreshed_options(
    options: Sequence[Option],
    map_for: Callable[[str, float | None], ReachabilityMap],
    yaws: FloatArray,
    was: World,
    now: World,
) -> list[Option]:
    """``options`` of one step for the world ``now``, computed for the world ``was``; ``map_for(arm,
    torso)``: the map (view) of an arm at a torso value [m] (see :mod:`placement.planning.torso`).

    Options whose reach disc saw no change of allowed yaws are returned as they are (same objects), and
    so are those the gripper rules out (``Option.blocked``: they have no map).
    """
    nav = now.nav
    out = list(options)
    # same arm, torso and target: same cells
    groups: dict[tuple[str, float | None, float, float, float], list[int]] = {}
    for j, o in enumerate(options):
        if o.blocked is not None:
            continue
        target = o.candidate.poses[-1]
        key = (o.arm, o.torso, float(target[0, 3]), float(target[1, 3]), pose_reach(map_for(o.arm, o.torso), target))
        groups.setdefault(key, []).append(j)
    nx = nav.shape[1]
    for (arm, torso, x, y, r), members in groups.items():
        disc = cells_within(nav, x, y, r)
        before, after = was.yaw_masks(disc), now.yaw_masks(disc)
        same = np.all(before == after, axis=1)
        if same.all():
            continue
        feasible = now.feasible.flat[disc]
        window = Window.around(disc[feasible], nav.shape)
        kept, fresh = disc[feasible & same], disc[feasible & ~same]
        computed = (
            manipulation_maps(
                map_for(arm, torso),
                [options[j].candidate.poses for j in members],
                nav,
                yaws,
                fresh,
                window,
                after[feasible & ~same],
            )
            if fresh.size
            else None
        )
        for n, j in enumerate(members):
            o = options[j]
            value = np.zeros(window.shape, np.float32)
            yaw = np.full(window.shape, -1, YAW_INDEX)
            _moved(o, window, kept, nx, value, yaw)
            if computed is not None:
                fy, fx = np.divmod(fresh, nx)
                value[fy - window.y0, fx - window.x0] = computed[n][0][fy - window.y0, fx - window.x0]
                yaw[fy - window.y0, fx - window.x0] = computed[n][1][fy - window.y0, fx - window.x0]
            out[j] = Option(o.arm, o.candidate, window, value, yaw, o.out_of_range, o.torso)
    return out
