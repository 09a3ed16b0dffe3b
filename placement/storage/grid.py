"""The 6D grid of a reachability map: TCP position and orientation in the base frame.

Axes, in storage order: ``x, y, z`` (cells of ``resolution`` metres from
``origin``), ``yaw, pitch, roll`` (yaw-first ZYX Euler angles of the canonical
TCP frame, see kernels/grid.py for the bin conventions).

Cell volume: a bin of (dyaw, dpitch, droll) at pitch p covers
``dyaw * droll * (sin(p + dpitch/2) - sin(p - dpitch/2))`` of SO(3), so bins
near pitch +-90 deg hold less orientation volume (and fill more slowly) than
bins near pitch 0, where top and side grasps live.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from placement.errors import GridError
from placement.kernels.grid import cell_indices

AXES = ("x", "y", "z", "yaw", "pitch", "roll")
ORIENTATION = (
    "zyx-euler: R = Rz(yaw) Ry(pitch) Rx(roll); yaw/roll bins centred on k*2pi/n; pitch bins split [-pi/2, pi/2]"
)


@dataclass(frozen=True)
class Grid:
    """A 6D map grid.

    Attributes:
        origin: lower corner (x, y, z) of the position grid in the base frame [m].
        resolution: position cell edge [m].
        shape: bin counts (nx, ny, nz, n_yaw, n_pitch, n_roll) (six, checked).
    """

    origin: tuple[float, float, float]
    resolution: float
    shape: tuple[int, ...]

    def __post_init__(self) -> None:
        if not (self.resolution > 0 and math.isfinite(self.resolution)):
            raise GridError(f"resolution must be a positive length in metres, got {self.resolution}")
        if len(self.shape) != 6 or any(int(s) < 1 for s in self.shape):
            raise GridError(f"grid shape must be 6 positive counts, got {self.shape}")
        n_yaw, n_pitch, n_roll = self.shape[3:]
        if n_yaw % 2 or n_roll % 2:
            raise GridError(f"yaw and roll bin counts must be even (roll +-pi is a bin centre), got {n_yaw}, {n_roll}")
        if n_pitch % 2 == 0:
            raise GridError(f"pitch bin count must be odd (pitch 0 is a bin centre), got {n_pitch}")

    @classmethod
    def around(cls, centre: npt.ArrayLike, reach: float, resolution: float, bins: Sequence[int] = (20, 9, 20)) -> Grid:
        """A grid covering the cube of half-size ``reach`` [m] around ``centre`` (3,) [m]."""
        if not (resolution > 0 and math.isfinite(resolution)):
            raise GridError(f"resolution must be a positive length in metres, got {resolution}")
        if resolution > reach:
            raise GridError(f"resolution {resolution} m is larger than the arm's reach {reach:.3f} m")
        lo = np.floor((np.asarray(centre) - reach) / resolution) * resolution  # (3,)
        hi = np.ceil((np.asarray(centre) + reach) / resolution) * resolution
        n = np.round((hi - lo) / resolution).astype(int)
        cells = int(np.prod(n)) * int(np.prod(bins))
        if cells > 4_000_000_000:
            raise GridError(f"grid of {cells:.3g} cells at resolution {resolution} m is too large")
        x, y, z = (float(v) for v in lo)
        return cls((x, y, z), float(resolution), tuple(int(v) for v in (*n, *bins)))

    @property
    def size(self) -> int:
        """The number of cells."""
        return int(np.prod(self.shape))

    @property
    def origin_array(self) -> npt.NDArray[np.float64]:
        """``origin`` (3,) [m]."""
        return np.asarray(self.origin, dtype=float)

    @property
    def shape_array(self) -> npt.NDArray[np.int64]:
        """``shape`` (6,)."""
        return np.asarray(self.shape, dtype=np.int64)

    @property
    def angle_steps(self) -> tuple[float, float, float]:
        """Bin widths (dyaw, dpitch, droll) [rad]."""
        n_yaw, n_pitch, n_roll = self.shape[3:]
        return 2 * math.pi / n_yaw, math.pi / n_pitch, 2 * math.pi / n_roll

    def index(self, T: npt.ArrayLike) -> npt.NDArray[np.int64]:
        """Flat cell indices of poses T (N, 4, 4) in the base frame; -1 outside the grid."""
        T = np.ascontiguousarray(T, dtype=float).reshape(-1, 4, 4)
        o, s = self.origin_array, self.shape_array
        flat: npt.NDArray[np.int64] = cell_indices(T, o, self.resolution, s)  # a numba kernel: untyped
        return flat

    def centre(self, flat: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Poses (N, 4, 4) at the centres of the cells with flat indices ``flat`` (N,)."""
        idx = np.stack(np.unravel_index(np.asarray(flat, dtype=np.int64), self.shape), axis=-1)
        dyaw, dpitch, droll = self.angle_steps
        pos = self.origin_array + (idx[:, :3] + 0.5) * self.resolution
        yaw = idx[:, 3] * dyaw
        pitch = -math.pi / 2 + (idx[:, 4] + 0.5) * dpitch
        roll = idx[:, 5] * droll
        return pose_from_zyx(pos, yaw, pitch, roll)

    def to_dict(self) -> dict[str, Any]:
        """The grid as stored in a map's metadata (with its axes and orientation convention)."""
        d = asdict(self)
        d.update(axes=list(AXES), orientation=ORIENTATION, origin=list(self.origin), shape=list(self.shape))
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Grid:
        """The grid of :meth:`to_dict`'s mapping (GridError if it is not a valid grid)."""
        return cls(tuple(d["origin"]), float(d["resolution"]), tuple(int(v) for v in d["shape"]))


def pose_from_zyx(
    pos: npt.ArrayLike, yaw: npt.ArrayLike, pitch: npt.ArrayLike, roll: npt.ArrayLike
) -> npt.NDArray[np.float64]:
    """(N, 4, 4) poses from positions (N, 3) [m] and ZYX angles (N,) [rad]."""
    yaw, pitch, roll = (np.atleast_1d(np.asarray(a, dtype=float)) for a in (yaw, pitch, roll))
    cy, sy, cp, sp, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    T = np.zeros((len(yaw), 4, 4))
    T[:, 0, 0] = cy * cp
    T[:, 0, 1] = cy * sp * sr - sy * cr
    T[:, 0, 2] = cy * sp * cr + sy * sr
    T[:, 1, 0] = sy * cp
    T[:, 1, 1] = sy * sp * sr + cy * cr
    T[:, 1, 2] = sy * sp * cr - cy * sr
    T[:, 2, 0] = -sp
    T[:, 2, 1] = cp * sr
    T[:, 2, 2] = cp * cr
    T[:, :3, 3] = pos
    T[:, 3, 3] = 1.0
    return T
