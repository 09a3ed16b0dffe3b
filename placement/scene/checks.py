"""Whole-scene checks: things inside obstacles' volumes.

Obstacles are solids: a box from ``center.z - size.z/2`` to ``center.z + size.z/2``, a cylinder
likewise, a polygon a prism from the floor of unbounded height. Each is a vertical prism over its
footprint, so a tilted (6D) object box meets it exactly where the part of the box within the
prism's height range, seen from above, meets the footprint. An object's bounding box may touch
a solid (a cup standing on a table) but not enter it by more than :data:`TOLERANCE`; a place
location (a TCP target) may not lie inside one.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence

import numpy as np
import numpy.typing as npt

from placement.scene.model import Box, Cylinder, Obstacle, Polygon, SceneObject, Shape
from placement.scene.poses import BOX_EDGES, box_corners

TOLERANCE = 1e-3  # [m] penetration accepted as touching (rounding in generated or exported scenes)

#: a point or an (xmin, ymin, xmax, ymax) box [m]
Coords = Sequence[float] | npt.NDArray[np.float64]


def _z_range(shape: Shape) -> tuple[float, float]:
    if isinstance(shape, Box):
        return shape.center[2] - shape.size[2] / 2, shape.center[2] + shape.size[2] / 2
    if isinstance(shape, Cylinder):
        return shape.center[2] - shape.height / 2, shape.center[2] + shape.height / 2
    return 0.0, math.inf


def _inside_polygon(p: Coords, pts: npt.NDArray[np.float64]) -> bool:
    """Even-odd rule for one point against (k, 2) vertices."""
    x, y = p
    inside = False
    for (x1, y1), (x2, y2) in zip(pts, np.roll(pts, -1, axis=0)):
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


def _segments_cross(a: Coords, b: Coords, c: Coords, d: Coords) -> bool:
    def orient(p: Coords, q: Coords, r: Coords) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    return bool(orient(a, b, c) * orient(a, b, d) < 0 and orient(c, d, a) * orient(c, d, b) < 0)


def _rect_overlaps(corners: npt.NDArray[np.float64], shape: Shape) -> bool:
    """Whether a (shrunk) convex footprint (k, 2), counter-clockwise, overlaps the shape's footprint."""
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


def _apart(a: Coords, b: Coords) -> bool:
    """Whether two (xmin, ymin, xmax, ymax) boxes are separated by more than :data:`TOLERANCE`."""
    return bool(
        a[2] < b[0] - TOLERANCE or b[2] < a[0] - TOLERANCE or a[3] < b[1] - TOLERANCE or b[3] < a[1] - TOLERANCE
    )


def obstacles_near(obstacles: Sequence[Obstacle]) -> Callable[[Coords], list[Obstacle]]:
    """A function of (xmin, ymin, xmax, ymax) giving the obstacles whose footprint bounds are not
    :func:`_apart` from it, in file order: one numpy pass over all bounds instead of a Python loop."""
    b = np.array([o.shape.bounds_xy() for o in obstacles], dtype=float).reshape(-1, 4)

    def near(a: Coords) -> list[Obstacle]:
        apart = (
            (a[2] < b[:, 0] - TOLERANCE)
            | (b[:, 2] < a[0] - TOLERANCE)
            | (a[3] < b[:, 1] - TOLERANCE)
            | (b[:, 3] < a[1] - TOLERANCE)
        )
        return [obstacles[int(k)] for k in np.flatnonzero(~apart)]

    return near


def box_penetrates(box: Box, shape: Shape) -> bool:
    """Whether ``box`` enters the solid ``shape`` by more than :data:`TOLERANCE` (touching is fine)."""
    if _apart(box.bounds_xy(), shape.bounds_xy()):
        return False
    lo, hi = _z_range(shape)
    if min(hi, box.center[2] + box.size[2] / 2) - max(lo, box.center[2] - box.size[2] / 2) <= TOLERANCE:
        return False
    shrunk = Box(box.center, np.maximum(np.asarray(box.size) - 2 * TOLERANCE, 1e-9), box.yaw)
    return _rect_overlaps(shrunk.corners_xy(), shape)


def _hull_xy(points: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """(k, 2) convex hull of the xy of ``points`` (n, >= 2), counter-clockwise (monotone chain)."""
    pts = sorted({(float(x), float(y)) for x, y in np.asarray(points)[:, :2]})
    if len(pts) < 3:
        return np.array(pts)

    def half(seq: Iterable[tuple[float, float]]) -> list[tuple[float, float]]:
        out: list[tuple[float, float]] = []
        for q in seq:
            while (
                len(out) >= 2
                and ((out[-1][0] - out[-2][0]) * (q[1] - out[-2][1]) - (out[-1][1] - out[-2][1]) * (q[0] - out[-2][0]))
                <= 0
            ):
                out.pop()
            out.append(q)
        return out[:-1]

    return np.array(half(pts) + half(reversed(pts)))


def object_penetrates(o: SceneObject, shape: Shape) -> bool:
    """Whether the bounding box of ``o`` (any orientation) enters the solid ``shape`` by more than
    :data:`TOLERANCE`; an upright object is checked exactly as :func:`box_penetrates` does."""
    if o.upright:
        return box_penetrates(o.box, shape)
    if _apart(o.bounds_xy(), shape.bounds_xy()):
        return False
    lo, hi = _z_range(shape)
    corners = box_corners(o.pose, np.maximum(np.asarray(o.size) - 2 * TOLERANCE, 1e-9))
    # the shrunk box cut to the slab lo <= z <= hi: its corners inside, its edges crossing a plane
    pts = [c for c in corners if lo <= c[2] <= hi]
    for i, j in BOX_EDGES:
        a, b = corners[i], corners[j]
        for plane in (lo, hi):
            if math.isfinite(plane) and (a[2] - plane) * (b[2] - plane) < 0:
                pts.append(a + (plane - a[2]) / (b[2] - a[2]) * (b - a))
    if len(pts) < 3:
        return False
    hull = _hull_xy(np.array(pts))
    return len(hull) >= 3 and _rect_overlaps(hull, shape)


def point_inside(p: Coords, shape: Shape) -> bool:
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
        return bool(
            abs(c * dx + s * dy) < shape.size[0] / 2 - TOLERANCE
            and abs(-s * dx + c * dy) < shape.size[1] / 2 - TOLERANCE
        )
    assert isinstance(shape, Polygon)
    return _inside_polygon(p[:2], np.asarray(shape.points))


def _obb_overlap(
    pa: npt.NDArray[np.float64], ha: npt.NDArray[np.float64], pb: npt.NDArray[np.float64], hb: npt.NDArray[np.float64]
) -> bool:
    """Whether two oriented boxes (poses (4, 4), half sizes (3,)) overlap: no separating axis among
    the 15 candidates (faces of each, cross products of edges; Gottschalk's test)."""
    A, B = pa[:3, :3], pb[:3, :3]
    R = A.T @ B
    t = A.T @ (pb[:3, 3] - pa[:3, 3])
    Ra = np.abs(R) + 1e-12  # parallel edges: their cross product is near zero, never a false separation
    for i in range(3):
        if abs(t[i]) > ha[i] + hb @ Ra[i]:
            return False
    for j in range(3):
        if abs(t @ R[:, j]) > ha @ Ra[:, j] + hb[j]:
            return False
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            ra = ha[i1] * Ra[i2, j] + ha[i2] * Ra[i1, j]
            rb = hb[j1] * Ra[i, j2] + hb[j2] * Ra[i, j1]
            if abs(t[i2] * R[i1, j] - t[i1] * R[i2, j]) > ra + rb:
                return False
    return True


def overlapping_objects(objects: Sequence[SceneObject], moved: set[str] | None = None) -> tuple[int, int] | None:
    """The first pair (i, j), i < j, of ``objects`` whose bounding boxes overlap by more than
    :data:`TOLERANCE` (each box shrunk by half of it on every side, so touching and stacking are
    fine), or None. ``moved``: only pairs with one of these names (None: all pairs). Boxes whose
    axis-aligned bounds are apart are skipped at once (n^2 / 2 comparisons in numpy, then the exact
    oriented-box test on the few pairs left)."""
    n = len(objects)
    if n < 2:
        return None
    half = [np.maximum(np.asarray(o.size) / 2 - TOLERANCE / 2, 0.0) for o in objects]
    poses = [o.pose for o in objects]
    lo = np.empty((n, 3))
    hi = np.empty((n, 3))
    for k, (pose, h) in enumerate(zip(poses, half)):
        ext = np.abs(pose[:3, :3]) @ h
        lo[k], hi[k] = pose[:3, 3] - ext, pose[:3, 3] + ext
    near = np.all((lo[:, None, :] < hi[None, :, :]) & (lo[None, :, :] < hi[:, None, :]), axis=2)
    near = np.triu(near, 1)
    if moved is not None:
        mask = np.array([o.name in moved for o in objects])
        near &= mask[:, None] | mask[None, :]
    for i, j in zip(*np.nonzero(near)):
        if _obb_overlap(poses[i], half[i], poses[j], half[j]):
            return int(i), int(j)
    return None
