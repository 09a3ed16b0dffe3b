"""Base footprints: a polygon in the base frame (the Nav2 convention), or a circle.

A preset gives either ``footprint_radius`` [m] (a circle about the base frame's origin) or
``footprint: [[x, y], ...]`` [m], a simple polygon around that origin in the base frame (x forward,
y left). The polygon is stored counter-clockwise; its circumscribed and inscribed radii about the
origin bound it for quick tests (a base farther than the circumscribed radius from every obstacle
is clear at every yaw; one closer than the inscribed radius is blocked at every yaw).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from placement.simplicity import self_crossing
from placement.validation import Checker

#: Smallest footprint area accepted [m^2]: anything smaller is a units mistake (millimetres?).
MIN_AREA = 1e-3
#: Largest distance of a footprint point (and largest footprint_radius) from the base origin [m]: a
#: bigger base is a units mistake, and the planner's per-yaw tables grow with its square.
MAX_BASE_RADIUS = 10.0
#: Most footprint points: the planner tests every point at every yaw for every cell near an obstacle.
MAX_FOOTPRINT_VERTICES = 256


def signed_area(points: np.ndarray) -> float:
    """Shoelace area [m^2] of a polygon (k, 2), positive when counter-clockwise."""
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def first_self_crossing(points: np.ndarray) -> tuple[int, int] | None:
    """The first pair of edges (i, j) that touch or cross (other than neighbours at their shared
    vertex), or None for a simple polygon: an exact O(k log k) sweep (:mod:`placement.simplicity`)."""
    return self_crossing(points)


def contains_origin(points: np.ndarray) -> bool:
    """Whether the base frame's origin lies strictly inside the polygon (even-odd rule)."""
    inside = False
    k = len(points)
    for i in range(k):
        (x1, y1), (x2, y2) = points[i], points[(i + 1) % k]
        if (y1 > 0) != (y2 > 0) and 0 < x1 + (0 - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


def parse_footprint(c: Checker, value: Any, key: str) -> tuple[tuple[float, float], ...]:
    """A footprint polygon from a preset: >= 3 ``[x, y]`` points [m] in the base frame, simple, of
    area >= :data:`MIN_AREA`, around the base frame's origin; returned counter-clockwise."""
    items = c.sequence(value, key, minimum=3, what="[x, y] points [m]")
    if len(items) > MAX_FOOTPRINT_VERTICES:
        c.fail(
            key,
            f"{len(items)} points, more than the {MAX_FOOTPRINT_VERTICES} allowed (the planner tests every "
            "point at every base yaw): simplify the outline",
        )
    pts = np.array([c.vector(p, f"{key}[{i}]", 2, "numbers [x y] [m]") for i, p in enumerate(items)])
    far = np.flatnonzero(np.hypot(pts[:, 0], pts[:, 1]) > MAX_BASE_RADIUS)
    if len(far):
        i = int(far[0])
        c.fail(
            f"{key}[{i}]",
            f"the point {list(pts[i])} is more than {MAX_BASE_RADIUS:g} m from the base frame's "
            "origin; the footprint is in metres",
        )
    for i in range(len(pts)):
        if np.array_equal(pts[i], pts[i - 1]):
            c.fail(f"{key}[{i}]", f"repeats the point before it {[float(v) for v in pts[i]]}")
    crossing = first_self_crossing(pts)
    if crossing is not None:
        i, j = crossing
        c.fail(
            key,
            f"the polygon crosses itself (edge {i}-{(i + 1) % len(pts)} meets edge {j}-{(j + 1) % len(pts)}); "
            "list the corners in order around the base",
        )
    area = signed_area(pts)
    if abs(area) < MIN_AREA:
        c.fail(key, f"the polygon's area is {abs(area):.3g} m^2 (< {MIN_AREA:g}); the footprint is in metres")
    if not contains_origin(pts):
        c.fail(key, "the base frame's origin (0, 0) is not inside the polygon; the points are in the base frame")
    if area < 0:
        pts = pts[::-1]
    return tuple((float(x), float(y)) for x, y in pts)


def circumradius(points: npt.ArrayLike) -> float:
    """Largest distance [m] from the base origin to a footprint point (k, 2)."""
    p = np.asarray(points, dtype=float)
    return float(np.max(np.hypot(p[:, 0], p[:, 1])))


def inscribed_radius(points: npt.ArrayLike) -> float:
    """Smallest distance [m] from the base origin to the footprint's boundary (k, 2)."""
    p = np.asarray(points, dtype=float)
    best = math.inf
    for a, b in zip(p, np.roll(p, -1, axis=0)):
        d = b - a
        t = min(max(float(np.dot(-a, d) / np.dot(d, d)), 0.0), 1.0)
        best = min(best, float(np.hypot(*(a + t * d))))
    return best
