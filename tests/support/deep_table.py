"""The deep-table pick of the torso planning tests: a cup in the middle of a 1.2 m deep table, which a
base of 0.3 m radius cannot come nearer than 0.9 m, and a narrow stand to put it on."""

from __future__ import annotations

from pathlib import Path

import yaml


def deep_table_scene(folder: Path, preset: Path | str, maps: Path | str) -> str:
    """Write the scene (robot ``preset``, maps ``maps``; lengths [m], angles [rad]) into ``folder`` and
    return its path."""
    scene = {
        "version": 1,
        "resolution": 0.05,
        "bounds": [0.0, 0.0, 6.0, 5.0],
        "robot": {"preset": str(preset), "start": [1.0, 4.0, 0.0]},
        "maps": str(maps),
        "obstacles": [
            {"name": "table", "box": {"center": [3.0, 2.5, 0.375], "size": [1.2, 1.2, 0.75]}, "table": True},
            {"name": "stand", "box": {"center": [1.0, 1.0, 0.4], "size": [0.3, 0.3, 0.8]}, "table": True},
        ],
        "objects": [{"name": "cup", "position": [3.0, 2.5, 0.8], "yaw": 0.4, "size": [0.06, 0.06, 0.1]}],
        "place_locations": [{"name": "spot", "position": [1.0, 1.0, 0.85]}],
        "task": [{"pick": "cup", "place": "spot"}],
        "planner": {"threshold": 0.01, "yaw_steps": 40},
    }
    path = Path(folder) / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    return str(path)
