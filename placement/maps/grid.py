"""The 6D grid of a reachability map, re-exported from :mod:`placement.storage.grid`.

The grid lives with the storage, whose stored map format reads it back from a map's metadata
(``BuiltMap.grid``) without importing the maps package; the maps, planner and viewer keep importing it from
here.
"""

from __future__ import annotations

from placement.storage.grid import AXES, ORIENTATION, Grid, pose_from_zyx

__all__ = ["AXES", "ORIENTATION", "Grid", "pose_from_zyx"]
