"""Independent checks of base placements against an occupancy map: plain geometry on its own cells."""

from __future__ import annotations

import math

import numpy as np


def footprint_on_map(planner, base) -> list[tuple[int, int]]:
    """Map cells (row, col) marked occupied (or unknown) whose centre lies inside the base's footprint
    polygon at ``base`` (x, y, yaw): plain geometry on the map's own cells."""
    occ = planner.scene.occupancy
    x, y, yaw = base
    poly = np.asarray(planner.robot.footprint, dtype=float)
    c, s = math.cos(yaw), math.sin(yaw)
    world = poly @ np.array([[c, s], [-s, c]]) + [x, y]
    r = occ.resolution
    lo, hi = world.min(axis=0), world.max(axis=0)
    c0, c1 = int((lo[0] - occ.origin[0]) / r) - 1, int((hi[0] - occ.origin[0]) / r) + 2
    r0, r1 = int((lo[1] - occ.origin[1]) / r) - 1, int((hi[1] - occ.origin[1]) / r) + 2
    hits = []
    for row in range(max(r0, 0), min(r1, occ.occupied.shape[0])):
        for col in range(max(c0, 0), min(c1, occ.occupied.shape[1])):
            if not occ.occupied[row, col]:
                continue
            px, py = occ.origin[0] + (col + 0.5) * r, occ.origin[1] + (row + 0.5) * r
            inside = True
            for k in range(len(world)):
                (ax, ay), (bx, by) = world[k], world[(k + 1) % len(world)]
                if (bx - ax) * (py - ay) - (by - ay) * (px - ax) < 0:
                    inside = False
                    break
            if inside:
                hits.append((row, col))
    return hits
