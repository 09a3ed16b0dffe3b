"""A robot's live map as its map server publishes it (``nav_msgs/OccupancyGrid`` values), and the
occupancy the base plans on from it.

map_server publishes -1 for unknown cells and 0..100 for the occupancy probability in percent; a
cell at or above ``occupied_percent`` (default 65, map_server's ``occupied_thresh``) is occupied, the
rest free, and unknown cells are what the policy says (``occupied``, ``free`` or ``cost``, as for a
scene file's map: :mod:`placement.scene.occupancy`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from placement.scene.occupancy import DEFAULT_UNKNOWN_COST, UNKNOWN_POLICIES, OccupancyMap, OccupancyMapError
from placement.validation import show

#: OccupancyGrid values at or above this [percent] are occupied (map_server's default ``occupied_thresh``
#: 0.65); -1 is unknown; the rest is free.
OCCUPIED_PERCENT = 65


def occupancy_from_values(
    values: npt.NDArray[np.int8],
    resolution: float,
    origin: tuple[float, float],
    unknown: str = "occupied",
    occupied_percent: int = OCCUPIED_PERCENT,
    unknown_cost: float = DEFAULT_UNKNOWN_COST,
    arm_height: float | None = None,
) -> OccupancyMap:
    """The occupancy map of an OccupancyGrid's ``values`` (rows, cols) int8, row 0 the lowest y: -1
    unknown (``occupied``, ``free`` or ``cost`` as ``unknown`` says), at or above ``occupied_percent``
    occupied, the rest free; cells of ``resolution`` [m], the lower-left corner at ``origin`` (x, y) [m]."""
    if unknown not in UNKNOWN_POLICIES:
        raise OccupancyMapError(f"unknown cells may be {', '.join(UNKNOWN_POLICIES)}, got {show(unknown)}")
    occupied = values >= occupied_percent
    if unknown == "occupied":
        occupied |= values < 0
    occupied.setflags(write=False)
    cells = None
    if unknown == "cost":
        cells = values < 0
        cells.setflags(write=False)
    ox, oy = (float(v) for v in origin)
    return OccupancyMap(occupied, float(resolution), (ox, oy, 0.0), None, unknown, arm_height, cells, unknown_cost)


@dataclass(frozen=True)
class GridValues:
    """An OccupancyGrid's checked content (as a robot's map server publishes it): ``values`` (rows,
    cols) int8 (-1 unknown, 0..100), row 0 the lowest y; ``resolution`` [m]; ``origin`` (x, y) [m]
    of cell (0, 0)'s lower-left corner; ``frame`` its frame_id."""

    values: npt.NDArray[np.int8]
    resolution: float
    origin: tuple[float, float]
    frame: str

    def occupancy(
        self,
        unknown: str = "occupied",
        occupied_percent: int = OCCUPIED_PERCENT,
        unknown_cost: float = DEFAULT_UNKNOWN_COST,
    ) -> OccupancyMap:
        """The grid as an occupancy map (see :func:`~placement.scene.occupancy.occupancy_from_values`)."""
        return occupancy_from_values(self.values, self.resolution, self.origin, unknown, occupied_percent, unknown_cost)
