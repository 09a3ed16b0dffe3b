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
    out = np.zeros(nav.shape, dtype=bool)
    add_shape(out, shape, nav)
    return out


def shape_window(shape, nav: NavGrid) -> tuple[int, int, int, int]:
    """Rows j0..j1-1 and columns i0..i1-1 (j0, j1, i0, i1) holding every cell whose centre can lie in
    the shape's footprint: its bounding box plus one cell, clipped to the grid."""
    x0, y0, x1, y1 = shape.bounds_xy()
    r = nav.resolution
    i0 = max(int(np.floor((x0 - nav.origin[0]) / r)) - 1, 0)
    i1 = min(int(np.ceil((x1 - nav.origin[0]) / r)) + 1, nav.shape[1])
    j0 = max(int(np.floor((y0 - nav.origin[1]) / r)) - 1, 0)
    j1 = min(int(np.ceil((y1 - nav.origin[1]) / r)) + 1, nav.shape[0])
    return j0, j1, i0, i1


def changed_occupancy(occupied: np.ndarray, nav: NavGrid, removed: list, kept: list, added: list) -> np.ndarray:
    """The occupancy after obstacles changed, from the old one (no occupancy map involved): the cells
    of removed shapes are cleared and every kept shape that reaches them is drawn again, then the
    added shapes are drawn; the same grid as rasterising everything anew."""
    out = occupied.copy()
    windows = [shape_window(ob.shape, nav) for ob in removed]
    for j0, j1, i0, i1 in windows:
        out[j0:j1, i0:i1] = False
    for ob in kept:
        a0, a1, b0, b1 = shape_window(ob.shape, nav)
        if any(a0 < j1 and j0 < a1 and b0 < i1 and i0 < b1 for j0, j1, i0, i1 in windows):
            add_shape(out, ob.shape, nav)
    for ob in added:
        add_shape(out, ob.shape, nav)
    return out


def add_shape(occupied: np.ndarray, shape, nav: NavGrid) -> None:
    """Mark in ``occupied`` (ny, nx) the cells whose centre lies inside the shape's footprint.

    Only the cells of the footprint's bounding box (plus one) are tested: the same decisions as
    testing every cell, at the cost of the shape's size rather than the grid's.
    """
    xs, ys = nav.centres()
    j0, j1, i0, i1 = shape_window(shape, nav)
    if i0 >= i1 or j0 >= j1:
        return
    X, Y = np.meshgrid(xs[i0:i1], ys[j0:j1])
    if isinstance(shape, Box):
        c, s = np.cos(shape.yaw), np.sin(shape.yaw)
        dx, dy = X - shape.center[0], Y - shape.center[1]
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        inside = (np.abs(lx) <= shape.size[0] / 2) & (np.abs(ly) <= shape.size[1] / 2)
    elif isinstance(shape, Cylinder):
        inside = (X - shape.center[0]) ** 2 + (Y - shape.center[1]) ** 2 <= shape.radius ** 2
    elif isinstance(shape, Polygon):
        inside = _inside_polygon(X, Y, np.asarray(shape.points))
    else:
        raise TypeError(f"unknown shape {type(shape).__name__}")
    occupied[j0:j1, i0:i1] |= inside


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
        add_shape(occ, ob.shape, nav)
    if scene.occupancy is not None:
        occ |= rasterize_occupancy(scene.occupancy, nav.origin, nav.resolution, nav.shape, conservative=True,
                                   outside_occupied=True)
    return world_from_occupancy(nav, occ, footprint_radius, config)


def world_from_occupancy(nav: NavGrid, occ: np.ndarray, footprint_radius: float, config: PlannerConfig) -> World:
    """Distance, feasibility and speed from an occupancy grid (ny, nx) bool."""
    dist = distance_map(occ, nav.resolution)
    feasible = dist >= footprint_radius
    factor = speed_factor(dist, config.velocity_lambda, config.velocity_k, config.d_max)
    return World(nav, occ, dist, feasible, factor)
