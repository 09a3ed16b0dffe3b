"""Array and grid types shared by the planning stages (shapes and units in each user's docstring)."""

from __future__ import annotations

from typing import TypeAlias

import numpy as np
import numpy.typing as npt

#: float64 arrays: poses (4, 4) and (P, 4, 4), costs [m], coordinates [m], yaws [rad], configurations.
FloatArray: TypeAlias = npt.NDArray[np.float64]
#: float32 arrays: manipulation map values (dimensionless).
Float32Array: TypeAlias = npt.NDArray[np.float32]
#: int64 arrays: flat cell indices, yaw indices, predecessors.
IntArray: TypeAlias = npt.NDArray[np.int64]
#: int16 arrays: a manipulation map's base yaw indices (``planner.yaw_steps`` is at most 3,600: a
#: quarter of int64's memory, in every option of every step).
YawIndexArray: TypeAlias = npt.NDArray[np.int16]
#: the dtype of :data:`YawIndexArray`
YAW_INDEX = np.int16
#: bool arrays: grid masks (ny, nx).
BoolArray: TypeAlias = npt.NDArray[np.bool_]
#: uint64 arrays: packed yaw masks (N, W).
MaskArray: TypeAlias = npt.NDArray[np.uint64]
#: A grid cell (iy, ix).
Cell: TypeAlias = tuple[int, int]
#: A base placement (x [m], y [m], yaw [rad]).
BasePose: TypeAlias = tuple[float, float, float]

__all__ = [
    "YAW_INDEX",
    "BasePose",
    "BoolArray",
    "Cell",
    "Float32Array",
    "FloatArray",
    "IntArray",
    "MaskArray",
    "YawIndexArray",
]
