"""Rasterising a scene onto the navigation grid: occupancy, distance, base feasibility, speed."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import PlannerConfig
from .navgrid import NavGrid
from .navigation import distance_map, speed_factor
from .scene import Box, Cylinder, Polygon, Scene
from .scene.occupancy import rasterize_occupancy


def _inside_polygon(px: np.ndarray, py: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Even-odd rule for points (px, py) against polygon ``pts`` (k, 2)."""
    inside = np.zeros(px.shape, dtype=bool)
    k = len(pts)
    for i in range(k):
        x1, y1 = pts[i]
        x2, y2 = pts[(i + 1) % k]
        crosses = (y1 > py) != (y2 > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            xi = x1 + (py - y1) * (x2 - x1) / (y2 - y1)
        inside ^= crosses & (px < xi)
    return inside


def shape_mask(shape, nav: NavGrid) -> np.ndarray:
    """(ny, nx) bool: cells whose centre lies inside the shape's footprint."""
    xs, ys = nav.centres()
    X, Y = np.meshgrid(xs, ys)
    if isinstance(shape, Box):
        c, s = np.cos(shape.yaw), np.sin(shape.yaw)
        dx, dy = X - shape.center[0], Y - shape.center[1]
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        return (np.abs(lx) <= shape.size[0] / 2) & (np.abs(ly) <= shape.size[1] / 2)
    if isinstance(shape, Cylinder):
        return (X - shape.center[0]) ** 2 + (Y - shape.center[1]) ** 2 <= shape.radius ** 2
    if isinstance(shape, Polygon):
        return _inside_polygon(X, Y, np.asarray(shape.points))
    raise TypeError(f"unknown shape {type(shape).__name__}")


@dataclass(frozen=True)
class World:
    """The static navigation layers of a scene, all (ny, nx) over ``nav``.

    Attributes:
        nav: the grid. occupied: bool (obstacles, occupancy-map cells that are occupied or unknown,
        and with an occupancy map every cell outside it). distance: distance to the nearest occupied
        cell centre [m]. feasible: bool, base centre allowed (distance >= footprint radius).
        factor: slowdown of Eq. 4 (travel cost per metre, >= 1).
    """

    nav: NavGrid
    occupied: np.ndarray
    distance: np.ndarray
    feasible: np.ndarray
    factor: np.ndarray


def build_world(scene: Scene, footprint_radius: float, config: PlannerConfig) -> World:
    """Occupancy from the scene's obstacles (and occupancy map), then distance, feasibility, speed.

    ``footprint_radius`` [m]; the velocity model's parameters come from ``config``.
    """
    nav = scene.nav_grid()
    occ = np.zeros(nav.shape, dtype=bool)
    for ob in scene.obstacles:
        occ |= shape_mask(ob.shape, nav)
    if scene.occupancy is not None:
        occ |= rasterize_occupancy(scene.occupancy, nav.origin, nav.resolution, nav.shape, conservative=True,
                                   outside_occupied=True)
    dist = distance_map(occ, nav.resolution)
    feasible = dist >= footprint_radius
    factor = speed_factor(dist, config.velocity_lambda, config.velocity_k, config.d_max)
    return World(nav, occ, dist, feasible, factor)
