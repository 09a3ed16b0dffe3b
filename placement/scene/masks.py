"""Nav2 costmap filter masks: where the base may not go (keepout) and how fast it may drive (speed).

A mask is a map_server map (YAML + PGM), read into the OccupancyGrid values that
``nav2_map_server`` publishes (-1 unknown, 0..100; see :func:`~placement.scene.occupancy.grid_values`),
and given the meaning Nav2's filters give it:

* **keepout** (``KeepoutFilter``): cells of value 100 (``occupied``) are closed to the base, as lethal
  cells of its costmap: no footprint may overlap them and no path cross them. Other values (free,
  unknown, the costs of a ``scale`` mask) leave the base free.
* **speed** (``SpeedFilter``): a cell of value ``v`` in 1..100 limits the speed to
  ``base + multiplier * v``, in percent of the robot's ``v_max`` (``type: percent``) or in m/s
  (``type: absolute``); 0 and -1 set no limit. Travel through the cell costs ``v_max / limit`` times
  its length on top of the Eq. 4 slowdown (the planner's cost is time): the two multiply. A limit
  of 0 or less closes the cell, like keepout; a limit above ``v_max`` (or 100 %) does nothing.
  Nav2 takes ``type``, ``base`` and ``multiplier`` from the ``CostmapFilterInfo`` message; the scene
  gives them with the mask.

Both rasterise onto the planning grid: keepout conservatively (a planning cell that any keepout cell
overlaps is closed), speed by the slowest mask cell the planning cell overlaps. Planning cells
outside a mask are unrestricted.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from placement.scene.occupancy import MapImage, OccupancyMap, cell_span, load_map_image, rasterize_occupancy

#: Speed limit types of Nav2's CostmapFilterInfo (1: percent, 2: absolute).
SPEED_TYPES = ("percent", "absolute")
#: [%] the lowest limit that still moves the base; slower closes the cell (a 1e4-fold slowdown).
MIN_PERCENT = 0.01


@dataclass(frozen=True, eq=False)
class KeepoutMask:
    """A Nav2 keepout mask: ``image`` its grid (see the module doc)."""

    image: MapImage

    @property
    def source(self) -> Path:
        return self.image.source

    def closed(
        self, origin_xy: tuple[float, float], resolution: float, shape: tuple[int, int]
    ) -> npt.NDArray[np.bool_]:
        """(ny, nx) bool: the planning cells that a keepout cell (value 100) overlaps."""
        occ = OccupancyMap(self.image.values == 100, self.image.resolution, self.image.origin, self.image.source)
        return rasterize_occupancy(occ, origin_xy, resolution, shape, conservative=True)


@dataclass(frozen=True, eq=False)
class SpeedMask:
    """A Nav2 speed mask: ``image`` its grid, ``type`` percent or absolute, the limit
    ``base + multiplier * value`` [% or m/s] (see the module doc)."""

    image: MapImage
    type: str = "percent"
    base: float = 0.0
    multiplier: float = 1.0

    @property
    def source(self) -> Path:
        return self.image.source

    def fraction(self, v_max: float) -> npt.NDArray[np.float64]:
        """(rows, cols) the allowed fraction of ``v_max`` [m/s] per mask cell: 1 without a limit, 0
        where the limit closes the cell, else in (0, 1]."""
        v = self.image.values.astype(np.float64)
        limited = v > 0
        limit = self.base + self.multiplier * v
        percent = limit if self.type == "percent" else 100.0 * limit / float(v_max)
        frac = np.where(percent < MIN_PERCENT, 0.0, percent / 100.0)
        out: npt.NDArray[np.float64] = np.where(limited, np.clip(frac, 0.0, 1.0), 1.0)
        return out

    def slowdown(
        self, origin_xy: tuple[float, float], resolution: float, shape: tuple[int, int], v_max: float
    ) -> npt.NDArray[np.float64]:
        """(ny, nx) the travel cost multiplier of each planning cell, ``1 / fraction`` of the slowest
        mask cell it overlaps (>= 1; inf where a cell is closed)."""
        frac = self.fraction(v_max)
        rows, cols = frac.shape
        ny, nx = shape
        ox, oy = origin_xy
        mx, my, _ = self.image.origin
        res = self.image.resolution
        x0 = ox + np.arange(nx) * resolution
        y0 = oy + np.arange(ny) * resolution
        c0, c1, vc = cell_span(x0, x0 + resolution, mx, res, cols)
        r0, r1, vr = cell_span(y0, y0 + resolution, my, res, rows)
        # the minimum over each cell's span of mask rows, then of mask columns (spans are short: a
        # planning cell covers a few mask cells)
        out = np.ones((ny, nx))
        if not (vr.any() and vc.any()):
            return out
        row_min = np.empty((ny, cols))
        for j in range(ny):
            row_min[j] = frac[r0[j] : r1[j] + 1].min(axis=0) if vr[j] else 1.0
        for i in range(nx):
            if vc[i]:
                out[:, i] = row_min[:, c0[i] : c1[i] + 1].min(axis=1)
        with np.errstate(divide="ignore"):
            slow: npt.NDArray[np.float64] = 1.0 / out
        return slow


def load_keepout_mask(path: str | Path) -> KeepoutMask:
    """A keepout mask from its map YAML (OccupancyMapError for a bad file, as for occupancy maps)."""
    return KeepoutMask(load_map_image(path))


def load_speed_mask(path: str | Path, type: str = "percent", base: float = 0.0, multiplier: float = 1.0) -> SpeedMask:
    """A speed mask from its map YAML and the CostmapFilterInfo values ``type``, ``base``, ``multiplier``."""
    return SpeedMask(load_map_image(path), type, float(base), float(multiplier))
