"""Scene documents the tests share: a full version 1 scene, a small version 2 one, key mutations."""

from __future__ import annotations

import math
from pathlib import Path

import yaml

FULL_SCENE = """\
version: 1
resolution: 0.1
bounds: [-3.0, -3.0, 7.0, 5.0]
robot:
  preset: pr2
  start: [0.0, 0.0, 1.5707963]
maps: maps/pr2
occupancy_map: floor.yaml
obstacles:
  - {name: table_1, box: {center: [2.0, 0.0, 0.375], size: [0.8, 0.6, 0.75], yaw: 0.1}, table: true}
  - {name: pillar, cylinder: {center: [-1.0, 3.0, 1.0], radius: 0.2, height: 2.0}}
  - {name: wall, polygon: [[-2.5, -2.5], [6.5, -2.5], [6.5, -2.4], [-2.5, -2.4]]}
objects:
  - {name: cup_1, position: [2.1, 0.1, 0.8], yaw: 0.3, size: [0.08, 0.08, 0.1]}
  - {name: cup_2, position: [1.9, -0.1, 0.81], size: [0.06, 0.1, 0.12]}
place_locations:
  - {name: bin_a, position: [5.0, 1.0, 0.9]}
  - {name: bin_b, position: [5.0, -1.0, 0.9]}
task:
  - {pick: cup_1, place: bin_a}
  - {pick: cup_2, place: bin_b}
planner: {lambda_n: 0.05, yaw_steps: 60, grasp_yaws: [0.0, 1.5707963]}
"""


def base_doc() -> dict:
    return yaml.safe_load(FULL_SCENE.replace("occupancy_map: floor.yaml\n", ""))


def set_key(path, value):
    """Mutation setting the key at ``path`` (a list of keys/indices); value ``KeyError`` deletes it."""

    def mutate(d):
        for k in path[:-1]:
            d = d[k]
        if value is KeyError:
            del d[path[-1]]
        else:
            d[path[-1]] = value

    return mutate


KITCHEN = Path(__file__).resolve().parents[2] / "examples" / "kitchen.yaml"
S = math.sqrt(0.5)
ON_SIDE = [S, 0.0, 0.0, S]  # 90 degrees about x


def v2_doc() -> dict:
    """A small valid version 2 scene using every version 2 key."""
    return {
        "version": 2,
        "robot": {"start": [0.0, 0.0, 0.0]},
        "obstacles": [{"name": "table", "box": {"center": [2.0, 0.0, 0.375], "size": [0.8, 0.6, 0.75]}, "table": True}],
        "objects": [
            {"name": "can", "position": [2.0, 0.1, 0.785], "orientation": ON_SIDE, "size": [0.07, 0.07, 0.12]},
            {
                "name": "cup",
                "position": [1.9, -0.1, 0.8],
                "yaw": 0.3,
                "size": [0.06, 0.06, 0.1],
                "grasps": [{"name": "rim", "poses": [[0, 0, 0.15, 1, 0, 0, 0], [0, 0, 0.05, 1, 0, 0, 0]]}],
            },
        ],
        "place_locations": [
            {"name": "spot", "position": [2.2, 0.0, 0.85], "orientations": [[0.5, 0.5, 0.5, 0.5]]},
            {"name": "bin", "position": [2.2, 0.2, 0.85]},
        ],
        "trajectories": [
            {"name": "door", "poses": [[1.0, 1.0, 1.0, 0, 0, 0, 1]]},
            {"name": "door2", "poses": [[1.0, 1.5, 1.0, 0, 0, 0, 1], [1.1, 1.5, 1.0, 0, 0, 0, 1]]},
        ],
        "task": [
            {"reach": ["door", "door2"]},
            {"pick": "can", "place": "spot"},
            {"pick": "cup", "place": "bin"},
            {"reach": "door"},
        ],
    }
