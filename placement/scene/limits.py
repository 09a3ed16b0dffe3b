"""What a scene may hold: the bounds that keep parsing and planning within seconds and a few GB.

Each is checked before the work it bounds, and the message names the bound. Measured on 2 shared
cores (docs/planning.md, "What is checked when").
"""

from __future__ import annotations

from collections.abc import Sequence

from placement.scene.model import Scene
from placement.scene.occupancy import MAX_COORD

__all__ = [
    "BOUNDS_MARGIN",
    "MAX_COORD",
    "MAX_GRID_CELLS",
    "MAX_OBJECTS",
    "MAX_OBSTACLES",
    "MAX_POLYGON_VERTICES",
    "MAX_SCENE_BYTES",
    "MAX_TASK",
    "MAX_TOTAL_VERTICES",
    "RESOLUTION_RANGE",
    "default_bounds",
    "things_extent",
]

BOUNDS_MARGIN = 1.0  # [m]
#: The planning grid: at most 5 M cells of at least 1 cm. Planning the first table-clearing step
#: with the PR2 square takes ~2 s per million 5 cm cells (6.4 M: 13 s, 0.8 GB; 12.8 M at 1 cm: 26 s,
#: 1.3 GB), and finer cells cost more per cell, the footprint's yaw tables growing with (radius /
#: resolution)^2 (3.2 M cells at 5 mm: 42 s; at 1 mm the tables alone run for minutes).
MAX_GRID_CELLS = 5_000_000
RESOLUTION_RANGE = (0.01, 100.0)  # [m]
#: A scene file larger than this is refused before it is parsed: PyYAML builds ~10,000 scalars per
#: second on a loaded core (10,000 boxes, 1.2 MB: 7-12 s), so 2 MiB parse in well under a minute.
MAX_SCENE_BYTES = 2 * 2**20
#: Obstacles in a scene (or after an update): 10,000 small boxes plan a pick in 12 s after parsing.
MAX_OBSTACLES = 10_000
#: Points of one obstacle polygon and of all of them: the collision check cuts a non-convex polygon
#: into triangles in O(k^2) (one 1,000-point star adds 8 s to a plan, ten add 56 s; a 10,000-point
#: circle ran past 300 s).
MAX_POLYGON_VERTICES = 1_000
MAX_TOTAL_VERTICES = 4_000
MAX_OBJECTS = 1_000  # objects, and likewise place locations and trajectories
#: Entries of a task (a pick/place pair is one entry and two steps). Memory grows with the steps
#: (every step's layers are kept): 200 pairs took 3.9 GB with `global`, and 1,000 ran out of memory;
#: 100 pairs on two generated rooms stay within 60 s and 4 GB end to end with every method
#: (tools/bench_limits.py, docs/benchmarks.md).
MAX_TASK = 100


def _extend(box: tuple[float, float, float, float] | None, b: Sequence[float]) -> tuple[float, float, float, float]:
    if box is None:
        xmin, ymin, xmax, ymax = (float(v) for v in b)
        return (xmin, ymin, xmax, ymax)
    return (min(box[0], b[0]), min(box[1], b[1]), max(box[2], b[2]), max(box[3], b[3]))


def things_extent(scene: Scene) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) [m] of everything the task involves: obstacles, objects, place
    locations, trajectory poses and the start."""
    extent = None
    for o in scene.obstacles:
        extent = _extend(extent, o.shape.bounds_xy())
    for obj in scene.objects:
        extent = _extend(extent, obj.bounds_xy())
    for pl in scene.place_locations:
        extent = _extend(extent, (pl.position[0], pl.position[1]) * 2)
    for t in scene.trajectories:
        extent = _extend(extent, (*t.poses[:, :2].min(axis=0), *t.poses[:, :2].max(axis=0)))
    return _extend(extent, (scene.start[0], scene.start[1]) * 2)


def default_bounds(scene: Scene) -> tuple[float, float, float, float]:
    """The extent of everything in ``scene`` (and its occupancy map), grown by ``BOUNDS_MARGIN``."""
    extent = things_extent(scene)
    if scene.occupancy is not None:
        extent = _extend(extent, scene.occupancy.extent)
    m = BOUNDS_MARGIN
    return (extent[0] - m, extent[1] - m, extent[2] + m, extent[3] + m)
