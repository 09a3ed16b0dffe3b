"""Whole-scene checks: things inside obstacles' volumes.

Obstacles are solids: a box from ``center.z - size.z/2`` to ``center.z + size.z/2``, a cylinder
likewise, a polygon a prism from the floor of unbounded height. An object's bounding box may touch
a solid (a cup standing on a table) but not enter it by more than :data:`TOLERANCE`; a place
location (a TCP target) may not lie inside one.
"""

from __future__ import annotations

import math

import numpy as np

from .model import Box, Cylinder, Polygon

TOLERANCE = 1e-3  # [m] penetration accepted as touching (rounding in generated or exported scenes)


def _z_range(shape) -> tuple[float, float]:
    if isinstance(shape, Box):
        return shape.center[2] - shape.size[2] / 2, shape.center[2] + shape.size[2] / 2
    if isinstance(shape, Cylinder):
        return shape.center[2] - shape.height / 2, shape.center[2] + shape.height / 2
    return 0.0, math.inf


def _inside_polygon(p, pts: np.ndarray) -> bool:
    """Even-odd rule for one point against (k, 2) vertices."""
    x, y = p
    inside = False
    for (x1, y1), (x2, y2) in zip(pts, np.roll(pts, -1, axis=0)):
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


def _segments_cross(a, b, c, d) -> bool:
    def orient(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    return orient(a, b, c) * orient(a, b, d) < 0 and orient(c, d, a) * orient(c, d, b) < 0


def _rect_overlaps(corners: np.ndarray, shape) -> bool:
    """Whether a (shrunk) footprint rectangle (4, 2), counter-clockwise, overlaps the shape's footprint."""
    if isinstance(shape, Cylinder):
        c = np.asarray(shape.center[:2])
        # distance from the centre to the rectangle: inside, or closer than the radius to an edge
        if _inside_polygon(c, corners):
            return True
        for a, b in zip(corners, np.roll(corners, -1, axis=0)):
            t = np.clip(np.dot(c - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
            if np.linalg.norm(a + t * (b - a) - c) < shape.radius:
                return True
        return False
    other = shape.corners_xy() if isinstance(shape, Box) else np.asarray(shape.points)
    if any(_inside_polygon(p, other) for p in corners) or any(_inside_polygon(p, corners) for p in other):
        return True
    edges = list(zip(other, np.roll(other, -1, axis=0)))
    return any(_segments_cross(a, b, c, d) for a, b in zip(corners, np.roll(corners, -1, axis=0)) for c, d in edges)


def _apart(a, b) -> bool:
    """Whether two (xmin, ymin, xmax, ymax) boxes are separated by more than :data:`TOLERANCE`."""
    return a[2] < b[0] - TOLERANCE or b[2] < a[0] - TOLERANCE or a[3] < b[1] - TOLERANCE or b[3] < a[1] - TOLERANCE


def box_penetrates(box: Box, shape) -> bool:
    """Whether ``box`` enters the solid ``shape`` by more than :data:`TOLERANCE` (touching is fine)."""
    if _apart(box.bounds_xy(), shape.bounds_xy()):
        return False
    lo, hi = _z_range(shape)
    if min(hi, box.center[2] + box.size[2] / 2) - max(lo, box.center[2] - box.size[2] / 2) <= TOLERANCE:
        return False
    shrunk = Box(box.center, np.maximum(np.asarray(box.size) - 2 * TOLERANCE, 1e-9), box.yaw)
    return _rect_overlaps(shrunk.corners_xy(), shape)


def point_inside(p, shape) -> bool:
    """Whether the point ``p`` (3,) [m] lies inside the solid ``shape``, deeper than :data:`TOLERANCE`."""
    if _apart((p[0], p[1], p[0], p[1]), shape.bounds_xy()):
        return False
    lo, hi = _z_range(shape)
    if not lo + TOLERANCE < p[2] < hi - TOLERANCE:
        return False
    if isinstance(shape, Cylinder):
        return math.hypot(p[0] - shape.center[0], p[1] - shape.center[1]) < shape.radius - TOLERANCE
    if isinstance(shape, Box):
        c, s = math.cos(shape.yaw), math.sin(shape.yaw)
        dx, dy = p[0] - shape.center[0], p[1] - shape.center[1]
        return (abs(c * dx + s * dy) < shape.size[0] / 2 - TOLERANCE
                and abs(-s * dx + c * dy) < shape.size[1] / 2 - TOLERANCE)
    assert isinstance(shape, Polygon)
    return _inside_polygon(p[:2], np.asarray(shape.points))
