"""Rotations and poses of the scene file: quaternions ``[x, y, z, w]`` (ROS order), 7-vectors
``[x, y, z, qx, qy, qz, qw]`` and oriented boxes. Units: metres and radians."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
import numpy.typing as npt

#: a quaternion whose norm is within this of 1 is accepted (and normalised)
UNIT_TOLERANCE = 1e-6


def normalised(q: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """(4,) ``q`` divided by its norm, left as it is when already unit to rounding (so that writing
    a scene and reading it back gives the same numbers)."""
    q = np.asarray(q, dtype=float)
    n = float(np.linalg.norm(q))
    return q if abs(n - 1.0) <= 1e-15 else q / n


def yaw_quaternion(yaw: float) -> npt.NDArray[np.float64]:
    """(4,) [x, y, z, w] of a rotation by ``yaw`` [rad] about z."""
    return np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])


def quaternion_matrix(q: Iterable[float]) -> npt.NDArray[np.float64]:
    """(3, 3) rotation of the unit quaternion ``q`` (4,) [x, y, z, w]."""
    x, y, z, w = (float(v) for v in q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_yaw(R: npt.NDArray[np.float64]) -> float:
    """The ZYX yaw [rad] of the rotation R (3, 3): the heading of its x axis (0 when x is vertical)."""
    return math.atan2(R[1, 0], R[0, 0])


def pose_matrix(position: npt.ArrayLike, q: Iterable[float]) -> npt.NDArray[np.float64]:
    """(4, 4) homogeneous pose of ``position`` (3,) [m] and unit quaternion ``q`` (4,) [x, y, z, w]."""
    T = np.eye(4)
    T[:3, :3] = quaternion_matrix(q)
    T[:3, 3] = position
    return T


def pose_matrices(poses: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """(P, 4, 4) poses of (P, 7) rows ``[x, y, z, qx, qy, qz, qw]``."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 7)
    return np.stack([pose_matrix(p[:3], p[3:]) for p in poses]) if len(poses) else np.zeros((0, 4, 4))


def box_corners(pose: npt.ArrayLike, size: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """(8, 3) corners [m] of a box of edge lengths ``size`` (3,) [m] centred at ``pose`` (4, 4)."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    local = signs * (np.asarray(size, dtype=float) / 2)
    T = np.asarray(pose, dtype=float)
    corners: npt.NDArray[np.float64] = local @ T[:3, :3].T + T[:3, 3]
    return corners


#: the 12 edges of :func:`box_corners`, as index pairs (corners differing in one sign)
BOX_EDGES = tuple((i, j) for i in range(8) for j in range(i + 1, 8) if bin(i ^ j).count("1") == 1)
