"""Bounding boxes and the base frame: the cheap bounds that decide which pairs a collision check gives to coal."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

_CORNERS = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=bool)


def base_matrix(x: float, y: float, yaw: float) -> npt.NDArray[np.float64]:
    """(4, 4) pose of the base frame on the floor at (x, y) [m], heading ``yaw`` [rad]."""
    B = np.eye(4)
    c, s = np.cos(yaw), np.sin(yaw)
    B[:2, :2] = [[c, -s], [s, c]]
    B[:2, 3] = (x, y)
    return B


def model_aabb(aabb: npt.NDArray[np.float64], A: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """(S, 2, 3) boxes ``aabb`` (S, 2, 3) moved by ``A`` (4, 4), bounded again by axis-aligned boxes."""
    corners = np.where(_CORNERS[None], aabb[:, None, 1], aabb[:, None, 0])  # (S, 8, 3)
    moved = corners @ A[:3, :3].T + A[:3, 3]
    return np.stack([moved.min(axis=1), moved.max(axis=1)], axis=1)


def influence_box(
    centres: npt.NDArray[np.float64],
    radii: npt.NDArray[np.float64],
    carried: npt.NDArray[np.float64] | None = None,
    carried_radius: float = 0.0,
) -> tuple[float, float, float, float, float, float]:
    """The world box (x0, y0, z0, x1, y1, z1) [m] around spheres at ``centres`` (N, 3) [m] of ``radii``
    (N,) [m] and, given, a carried object's positions ``carried`` (P, 3) [m] grown by ``carried_radius``
    [m]: a check of those shapes cannot see a scene piece that lies outside it (see
    :attr:`placement.collision.CollisionResult.box`)."""
    r = np.asarray(radii, dtype=float)[:, None]
    lo = (centres - r).min(axis=0, initial=np.inf)
    hi = (centres + r).max(axis=0, initial=-np.inf)
    if carried is not None and len(carried):
        lo = np.minimum(lo, carried.min(axis=0) - carried_radius)
        hi = np.maximum(hi, carried.max(axis=0) + carried_radius)
    return (float(lo[0]), float(lo[1]), float(lo[2]), float(hi[0]), float(hi[1]), float(hi[2]))
