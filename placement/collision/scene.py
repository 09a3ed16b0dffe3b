"""The scene as coal collision objects in the world frame (z up, metres).

* Boxes (obstacles, tables, objects' bounding boxes): ``coal.Box`` at their centre, turned by ``yaw``, or
  by a 6D pose when the thing has a ``pose`` (4, 4) or an ``orientation`` (4,) ``[x, y, z, w]``.
* Vertical cylinders: ``coal.Cylinder`` (its axis is z).
* Polygons (prisms from the floor, unbounded in height in the scene model): :data:`PRISM_HEIGHT` tall;
  a non-convex polygon is cut into triangles (ear clipping), each a convex prism, so a robot shape
  wholly inside the prism still collides (a mesh would only have a surface).
* Occupancy maps: each occupied (or unknown) cell is a box of :data:`PRISM_HEIGHT` from the floor, made
  only for the cells near the robot (see :class:`OccupancyCells`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import coal
import numpy as np

from ..errors import PlacementError

#: Height [m] given to polygon prisms and occupancy cells (unbounded in the scene model).
PRISM_HEIGHT = 3.0


@dataclass(frozen=True, eq=False)
class SceneShape:
    """One convex piece of a scene thing: ``name`` (the obstacle's or object's), coal ``geometry``,
    ``pose`` (4, 4) in the world, ``aabb`` (2, 3) world-frame (min, max) corners [m]."""

    name: str
    geometry: coal.CollisionGeometry
    pose: np.ndarray
    aabb: np.ndarray


def pose_of(thing, centre, yaw: float) -> np.ndarray:
    """(4, 4) pose of a box-like thing: its ``pose``, else ``orientation`` [x, y, z, w] at ``centre``,
    else ``yaw`` about z at ``centre`` [m, rad]."""
    T = getattr(thing, "pose", None)
    if T is not None:
        return np.asarray(T, dtype=float).reshape(4, 4)
    out = np.eye(4)
    out[:3, 3] = np.asarray(centre, dtype=float)
    quat = getattr(thing, "orientation", None)
    if quat is not None:
        x, y, z, w = (float(v) for v in quat)
        out[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                       [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                       [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    else:
        c, s = math.cos(yaw), math.sin(yaw)
        out[:2, :2] = [[c, -s], [s, c]]
    return out


def box_aabb(pose: np.ndarray, size) -> np.ndarray:
    """(2, 3) world AABB of a box of full ``size`` (3,) at ``pose`` (4, 4)."""
    half = np.abs(pose[:3, :3]) @ (np.asarray(size, dtype=float) / 2)
    return np.array([pose[:3, 3] - half, pose[:3, 3] + half])


def box_shape(name: str, thing, centre, size, yaw: float) -> SceneShape:
    pose = pose_of(thing, centre, yaw)
    return SceneShape(name, coal.Box(*(float(v) for v in size)), pose, box_aabb(pose, size))


def cylinder_shape(name: str, centre, radius: float, height: float) -> SceneShape:
    pose = np.eye(4)
    pose[:3, 3] = centre
    half = np.array([radius, radius, height / 2])
    return SceneShape(name, coal.Cylinder(float(radius), float(height)), pose,
                      np.array([pose[:3, 3] - half, pose[:3, 3] + half]))


def signed_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def is_convex(points: np.ndarray) -> bool:
    """True if the counter-clockwise polygon ``points`` (k, 2) turns left (or straight) at every vertex."""
    d = np.roll(points, -1, axis=0) - points
    cross = d[:, 0] * np.roll(d[:, 1], -1) - d[:, 1] * np.roll(d[:, 0], -1)
    return bool(np.all(cross >= -1e-12))


def triangulate(points: np.ndarray) -> list[np.ndarray]:
    """Ear-clipping triangulation of a simple polygon (k, 2) -> list of (3, 2) triangles."""
    pts = [np.asarray(p, dtype=float) for p in points]
    if signed_area(np.array(pts)) < 0:
        pts.reverse()
    out, guard = [], 0
    while len(pts) > 3 and guard < 10_000:
        guard += 1
        n = len(pts)
        for i in range(n):
            a, b, c = pts[i - 1], pts[i], pts[(i + 1) % n]
            if (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) <= 1e-15:
                continue  # reflex or straight vertex: not an ear
            corners = {(i - 1) % n, i, (i + 1) % n}
            if any(inside_triangle(p, a, b, c) for k, p in enumerate(pts) if k not in corners):
                continue
            out.append(np.array([a, b, c]))
            del pts[i]
            break
        else:  # no ear: degenerate input; fall back to a fan so that the area is still covered
            break
    out += [np.array([pts[0], pts[k], pts[k + 1]]) for k in range(1, len(pts) - 1)]
    return out


def inside_triangle(p, a, b, c) -> bool:
    def side(u, v, w):
        return (v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0])

    return side(a, b, p) >= 0 and side(b, c, p) >= 0 and side(c, a, p) >= 0


def prism(points: np.ndarray, height: float) -> coal.ConvexBase:
    """A convex prism over the convex polygon ``points`` (k, 2), z from 0 to ``height``."""
    verts = coal.StdVec_Vec3s()
    verts.extend([np.array([x, y, z]) for z in (0.0, height) for x, y in points])
    return coal.Convex.convexHull(verts, False, None)


def polygon_shapes(name: str, points, height: float = PRISM_HEIGHT) -> list[SceneShape]:
    """Convex prisms covering the polygon prism ``points`` (k, 2) [m], ``height`` [m] tall."""
    points = np.asarray(points, dtype=float)
    if signed_area(points) < 0:
        points = points[::-1]
    pieces = [points] if is_convex(points) else triangulate(points)
    out = []
    for piece in pieces:
        aabb = np.array([[*piece.min(axis=0), 0.0], [*piece.max(axis=0), height]])
        out.append(SceneShape(name, prism(piece, height), np.eye(4), aabb))
    return out


def obstacle_shapes(name: str, shape) -> list[SceneShape]:
    """The convex pieces of one obstacle shape (Box, Cylinder or Polygon of the scene model)."""
    if hasattr(shape, "points"):
        return polygon_shapes(name, shape.points)
    if hasattr(shape, "radius"):
        return [cylinder_shape(name, shape.center, shape.radius, shape.height)]
    if hasattr(shape, "size"):
        return [box_shape(name, shape, shape.center, shape.size, getattr(shape, "yaw", 0.0))]
    raise PlacementError(f"obstacle '{name}': shape {type(shape).__name__} is not supported by the collision "
                         "check (box, cylinder, polygon)")


def scene_shapes(scene) -> list[SceneShape]:
    """Every obstacle (tables included) and object of ``scene`` as convex pieces, in file order."""
    out = []
    for ob in scene.obstacles:
        out += obstacle_shapes(ob.name, ob.shape)
    for obj in scene.objects:
        out.append(box_shape(obj.name, obj, obj.position, obj.size, obj.yaw))
    return out


class OccupancyCells:
    """The occupied cells of an occupancy map as boxes ``resolution`` x ``resolution`` x :data:`PRISM_HEIGHT`.

    A map has up to millions of cells: :meth:`near` returns only the occupied cells in a window (the
    robot's reach), all sharing one coal box.
    """

    def __init__(self, occupancy, height: float = PRISM_HEIGHT):
        self.occupied = np.asarray(occupancy.occupied, dtype=bool)
        self.resolution = float(occupancy.resolution)
        self.origin = (float(occupancy.origin[0]), float(occupancy.origin[1]))
        self.height = float(height)
        self.geometry = coal.Box(self.resolution, self.resolution, self.height)

    def near(self, xmin: float, ymin: float, xmax: float, ymax: float) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) of the occupied cells overlapping the window [m] (world frame)."""
        res, (ox, oy) = self.resolution, self.origin
        rows, cols = self.occupied.shape
        c0, c1 = max(0, math.floor((xmin - ox) / res)), min(cols, math.ceil((xmax - ox) / res))
        r0, r1 = max(0, math.floor((ymin - oy) / res)), min(rows, math.ceil((ymax - oy) / res))
        if c0 >= c1 or r0 >= r1:
            return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
        r, c = np.nonzero(self.occupied[r0:r1, c0:c1])
        return r + r0, c + c0

    def centres(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """(k, 3) world centres of cells [m]."""
        res, (ox, oy) = self.resolution, self.origin
        return np.stack([ox + (cols + 0.5) * res, oy + (rows + 0.5) * res,
                         np.full(len(rows), self.height / 2)], axis=1)

    def shape(self, row: int, col: int) -> SceneShape:
        """Cell (row, col) as a :class:`SceneShape` named ``occupancy[row,col]``."""
        pose = np.eye(4)
        pose[:3, 3] = self.centres(np.array([row]), np.array([col]))[0]
        half = np.array([self.resolution / 2, self.resolution / 2, self.height / 2])
        return SceneShape(f"occupancy[{row},{col}]", self.geometry, pose,
                          np.array([pose[:3, 3] - half, pose[:3, 3] + half]))
