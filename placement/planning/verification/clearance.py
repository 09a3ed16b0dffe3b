"""The exact clearance of a placed base footprint from the scene's obstacles, for checking plans.

The planner tests a polygon footprint against the cells that obstacles touch (conservative: it keeps
``footprint_padding`` from every touched square, hence from the obstacles); this is the independent
check of a plan's base poses against the obstacles' own outlines, in plain geometry: the footprint
polygon at the step's base pose against each obstacle's outline in the plane (a box's rectangle, a
polygon, a cylinder's circle), distance 0 when they overlap. A round base is the circle of its radius.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from placement.planning.arrays import FloatArray
from placement.planning.settings import PlannerConfig
from placement.robots import Robot
from placement.scene import Scene
from placement.scene.model import Box, Cylinder, Polygon, Shape

#: Points of a round base's outline (the polygon circumscribes the circle: distances are not larger).
CIRCLE_POINTS = 48


def _point_segment(p: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Distances [m] from points ``p`` (N, 2) to the segment a-b."""
    ab = b - a
    t = np.clip(((p - a) @ ab) / max(float(ab @ ab), 1e-300), 0.0, 1.0)
    out: FloatArray = np.linalg.norm(p - (a + t[:, None] * ab), axis=1)
    return out


def _crosses(a: FloatArray, b: FloatArray, c: FloatArray, d: FloatArray) -> bool:
    def side(o: FloatArray, p: FloatArray, q: FloatArray) -> float:
        return float((p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0]))

    return (side(a, b, c) > 0) != (side(a, b, d) > 0) and (side(c, d, a) > 0) != (side(c, d, b) > 0)


def _inside(p: FloatArray, poly: FloatArray) -> bool:
    """Whether point ``p`` (2,) lies inside the simple polygon ``poly`` (k, 2) (even-odd rule)."""
    x, y = float(p[0]), float(p[1])
    inside = False
    for (x1, y1), (x2, y2) in zip(poly, np.roll(poly, -1, axis=0)):
        if (y1 > y) != (y2 > y) and x < (x2 - x1) * (y - y1) / (y2 - y1) + x1:
            inside = not inside
    return inside


def polygon_distance(a: FloatArray, b: FloatArray) -> float:
    """Distance [m] between two simple polygons (k, 2) and (m, 2); 0 when they overlap."""
    if _inside(a[0], b) or _inside(b[0], a):
        return 0.0
    best = math.inf
    for p, q in zip(a, np.roll(a, -1, axis=0)):
        for r, s in zip(b, np.roll(b, -1, axis=0)):
            if _crosses(p, q, r, s):
                return 0.0
        best = min(best, float(np.min(_point_segment(b, p, q))))
    for r, s in zip(b, np.roll(b, -1, axis=0)):
        best = min(best, float(np.min(_point_segment(a, r, s))))
    return best


def outline(shape: Shape) -> tuple[FloatArray, float]:
    """An obstacle's outline in the plane: (polygon (k, 2) [m], radius [m] to add around it)."""
    if isinstance(shape, Box):
        c, s = math.cos(shape.yaw), math.sin(shape.yaw)
        hx, hy = float(shape.size[0]) / 2, float(shape.size[1]) / 2
        corners = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
        return corners @ np.array([[c, s], [-s, c]]) + np.asarray(shape.center[:2], dtype=float), 0.0
    if isinstance(shape, Cylinder):
        return np.asarray(shape.center[:2], dtype=float)[None, :], float(shape.radius)
    assert isinstance(shape, Polygon)
    return np.asarray(shape.points, dtype=float)[:, :2], 0.0


def footprint_at(robot: Robot, base: tuple[float, float, float]) -> tuple[FloatArray, float]:
    """The base's outline at ``base`` (x [m], y [m], yaw [rad]): (polygon (k, 2), radius around it)."""
    x, y, yaw = base
    if robot.footprint is None:
        return np.array([[x, y]]), float(robot.footprint_radius)
    c, s = math.cos(yaw), math.sin(yaw)
    return np.asarray(robot.footprint, dtype=float) @ np.array([[c, s], [-s, c]]) + [x, y], 0.0


def clearance(robot: Robot, scene: Scene, base: tuple[float, float, float]) -> tuple[float, str | None]:
    """(the least distance [m] from the base's footprint at ``base`` to an obstacle of ``scene``, that
    obstacle's name); (inf, None) without obstacles. 0 when they overlap."""
    foot, r0 = footprint_at(robot, base)
    best, name = math.inf, None
    for ob in scene.obstacles:
        poly, r1 = outline(ob.shape)
        if len(poly) == 1 and len(foot) == 1:
            d = float(np.linalg.norm(poly[0] - foot[0]))
        elif len(poly) == 1:
            d = (
                0.0
                if _inside(poly[0], foot)
                else float(min(np.min(_point_segment(poly, p, q)) for p, q in zip(foot, np.roll(foot, -1, axis=0))))
            )
        elif len(foot) == 1:
            d = (
                0.0
                if _inside(foot[0], poly)
                else float(min(np.min(_point_segment(foot, p, q)) for p, q in zip(poly, np.roll(poly, -1, axis=0))))
            )
        else:
            d = polygon_distance(foot, poly)
        d = max(d - r0 - r1, 0.0)
        if d < best:
            best, name = d, ob.name
    return best, name


def clearance_problems(
    robot: Robot, scene: Scene, bases: list[tuple[str, tuple[float, float, float]]], padding: float
) -> list[str]:
    """``where: the base footprint comes X cm from NAME`` for each (where, base pose) whose footprint
    keeps less than ``padding`` [m] (less 1 mm for rounding) from an obstacle of ``scene``."""
    out = []
    for where, base in bases:
        d, name = clearance(robot, scene, base)
        if d < padding - 1e-3:
            what = "overlaps" if d <= 0.0 else f"comes {d * 100:.1f} cm from"
            out.append(f"{where}: the base footprint {what} obstacle '{name}' (padding {padding:g} m)")
    return out


def scene_clearance(robot: Robot, scene: Scene, steps: Sequence[Any]) -> list[str]:
    """:func:`clearance_problems` of the planned ``steps`` (``StepResult``) of a plan of ``scene``:
    a polygon base keeps the scene's ``footprint_padding``, a round one its radius (which has its
    margin in it)."""
    padding = PlannerConfig.from_overrides(scene.planner, str(scene.source or scene.name)).footprint_padding
    bases = [(f"step {s.step} ({s.action} {s.target})", s.base) for s in steps if s.ok]
    return clearance_problems(robot, scene, bases, padding if robot.footprint is not None else 0.0)
