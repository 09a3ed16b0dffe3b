"""The planar grid of base positions that every 2D layer of a scene lives on."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import PlacementError


@dataclass(frozen=True)
class NavGrid:
    """A planar grid: ``origin`` (x, y) of the lower-left corner [m], cell ``resolution`` [m], (ny, nx)."""

    origin: tuple[float, float]
    resolution: float
    shape: tuple[int, int]

    def cell(self, x: float, y: float) -> tuple[int, int]:
        """(iy, ix) of the cell containing (x, y) [m]; PlacementError outside the grid."""
        ix = int(math.floor((x - self.origin[0]) / self.resolution))
        iy = int(math.floor((y - self.origin[1]) / self.resolution))
        if not (0 <= iy < self.shape[0] and 0 <= ix < self.shape[1]):
            raise PlacementError(f"point ({x:.3f}, {y:.3f}) m is outside the navigation grid")
        return iy, ix

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell centre coordinates: xs (nx,), ys (ny,) [m]."""
        xs = self.origin[0] + (np.arange(self.shape[1]) + 0.5) * self.resolution
        ys = self.origin[1] + (np.arange(self.shape[0]) + 0.5) * self.resolution
        return xs, ys
