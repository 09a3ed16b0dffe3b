"""Triangle meshes of the scene's shapes for the viewer: boxes, vertical cylinders, polygon prisms,
the footprint ring. Vertices (n, 3) float32 [m], faces (m, 3) int32."""

from __future__ import annotations

import math
from typing import cast

import numpy as np
import numpy.typing as npt

# polygons are unbounded in height in the scene model; they are drawn this tall [m]
POLYGON_HEIGHT = 2.0


def pose_matrix(x: float, y: float, yaw: float, z: float = 0.0) -> npt.NDArray[np.float64]:
    """(4, 4) pose at (x, y, z) [m] turned by ``yaw`` [rad] about z."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0, x], [s, c, 0, y], [0, 0, 1, z], [0, 0, 0, 1]], dtype=float)


def yaw_wxyz(yaw: float) -> tuple[float, float, float, float]:
    """Quaternion (w, x, y, z) of a turn by ``yaw`` [rad] about z."""
    return (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


def label_offset(orientation: npt.ArrayLike, size: npt.ArrayLike, above: float = 0.08) -> tuple[float, float, float]:
    """Where a label goes in the frame of a box of ``size`` (3,) [m] turned by ``orientation`` (ROS
    quaternion ``[x, y, z, w]``): ``above`` [m] over the box's top in the world, straight over its centre.

    The label is a child of the box's node, so its position is in the box's frame, not the world's."""
    x, y, z, w = (float(v) for v in np.asarray(orientation, dtype=float).reshape(4))
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    R = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    half_height = float(np.abs(R[2]) @ (np.asarray(size, dtype=float) / 2))  # the box's half extent along world z
    ox, oy, oz = (float(v) for v in R.T @ np.array([0.0, 0.0, half_height + above]))
    return (ox, oy, oz)


def ear_clip(points: npt.ArrayLike) -> npt.NDArray[np.int32]:
    """(k - 2, 3) triangles of a simple polygon ``points`` (k, 2), either orientation."""
    pts = np.asarray(points, dtype=float)
    area = 0.5 * float(np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1]))
    idx = list(range(len(pts))) if area >= 0 else list(range(len(pts)))[::-1]
    tris: list[tuple[int, int, int]] = []
    guard = 0
    while len(idx) > 3 and guard < 10 * len(pts) ** 2:
        guard += 1
        for n in range(len(idx)):
            a, b, c = idx[n - 1], idx[n], idx[(n + 1) % len(idx)]
            pa, pb, pc = pts[a], pts[b], pts[c]
            if (pb[0] - pa[0]) * (pc[1] - pa[1]) - (pb[1] - pa[1]) * (pc[0] - pa[0]) <= 1e-12:
                continue  # reflex or flat corner: not an ear
            if any(_inside(pts[o], pa, pb, pc) for o in idx if o not in (a, b, c)):
                continue
            tris.append((a, b, c))
            idx.pop(n)
            break
        else:
            break  # self-intersecting: what is left is drawn as a fan rather than not at all
    tris += [(idx[0], idx[i], idx[i + 1]) for i in range(1, len(idx) - 1)]
    return np.array(tris, dtype=np.int32).reshape(-1, 3)


def _inside(
    p: npt.NDArray[np.float64], a: npt.NDArray[np.float64], b: npt.NDArray[np.float64], c: npt.NDArray[np.float64]
) -> bool:
    def side(u: npt.NDArray[np.float64], v: npt.NDArray[np.float64], w: npt.NDArray[np.float64]) -> float:
        return float((v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0]))

    return side(a, b, p) >= 0 and side(b, c, p) >= 0 and side(c, a, p) >= 0


def prism(points: npt.ArrayLike, z0: float, z1: float) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.int32]]:
    """The closed prism over polygon ``points`` (k, 2) from height ``z0`` to ``z1`` [m]."""
    pts = np.asarray(points, dtype=float)
    k = len(pts)
    verts = np.vstack([np.c_[pts, np.full(k, z0)], np.c_[pts, np.full(k, z1)]]).astype(np.float32)
    cap = ear_clip(pts)
    faces: list[npt.NDArray[np.integer]] = [cap[:, ::-1], cap + k]
    for i in range(k):
        j = (i + 1) % k
        faces.append(np.array([[i, j, k + j], [i, k + j, k + i]]))
    return verts, np.vstack(faces).astype(np.int32)


#: The 12 outward triangles of a box over its corners numbered by bits (x: 1, y: 2, z: 4).
_BOX_FACES = np.array(
    [
        [0, 2, 1], [1, 2, 3],  # z0
        [4, 5, 6], [5, 7, 6],  # z1
        [0, 1, 4], [1, 5, 4],  # y0
        [2, 6, 3], [3, 6, 7],  # y1
        [0, 4, 2], [2, 4, 6],  # x0
        [1, 3, 5], [3, 7, 5],  # x1
    ],
    dtype=np.int32,
)  # fmt: skip


def boxes_mesh(boxes: npt.ArrayLike) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.int32]]:
    """One mesh of axis-aligned ``boxes`` (k, 6) (x0, y0, z0, x1, y1, z1) [m]: (8 k, 3) vertices and
    (12 k, 3) outward triangles."""
    b = np.asarray(boxes, dtype=float).reshape(-1, 6)
    bits = np.arange(8)
    corners = np.stack(
        [np.where(bits & 1, b[:, None, 3], b[:, None, 0]), np.where(bits & 2, b[:, None, 4], b[:, None, 1]),
         np.where(bits & 4, b[:, None, 5], b[:, None, 2])],
        axis=2,
    )  # fmt: skip
    faces = _BOX_FACES[None] + 8 * np.arange(len(b), dtype=np.int32)[:, None, None]
    return corners.reshape(-1, 3).astype(np.float32), faces.reshape(-1, 3).astype(np.int32)


def circle(radius: float, n: int = 48) -> npt.NDArray[np.float64]:
    """(n, 2) points on a circle of ``radius`` [m] around the origin, counter-clockwise."""
    a = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return cast("npt.NDArray[np.float64]", radius * np.c_[np.cos(a), np.sin(a)])


def footprint_segments(radius: float, polygon: npt.ArrayLike | None = None, z: float = 0.0) -> npt.NDArray[np.float32]:
    """(n, 2, 3) line segments of a base footprint at height ``z`` [m] in the base frame: the closed
    ``polygon`` (k, 2) [m] if given, else a circle of ``radius`` [m]."""
    if polygon is None:
        return ring_segments(radius, z)
    pts = np.asarray(polygon, dtype=float)
    p = np.c_[pts, np.full(len(pts), z)]
    return np.stack([p, np.roll(p, -1, axis=0)], axis=1).astype(np.float32)


def ring_segments(radius: float, z: float = 0.0, n: int = 48) -> npt.NDArray[np.float32]:
    """(n, 2, 3) line segments of a circle of ``radius`` [m] at height ``z`` around the origin."""
    p = np.c_[circle(radius, n), np.full(n, z)]
    return np.stack([p, np.roll(p, -1, axis=0)], axis=1).astype(np.float32)


def polyline_segments(points: npt.ArrayLike) -> npt.NDArray[np.float32]:
    """(m - 1, 2, 3) line segments joining consecutive ``points`` (m, 3)."""
    p = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    return np.stack([p[:-1], p[1:]], axis=1) if len(p) > 1 else np.zeros((0, 2, 3), np.float32)
