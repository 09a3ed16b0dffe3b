"""The base's world: the scene rasterised onto the navigation grid, and its cost maps.

Occupancy, obstacle distance and base feasibility per yaw (:mod:`.layers`, :mod:`.footprints`), the
planning window on a building's map (:mod:`.window`), travel costs (the paper's Eqs. 4 and 5,
:mod:`.navigation`) and the heuristic towards the next step (:mod:`.heuristic`). Arrays are (ny, nx)
over a :class:`~placement.scene.navgrid.NavGrid`; costs in metres, times in seconds.
"""

from placement.planning.world.footprints import BaseShape
from placement.planning.world.heuristic import region_heuristic
from placement.planning.world.layers import (
    World,
    add_touched,
    build_world,
    changed_occupancy,
    windowed_world,
    world_from_occupancy,
    world_still_serves,
)
from placement.planning.world.navigation import costs_at, extract_path, navigation_cost, reachable_from, side_by_side

__all__ = [
    "BaseShape",
    "World",
    "add_touched",
    "build_world",
    "changed_occupancy",
    "costs_at",
    "extract_path",
    "navigation_cost",
    "reachable_from",
    "region_heuristic",
    "side_by_side",
    "windowed_world",
    "world_from_occupancy",
    "world_still_serves",
]
