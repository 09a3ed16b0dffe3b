"""A small planning scene (a table with a cup and a box, a shelf to put them on) written for the test maps."""

from __future__ import annotations

import json

import yaml

SCENE = {
    "version": 1,
    "resolution": 0.05,
    "bounds": [0.0, 0.0, 6.0, 5.0],
    "robot": {"preset": "pr2", "start": [1.0, 4.0, 0.0]},
    "obstacles": [
        {"name": "table", "box": {"center": [3.0, 2.5, 0.375], "size": [0.8, 0.6, 0.75]}, "table": True},
        {"name": "shelf", "box": {"center": [1.0, 0.8, 0.375], "size": [0.6, 0.6, 0.75]}},
        {"name": "pillar", "cylinder": {"center": [4.5, 4.0, 1.0], "radius": 0.2, "height": 2.0}},
    ],
    "objects": [
        {"name": "cup", "position": [3.0, 2.55, 0.8], "yaw": 0.4, "size": [0.06, 0.06, 0.1]},
        {"name": "box", "position": [2.8, 2.4, 0.8], "yaw": 1.0, "size": [0.05, 0.12, 0.1]},
    ],
    "place_locations": [{"name": "spot", "position": [1.0, 0.8, 0.85]}],
    "task": [{"pick": "cup", "place": "spot"}, {"pick": "box", "place": "spot"}],
    "planner": {"threshold": 0.01, "yaw_steps": 40},
}


def write_scene(tmp_path, maps_dir, **changes):
    scene = json.loads(json.dumps(SCENE))
    scene["maps"] = str(maps_dir)
    for key, value in changes.items():
        scene[key] = value
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    return path
