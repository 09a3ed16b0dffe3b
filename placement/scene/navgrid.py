"""The planar grid of base positions that every 2D layer of a scene lives on."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from placement.errors import PlacementError


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


@dataclass(frozen=True)
class Window:
    """Rows ``y0 .. y1 - 1`` and columns ``x0 .. x1 - 1`` of a grid (a part that holds all the data
    of a layer that is zero elsewhere, such as one IRM)."""

    y0: int
    y1: int
    x0: int
    x1: int

    @classmethod
    def around(cls, cells: np.ndarray, shape: tuple[int, int], margin: int = 1) -> Window:
        """The bounding box of flat ``cells`` of a grid of ``shape``, grown by ``margin`` cells
        (clipped to the grid); an empty window for no cells."""
        if len(cells) == 0:
            return cls(0, 0, 0, 0)
        iy, ix = np.divmod(np.asarray(cells), shape[1])
        return cls(
            max(int(iy.min()) - margin, 0),
            min(int(iy.max()) + 1 + margin, shape[0]),
            max(int(ix.min()) - margin, 0),
            min(int(ix.max()) + 1 + margin, shape[1]),
        )

    @property
    def shape(self) -> tuple[int, int]:
        return (self.y1 - self.y0, self.x1 - self.x0)

    @property
    def slices(self) -> tuple[slice, slice]:
        """Index a full (ny, nx) layer with these to get the window's part."""
        return (slice(self.y0, self.y1), slice(self.x0, self.x1))

    def holds(self, cells: np.ndarray, nx: int) -> bool:
        """Whether every flat cell (of a grid with ``nx`` columns) lies inside."""
        iy, ix = np.divmod(np.asarray(cells), nx)
        return bool(np.all((iy >= self.y0) & (iy < self.y1) & (ix >= self.x0) & (ix < self.x1)))

    def to_global(self, local_flat: np.ndarray, nx: int) -> np.ndarray:
        """Flat indices into the window -> flat indices into the grid (``nx`` columns); the order is kept."""
        ly, lx = np.divmod(np.asarray(local_flat, dtype=np.int64), self.x1 - self.x0)
        return (ly + self.y0) * nx + lx + self.x0
