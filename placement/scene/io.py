"""Reading and writing scene files (YAML): strict loading, and the scene back as a mapping."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from placement.scene.base_layers import base_layers_to_dict
from placement.scene.document import parse_scene
from placement.scene.limits import MAX_SCENE_BYTES
from placement.scene.model import Box, Cylinder, Obstacle, Scene, SceneError, SceneObject, Trajectory, is_path
from placement.scene.poses import yaw_quaternion
from placement.validation import parse_yaml, read_text


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file (YAML, contract version 1 or 2); its name is the file stem.

    Relative paths inside it are resolved against the file's directory. Raises :class:`SceneError`
    (one line naming the file and the key path) for anything that is not a valid scene.
    """
    path = Path(path)
    if not os.path.lexists(path):
        raise SceneError(f"scene file not found: {path}")
    text = read_text(path, SceneError, str(path), MAX_SCENE_BYTES, "scene file")
    if not text.strip():
        raise SceneError(f"{path}: the scene is empty")
    return parse_scene(parse_yaml(text, str(path), SceneError), path.parent, path.stem, source=path)


def save_scene(scene: Scene, path: str | Path) -> Path:
    """Write ``scene`` as a scene file (paths relative to its directory); returns the path."""
    path = Path(path)
    path.write_text(
        yaml.safe_dump(scene_to_dict(scene, relative_to=path.parent), sort_keys=False, default_flow_style=None)
    )
    return path


def _floats(a: npt.ArrayLike) -> list[float]:
    return [float(v) for v in np.asarray(a).ravel()]


def _plain(value: object) -> object:
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def obstacle_to_dict(o: Obstacle) -> dict[str, Any]:
    """One obstacle as a scene-file mapping."""
    s = o.shape
    shape: dict[str, Any]
    if isinstance(s, Box):
        shape = {"box": {"center": _floats(s.center), "size": _floats(s.size), "yaw": s.yaw}}
    elif isinstance(s, Cylinder):
        shape = {"cylinder": {"center": _floats(s.center), "radius": s.radius, "height": s.height}}
    else:
        shape = {"polygon": [_floats(p) for p in s.points]}
    out: dict[str, Any] = {"name": o.name, **shape}
    if o.table:
        out["table"] = True
    return out


def trajectory_to_dict(t: Trajectory) -> dict[str, Any]:
    """A named trajectory as a scene-file mapping (poses as [x, y, z, qx, qy, qz, qw] lists)."""
    return {"name": t.name, "poses": [_floats(p) for p in t.poses]}


def object_to_dict(o: SceneObject, version: int) -> dict[str, Any]:
    """One object as a scene-file mapping, so that reading it back gives the same numbers: with
    ``yaw`` when that is what its orientation was made from (always in version 1), else with
    ``orientation``; and its own grasps."""
    out: dict[str, Any] = {"name": o.name, "position": _floats(o.position)}
    assert o.orientation is not None  # set by SceneObject.__post_init__
    if version < 2 or np.array_equal(o.orientation, yaw_quaternion(o.yaw)):
        out["yaw"] = o.yaw
    else:
        out["orientation"] = _floats(o.orientation)
    out["size"] = _floats(o.size)
    if o.grasps:
        out["grasps"] = [trajectory_to_dict(g) for g in o.grasps]
    return out


def scene_to_dict(scene: Scene, relative_to: str | Path | None = None) -> dict[str, Any]:
    """The scene as a scene-file mapping (plain Python types, bounds always written).

    Paths are absolute, or relative to ``relative_to`` (the directory the file will be in) when given.
    """

    def path(p: str | Path) -> str:
        if relative_to is None:
            return str(p)
        return os.path.relpath(p, Path(relative_to).absolute())

    preset = scene.robot_preset
    if is_path(preset):
        preset = path(preset)
    out: dict[str, Any] = {
        "version": scene.version,
        "resolution": scene.resolution,
        "bounds": list(scene.bounds),
        "robot": {"preset": preset, "start": list(scene.start)},
    }
    if scene.maps is not None:
        out["maps"] = path(scene.maps)
    out.update(base_layers_to_dict(scene, path))
    out["obstacles"] = [obstacle_to_dict(o) for o in scene.obstacles]
    out["objects"] = [object_to_dict(o, scene.version) for o in scene.objects]
    out["place_locations"] = []
    for p in scene.place_locations:
        out["place_locations"].append({"name": p.name, "position": _floats(p.position)})
        if p.orientations is not None:
            out["place_locations"][-1]["orientations"] = [_floats(q) for q in p.orientations]
    if scene.trajectories:
        out["trajectories"] = [trajectory_to_dict(t) for t in scene.trajectories]
    out["task"] = [{"reach": list(t.reach)} if t.reach else {"pick": t.pick, "place": t.place} for t in scene.task]
    out["planner"] = _plain(scene.planner)
    return out
