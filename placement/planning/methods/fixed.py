"""The ``fixed`` baseline: pre-defined placements at the free sides of each table, facing it."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ...errors import PlacementError
from ..manipulation import manipulation_map
from ..navgrid import Window
from ..option import Option
from ..ranking import Ranked

if TYPE_CHECKING:
    from ..planner import Planner


def fixed_placements(planner: Planner) -> list[tuple[int, float]]:
    """(flat cell, yaw [rad]) centred on each side of each ``table: true`` obstacle, facing it, the base
    centre ``footprint_radius + fixed_margin`` [m] from the side; sides whose cell is not base-feasible
    are left out."""
    out = []
    nav, feasible = planner.world.nav, planner.world.feasible
    standoff = planner.robot.footprint_radius + planner.config.fixed_margin
    for ob in planner.scene.tables:
        sh = ob.shape
        if hasattr(sh, "size"):
            c, s_ = math.cos(sh.yaw), math.sin(sh.yaw)
            half = (sh.size[0] / 2, sh.size[1] / 2)
            sides = [((c, s_), half[0]), ((-c, -s_), half[0]), ((-s_, c), half[1]), ((s_, -c), half[1])]
        else:  # cylinder: four sides along the world axes
            sides = [((1.0, 0.0), sh.radius), ((-1.0, 0.0), sh.radius), ((0.0, 1.0), sh.radius),
                     ((0.0, -1.0), sh.radius)]
        for (nx_, ny_), h in sides:
            x = sh.center[0] + nx_ * (h + standoff)
            y = sh.center[1] + ny_ * (h + standoff)
            try:
                iy, ix = nav.cell(x, y)
            except PlacementError:
                continue
            if feasible[iy, ix]:
                out.append((iy * nav.shape[1] + ix, math.atan2(-ny_, -nx_)))
    return out


def rank_fixed(planner: Planner, options: list[Option], nav_cost: np.ndarray,
               heuristic: np.ndarray) -> list[Ranked]:
    """Fixed placements by decreasing manipulability of each (arm, candidate) at the placement's yaw
    (``cost`` = minus that value)."""
    nav = planner.world.nav
    ranked = []
    for flat, yaw in fixed_placements(planner):
        for k, o in enumerate(options):
            cell = np.array([flat])
            v, _ = manipulation_map(planner.maps[o.arm], o.candidate.poses, nav, np.array([yaw]), cell,
                                    Window.around(cell, nav.shape, margin=0))
            value = float(v[0, 0])
            if value >= planner.config.threshold:
                ranked.append((-value, k, flat, yaw))
    ranked.sort(key=lambda r: (r[0], r[1], r[2]))
    return [Ranked(*r) for r in ranked]
