"""The scene as coal collision objects in the world frame (z up, metres).

* Boxes (obstacles, tables, objects' bounding boxes): ``coal.Box`` at their centre, turned by ``yaw``, or
  by a 6D pose when the thing has a ``pose`` (4, 4) or an ``orientation`` (4,) ``[x, y, z, w]``.
* Vertical cylinders: ``coal.Cylinder`` (its axis is z).
* Polygons (prisms from the floor, unbounded in height in the scene model): :data:`PRISM_HEIGHT` tall;
  a non-convex polygon is cut into triangles (ear clipping), each a convex prism, so a robot shape
  wholly inside the prism still collides (a mesh would only have a surface).
* Occupancy maps, only when the scene gives their cells a height (``arm_height``): each occupied (or
  unknown) cell is a box that tall from the floor, made only for the cells near the robot (see
  :class:`OccupancyCells`).
* Point clouds: each run of occupied voxels in a column is a box (see :mod:`placement.scene.cloud`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import coal
import numpy as np
import numpy.typing as npt

from placement.errors import PlacementError

if TYPE_CHECKING:
    from placement.scene import Box, Cylinder, OccupancyMap, Polygon, Scene, SceneObject

#: Height [m] given to polygon prisms and occupancy cells (unbounded in the scene model).
PRISM_HEIGHT = 3.0


@dataclass(frozen=True, eq=False)
class SceneShape:
    """One convex piece of a scene thing: ``name`` (the obstacle's or object's), coal ``geometry``,
    ``pose`` (4, 4) in the world, ``aabb`` (2, 3) world-frame (min, max) corners [m]."""

    name: str
    geometry: coal.CollisionGeometry
    pose: npt.NDArray[np.float64]
    aabb: npt.NDArray[np.float64]


def pose_of(thing: object, centre: npt.ArrayLike, yaw: float) -> npt.NDArray[np.float64]:
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
        out[:3, :3] = [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    else:
        c, s = math.cos(yaw), math.sin(yaw)
        out[:2, :2] = [[c, -s], [s, c]]
    return out


def box_aabb(pose: npt.NDArray[np.float64], size: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """(2, 3) world AABB of a box of full ``size`` (3,) at ``pose`` (4, 4)."""
    half = np.abs(pose[:3, :3]) @ (np.asarray(size, dtype=float) / 2)
    return np.array([pose[:3, 3] - half, pose[:3, 3] + half])


def object_aabb(obj: SceneObject) -> npt.NDArray[np.float64]:
    """(2, 3) world AABB [m] of a scene object: the box of its piece in :func:`scene_shapes`."""
    return box_aabb(pose_of(obj, obj.position, obj.yaw), obj.size)


def box_shape(name: str, thing: object, centre: npt.ArrayLike, size: npt.NDArray[np.float64], yaw: float) -> SceneShape:
    pose = pose_of(thing, centre, yaw)
    return SceneShape(name, coal.Box(*(float(v) for v in size)), pose, box_aabb(pose, size))


def eroded(piece: SceneShape, depth: float) -> SceneShape | None:
    """``piece`` shrunk by ``depth`` [m] on every side: the points at least that deep inside it (a box's or
    a cylinder's; None for other shapes, or when nothing is that deep). ``depth`` 0: the piece itself."""
    if depth <= 0.0:
        return piece
    g = piece.geometry
    if isinstance(g, coal.Box):
        half = np.asarray(g.halfSide, dtype=float) - depth
        return None if half.min() <= 0 else replace(piece, geometry=coal.Box(*(2 * half)))
    if isinstance(g, coal.Cylinder):
        r, h = float(g.radius) - depth, float(g.halfLength) - depth
        return None if min(r, h) <= 0 else replace(piece, geometry=coal.Cylinder(r, 2 * h))
    return None


def cylinder_shape(name: str, centre: npt.ArrayLike, radius: float, height: float) -> SceneShape:
    pose = np.eye(4)
    pose[:3, 3] = centre
    half = np.array([radius, radius, height / 2])
    return SceneShape(
        name, coal.Cylinder(float(radius), float(height)), pose, np.array([pose[:3, 3] - half, pose[:3, 3] + half])
    )


def signed_area(points: npt.NDArray[np.float64]) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def is_convex(points: npt.NDArray[np.float64]) -> bool:
    """True if the counter-clockwise polygon ``points`` (k, 2) turns left (or straight) at every vertex."""
    d = np.roll(points, -1, axis=0) - points
    cross = d[:, 0] * np.roll(d[:, 1], -1) - d[:, 1] * np.roll(d[:, 0], -1)
    return bool(np.all(cross >= -1e-12))


def triangulate(points: npt.NDArray[np.float64]) -> list[npt.NDArray[np.float64]]:
    """Ear-clipping triangulation of a simple polygon (k, 2) -> list of (3, 2) triangles."""
    pts = [np.asarray(p, dtype=float) for p in points]
    if signed_area(np.array(pts)) < 0:
        pts.reverse()
    out: list[npt.NDArray[np.float64]] = []
    guard = 0
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


def inside_triangle(
    p: npt.NDArray[np.float64], a: npt.NDArray[np.float64], b: npt.NDArray[np.float64], c: npt.NDArray[np.float64]
) -> bool:
    def side(u: npt.NDArray[np.float64], v: npt.NDArray[np.float64], w: npt.NDArray[np.float64]) -> float:
        return float((v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0]))

    return bool(side(a, b, p) >= 0 and side(b, c, p) >= 0 and side(c, a, p) >= 0)


def prism(points: npt.NDArray[np.float64], height: float) -> coal.ConvexBase:
    """A convex prism over the convex polygon ``points`` (k, 2), z from 0 to ``height``."""
    verts = coal.StdVec_Vec3s()
    verts.extend([np.array([x, y, z]) for z in (0.0, height) for x, y in points])
    return coal.Convex.convexHull(verts, False, None)


def polygon_shapes(name: str, points: npt.ArrayLike, height: float = PRISM_HEIGHT) -> list[SceneShape]:
    """Convex prisms covering the polygon prism ``points`` (k, 2) [m], ``height`` [m] tall."""
    pts = np.asarray(points, dtype=float)
    if signed_area(pts) < 0:
        pts = pts[::-1]
    pieces = [pts] if is_convex(pts) else triangulate(pts)
    out = []
    for piece in pieces:
        aabb = np.array([[*piece.min(axis=0), 0.0], [*piece.max(axis=0), height]])
        out.append(SceneShape(name, prism(piece, height), np.eye(4), aabb))
    return out


def obstacle_shapes(name: str, shape: Box | Cylinder | Polygon) -> list[SceneShape]:
    """The convex pieces of one obstacle shape (Box, Cylinder or Polygon of the scene model)."""
    if hasattr(shape, "points"):
        return polygon_shapes(name, shape.points)
    if hasattr(shape, "radius") and hasattr(shape, "height"):
        return [cylinder_shape(name, shape.center, shape.radius, shape.height)]
    if hasattr(shape, "size"):
        return [box_shape(name, shape, shape.center, shape.size, getattr(shape, "yaw", 0.0))]
    raise PlacementError(
        f"obstacle '{name}': shape {type(shape).__name__} is not supported by the collision "
        "check (box, cylinder, polygon)"
    )


def scene_shapes(scene: Scene) -> list[SceneShape]:
    """Every obstacle (tables included) and object of ``scene`` as convex pieces, in file order, then
    the boxes of its point cloud (``cloud[i]``, see :mod:`placement.scene.cloud`)."""
    out: list[SceneShape] = []
    for ob in scene.obstacles:
        out += obstacle_shapes(ob.name, ob.shape)
    for obj in scene.objects:
        out.append(box_shape(obj.name, obj, obj.position, obj.size, obj.yaw))
    cloud = getattr(scene, "cloud", None)
    if cloud is not None:
        for i, (x0, y0, z0, x1, y1, z1) in enumerate(cloud.boxes):
            pose = np.eye(4)
            pose[:3, 3] = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
            size = (x1 - x0, y1 - y0, z1 - z0)
            out.append(SceneShape(f"cloud[{i}]", coal.Box(*size), pose, np.array([[x0, y0, z0], [x1, y1, z1]])))
    return out


class OccupancyCells:
    """The occupied cells of an occupancy map as boxes ``resolution`` x ``resolution`` x :data:`PRISM_HEIGHT`.

    A map has up to millions of cells: :meth:`near` returns only the occupied cells in a window (the
    robot's reach), all sharing one coal box.
    """

    def __init__(self, occupancy: OccupancyMap, height: float = PRISM_HEIGHT):
        self.occupied = np.asarray(occupancy.occupied, dtype=bool)
        self.resolution = float(occupancy.resolution)
        self.origin = (float(occupancy.origin[0]), float(occupancy.origin[1]))
        self.height = float(height)
        self.geometry = coal.Box(self.resolution, self.resolution, self.height)

    def near(
        self, xmin: float, ymin: float, xmax: float, ymax: float
    ) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
        """(rows, cols) of the occupied cells overlapping the window [m] (world frame)."""
        res, (ox, oy) = self.resolution, self.origin
        rows, cols = self.occupied.shape
        c0, c1 = max(0, math.floor((xmin - ox) / res)), min(cols, math.ceil((xmax - ox) / res))
        r0, r1 = max(0, math.floor((ymin - oy) / res)), min(rows, math.ceil((ymax - oy) / res))
        if c0 >= c1 or r0 >= r1:
            return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
        r, c = np.nonzero(self.occupied[r0:r1, c0:c1])
        return r + r0, c + c0

    def centres(self, rows: npt.NDArray[np.integer], cols: npt.NDArray[np.integer]) -> npt.NDArray[np.float64]:
        """(k, 3) world centres of cells [m]."""
        res, (ox, oy) = self.resolution, self.origin
        return np.stack([ox + (cols + 0.5) * res, oy + (rows + 0.5) * res, np.full(len(rows), self.height / 2)], axis=1)

    def shape(self, row: int, col: int) -> SceneShape:
        """Cell (row, col) as a :class:`SceneShape` named ``occupancy[row,col]``."""
        pose = np.eye(4)
        pose[:3, 3] = self.centres(np.array([row]), np.array([col]))[0]
        half = np.array([self.resolution / 2, self.resolution / 2, self.height / 2])
        return SceneShape(
            f"occupancy[{row},{col}]", self.geometry, pose, np.array([pose[:3, 3] - half, pose[:3, 3] + half])
        )


class PieceGrid:
    """Scene pieces bucketed on a coarse 2D grid, built once per scene, so that a check looks only at
    the pieces near the robot (10,000 far pieces cost nothing per check).

    Each piece is entered with its *reach square*: its AABB's centre +- r in x and y. The check bounds a
    piece by the AABB of its AABB turned into the robot's model frame (see
    :func:`~placement.collision.bounds.model_aabb`); within ``r`` of the centre lies all of that bound,
    so a piece whose reach square stays ``d`` away from a point (in x, y) is more than ``d`` away from
    it in the check's bound as well: :meth:`near` never leaves out a piece the check could pair.

    * The model frame differs from the world by a turn about z (``tilt`` 0: the base frame's z is the
      model's; the PR2's): the bound's x, y half extents are at most |h_xy| (h: the AABB's half
      extents), so r = sqrt(2) |h_xy|; a tall prism is as cheap as a short box. A ``tilt`` up to 1e-9
      (the largest z/xy entry of the base's rotation in the model) adds a matching margin.
    * Otherwise (``tilt`` None): r = sqrt(3) |h|, valid for any rotation.

    Args:
        aabb: (S, 2, 3) world-frame (min, max) corners of the pieces [m].
        tilt: see above.
        cell: grid cell [m]; coarser for scenes so wide that the grid would exceed 2^20 cells a side.
        spread: a piece whose reach square covers more than this many cells is not bucketed but tested
            at every query (walls, big tables: few).
    """

    #: [m] heights of the robot's shapes above the floor are taken to be below this (the margin of a ``tilt``).
    ROBOT_HEIGHT = 10.0

    def __init__(self, aabb: npt.ArrayLike, tilt: float | None = 0.0, cell: float = 0.5, spread: int = 64):
        aabb = np.asarray(aabb, dtype=float).reshape(-1, 2, 3)
        centre, half = aabb.mean(axis=1), (aabb[:, 1] - aabb[:, 0]) / 2
        slack = 1e-9 * (1.0 + np.abs(centre).max(axis=1) + np.abs(half).max(axis=1))
        if tilt is not None and 0.0 <= tilt <= 1e-9:
            r = math.sqrt(2.0) * (
                np.linalg.norm(half[:, :2], axis=1) + tilt * (half[:, 2] + np.abs(centre[:, 2]) + self.ROBOT_HEIGHT)
            )
        else:
            r = math.sqrt(3.0) * np.linalg.norm(half, axis=1)
        r = r + slack
        self.lo, self.hi = centre[:, :2] - r[:, None], centre[:, :2] + r[:, None]
        self.size = len(aabb)
        if self.size == 0:
            self.origin, self.cell, self.nx = np.zeros(2), float(cell), 1
            self._ids, self._pieces, self.wide = np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
            return
        self.origin = self.lo.min(axis=0)
        extent = float((self.hi.max(axis=0) - self.origin).max())
        self.cell = max(float(cell), extent / 2**20)
        self.nx = int(math.floor(extent / self.cell)) + 2
        c0 = np.floor((self.lo - self.origin) / self.cell).astype(np.int64)
        c1 = np.floor((self.hi - self.origin) / self.cell).astype(np.int64)
        n = (c1 - c0 + 1).prod(axis=1)
        wide = n > spread
        self.wide = np.flatnonzero(wide)
        small = np.flatnonzero(~wide)  # pieces over a few cells each: entered in every cell they cover
        pieces = np.repeat(small, n[small])
        first = np.repeat(np.cumsum(n[small]) - n[small], n[small])
        offset = np.arange(len(pieces)) - first
        width = (c1 - c0 + 1)[pieces, 0]
        ids = (c0[pieces, 1] + offset // width) * self.nx + c0[pieces, 0] + offset % width
        order = np.argsort(ids, kind="stable")
        self._ids, self._pieces = ids[order], pieces[order]

    def near(self, lo: npt.NDArray[np.float64], hi: npt.NDArray[np.float64]) -> npt.NDArray[np.int64]:
        """Sorted indices of the pieces whose reach square overlaps the window ``lo`` .. ``hi`` ((2,) or
        more: x, y first, world frame [m])."""
        x0, y0, x1, y1 = float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])
        if self.size == 0 or not all(map(math.isfinite, (x0, y0, x1, y1))):
            return np.arange(self.size)  # nothing to gain: let the check see everything
        ox, oy = float(self.origin[0]), float(self.origin[1])
        last = self.nx - 1
        qx0, qy0 = max(math.floor((x0 - ox) / self.cell), 0), max(math.floor((y0 - oy) / self.cell), 0)
        qx1, qy1 = min(math.floor((x1 - ox) / self.cell), last), min(math.floor((y1 - oy) / self.cell), last)
        found = [self.wide]
        if qx0 <= qx1 and qy0 <= qy1:
            rows = np.arange(qy0, qy1 + 1, dtype=np.int64) * self.nx
            starts = np.searchsorted(self._ids, rows + qx0, side="left")
            ends = np.searchsorted(self._ids, rows + qx1, side="right")
            found += [self._pieces[s:e] for s, e in zip(starts.tolist(), ends.tolist()) if e > s]
        cand = np.concatenate(found)
        L, H = self.lo[cand], self.hi[cand]
        keep = (L[:, 0] <= x1) & (L[:, 1] <= y1) & (H[:, 0] >= x0) & (H[:, 1] >= y0)
        return np.unique(cand[keep])
