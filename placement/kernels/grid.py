"""TCP pose -> 6D cell index, with yaw-first ZYX Euler orientation coordinates.

``R = Rz(yaw) Ry(pitch) Rx(roll)``. A base rotation about z adds to the yaw
only, so the inverse map for base yaw k*dyaw is the same grid with the yaw
index shifted by k. Yaw and roll bins are centred on multiples of their width
(yaw 0 and roll +-pi are bin centres, the top grasp sits mid-bin); pitch bins
split [-pi/2, pi/2] into an odd count, so pitch 0 is a bin centre too.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit


@njit(cache=True, inline="always")
def zyx_angles(T: npt.NDArray[np.float64]) -> tuple[float, float, float]:
    """(yaw, pitch, roll) [rad] of the rotation part of T (4, 4), R = Rz Ry Rx."""
    sp = -T[2, 0]
    if sp > 1.0:
        sp = 1.0
    elif sp < -1.0:
        sp = -1.0
    pitch = math.asin(sp)
    yaw = math.atan2(T[1, 0], T[0, 0])
    roll = math.atan2(T[2, 1], T[2, 2])
    return yaw, pitch, roll


@njit(cache=True, inline="always")
def wrap_bin(angle: float, n: int) -> int:
    """Bin of a periodic angle [rad] with n bins centred on multiples of 2 pi / n."""
    k = int(math.floor(angle * (n / (2.0 * math.pi)) + 0.5))
    k %= n
    return k + n if k < 0 else k


@njit(cache=True, inline="always")
def pitch_bin(pitch: float, n: int) -> int:
    """Bin of pitch in [-pi/2, pi/2] [rad] with n bins of width pi / n."""
    k = int(math.floor((pitch + 0.5 * math.pi) * (n / math.pi)))
    if k < 0:
        return 0
    if k >= n:
        return n - 1
    return k


@njit(cache=True)
def pose_bins(
    T: npt.NDArray[np.float64], z0: float, res: float, nz: int, n_pitch: int, n_roll: int
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """Per pose of T (n, 4, 4): its (z bin, pitch bin, roll bin) (n, 3) int64 in a grid whose z bins
    start at ``z0`` [m] (``res`` [m] wide, z bin -1 outside [0, nz)), and its yaw (n,) [rad]: the
    bins :func:`cell_index` gives, for many poses in one call."""
    n = T.shape[0]
    bins = np.empty((n, 3), dtype=np.int64)
    yaws = np.empty(n)
    for i in range(n):
        yaw, pitch, roll = zyx_angles(T[i])
        iz = int(math.floor((T[i, 2, 3] - z0) / res))
        bins[i, 0] = iz if 0 <= iz < nz else -1
        bins[i, 1] = pitch_bin(pitch, n_pitch)
        bins[i, 2] = wrap_bin(roll, n_roll)
        yaws[i] = yaw
    return bins, yaws


@njit(cache=True)
def cell_index(
    T: npt.NDArray[np.float64], origin: npt.NDArray[np.float64], res: float, shape: npt.NDArray[np.int64]
) -> int:
    """Flat index of pose T (4, 4) in a grid (x, y, z, yaw, pitch, roll), or -1 outside.

    origin: (3,) lower corner [m]; res: cell edge [m]; shape: (6,) int64 bin counts.
    """
    ix = int(math.floor((T[0, 3] - origin[0]) / res))
    iy = int(math.floor((T[1, 3] - origin[1]) / res))
    iz = int(math.floor((T[2, 3] - origin[2]) / res))
    if ix < 0 or iy < 0 or iz < 0 or ix >= shape[0] or iy >= shape[1] or iz >= shape[2]:
        return -1
    yaw, pitch, roll = zyx_angles(T)
    iyaw = wrap_bin(yaw, shape[3])
    ip = pitch_bin(pitch, shape[4])
    ir = wrap_bin(roll, shape[5])
    # (numpy's stubs type an element of ``shape`` as Any, and typing.cast does not compile in a kernel)
    return ((((ix * shape[1] + iy) * shape[2] + iz) * shape[3] + iyaw) * shape[4] + ip) * shape[5] + ir  # type: ignore[no-any-return]


@njit(cache=True)
def cell_indices(
    T: npt.NDArray[np.float64], origin: npt.NDArray[np.float64], res: float, shape: npt.NDArray[np.int64]
) -> npt.NDArray[np.int64]:
    """Flat indices (N,) int64 of poses T (N, 4, 4); -1 outside the grid."""
    out = np.empty(T.shape[0], dtype=np.int64)
    for i in range(T.shape[0]):
        out[i] = cell_index(T[i], origin, res, shape)
    return out
