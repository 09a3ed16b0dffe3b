"""A collision test scene: a table with a crate, a pillar and a cabinet around it, two objects on it."""

from __future__ import annotations

import dataclasses

import numpy as np

from placement.scene import OccupancyMap


def scene_doc(preset: str, table_x: float) -> dict:
    return {
        "version": 1,
        "resolution": 0.05,
        "bounds": [-3, -3, 3, 3],
        "robot": {"preset": preset, "start": [-2, 0, 0]},
        "obstacles": [
            {"name": "table_1", "box": {"center": [table_x, 0.0, 0.36], "size": [0.6, 0.9, 0.72]}, "table": True},
            {
                "name": "tilted_crate",
                "box": {"center": [table_x - 0.1, -0.75, 0.5], "size": [0.3, 0.3, 1.0], "yaw": 0.6},
            },
            {"name": "pillar", "cylinder": {"center": [table_x - 0.2, 0.8, 0.6], "radius": 0.12, "height": 1.2}},
            {"name": "cabinet", "polygon": [[-0.9, 0.6], [-0.5, 0.55], [-0.45, 1.0], [-0.85, 1.1]]},
        ],
        "objects": [
            {"name": "cup_1", "position": [table_x - 0.15, -0.2, 0.77], "yaw": 0.3, "size": [0.06, 0.06, 0.1]},
            {"name": "box_2", "position": [table_x - 0.2, 0.15, 0.79], "yaw": 1.2, "size": [0.05, 0.12, 0.14]},
        ],
        "place_locations": [{"name": "p", "position": [table_x, 0.3, 0.8]}],
        "task": [{"pick": "cup_1", "place": "p"}],
    }


def with_occupancy(scene):
    """The scene plus a 0.1 m occupancy map: a wall behind the robot and a few posts near the table, its
    cells 3 m tall boxes for the arm too."""
    occ = np.zeros((40, 40), dtype=bool)  # x, y in [-2, 2)
    occ[:, 5] = True  # x in [-1.5, -1.4)
    occ[12, 30] = occ[27, 29] = True  # posts at (1.05, -0.75), (0.95, 0.75)
    return dataclasses.replace(scene, occupancy=OccupancyMap(occ, 0.1, (-2.0, -2.0, 0.0), arm_height=3.0))


def box_distance(centres, aabb):
    """(N, S) distances [m] from points (N, 3) to boxes (S, 2, 3) (0 inside), in numpy: the reference of
    the broad phase's sphere bound (placement/kernels/broadphase.py)."""
    lo, hi = aabb[None, :, 0], aabb[None, :, 1]
    p = centres[:, None, :]
    return np.linalg.norm(np.maximum(lo - p, 0.0) + np.maximum(p - hi, 0.0), axis=2)


def boxes_distance(centres, extents, aabb):
    """(N, S) distances [m] between boxes of ``centres`` (N, 3) and half ``extents`` (N, 3) and boxes
    ``aabb`` (S, 2, 3) (0 where they overlap), in numpy: the reference of the broad phase's box bound."""
    c, e = centres[:, None, :], extents[:, None, :]
    gap = np.maximum(aabb[None, :, 0] - (c + e), 0.0) + np.maximum((c - e) - aabb[None, :, 1], 0.0)
    return np.linalg.norm(gap, axis=2)
