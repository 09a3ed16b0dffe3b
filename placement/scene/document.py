"""The scene file (docs/scenes.md, versions 1 and 2): what the robot must do, and where.

Units are metres and radians; the world frame has z up (ROS REP-103) and yaws turn counter-clockwise
about z. Shapes rotate about z only (a ``yaw``); in version 2 objects may have a full orientation
and the file gains grasps, place orientations and reach steps (see v2.py and below). Example::

    version: 1
    resolution: 0.05                 # navigation grid cell [m], default 0.05
    bounds: [xmin, ymin, xmax, ymax] # [m], optional: default extent of everything + 1 m
    robot:
      preset: pr2                    # built-in name or path to a robot YAML (default pr2)
      start: [x, y, yaw]             # [m, m, rad]
    maps: maps/pr2                   # optional: where the reachability maps are
    occupancy_map: floor.yaml        # optional: ROS map_server map, for the base only (see base_layers.py)
    keepout_mask: keepout.yaml       # optional: Nav2 keepout filter mask
    speed_mask: speed.yaml           # optional: Nav2 speed filter mask
    obstacle_cloud: room.pcd         # optional: a point cloud, boxes for the arm (see cloud.py)
    obstacles:                       # the base must avoid all of them
      - {name: table_1, box: {center: [x, y, z], size: [sx, sy, sz], yaw: 0.0}, table: true}
      - {name: pillar, cylinder: {center: [x, y, z], radius: r, height: h}}
      - {name: wall, polygon: [[x, y], [x, y], [x, y]]}
    objects:                         # things to pick: bounding box centre, yaw, size
      - {name: cup_1, position: [x, y, z], yaw: 0.3, size: [sx, sy, sz]}
    place_locations:                 # TCP target when placing
      - {name: bin_a, position: [x, y, z]}
    task:                            # ordered pick/place pairs
      - {pick: cup_1, place: bin_a}
    planner: {}                      # optional overrides, keys in PLANNER_KEYS (planning/settings.py)

Version 2 adds keys (6D objects, grasps, place orientations, trajectories, reach steps): see v2.py.

Decisions (where the paper is silent):

* Validation is strict: unknown keys anywhere, wrong types, non-finite numbers, non-positive sizes,
  duplicate YAML keys all raise :class:`SceneError`, one line naming the file and the key path.
* Paths (``robot.preset`` when it is a path, ``maps``, ``occupancy_map``) are relative to the scene
  file. A preset is a path when it ends in ``.yaml``/``.yml`` or contains a ``/``; otherwise it must be
  a built-in preset name. The occupancy map is loaded and checked with the scene; ``maps`` is not
  (the map opener reports a missing map).
* Names are unique across obstacles, objects and place locations (they identify things in the
  output and in dynamic updates). An object is picked at most once per task.
* ``box.center``/``cylinder.center`` are the centroids; ``yaw`` defaults to 0. A polygon is a
  vertical prism from the floor of unbounded height, simple, either way round (>= 3 points, non-zero
  area). ``table: true`` needs a box or a cylinder (a surface).
* Default ``bounds``: the extent of everything (see limits.py), grown by 1 m. The start, objects,
  place locations and trajectory ends lie inside ``bounds``. Counts, sizes, the grid and the file
  are bounded (limits.py). Objects may touch obstacles and each other but not enter them, and place
  locations may not lie inside an obstacle (checks.py).
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Any

from placement.robots.preset import builtin_presets
from placement.scene.base_layers import parse_base_layers, parse_cloud, resolve
from placement.scene.consistency import check_scene
from placement.scene.limits import MAX_OBJECTS, MAX_OBSTACLES, MAX_TASK, RESOLUTION_RANGE, default_bounds
from placement.scene.model import Scene, is_path
from placement.scene.parts import OBJECT_KEYS_V1, SCENE_VERSION, SCENE_VERSIONS, SceneParser
from placement.scene.planner_block import parse_planner
from placement.validation import describe, show

DEFAULT_RESOLUTION = 0.05  # [m]
DEFAULT_PRESET = "pr2"

# the parser's names keep their import path here (placement.scene and the planner's updates read them)
__all__ = ["OBJECT_KEYS_V1", "SCENE_VERSION", "SCENE_VERSIONS", "SceneParser", "check_scene", "parse_scene"]

TOP_KEYS = (
    "version",
    "resolution",
    "bounds",
    "robot",
    "maps",
    "occupancy_map",
    "keepout_mask",
    "speed_mask",
    "obstacle_cloud",
    "obstacles",
    "objects",
    "place_locations",
    "task",
    "planner",
    "trajectories",
)
ROBOT_KEYS = ("preset", "start")


def parse_scene(
    data: Any, origin_dir: str | Path = ".", name: str = "scene", source: str | Path | None = None
) -> Scene:
    """Validate a scene mapping (as read from YAML) and build a :class:`Scene`.

    Args:
        data: the parsed YAML document.
        origin_dir: directory that relative paths are resolved against.
        name: the scene's name.
        source: the file it came from (used in error messages; default ``name``).
    Raises:
        SceneError: one line, ``SOURCE: KEY.PATH: problem`` or ``SOURCE: unknown key 'KEY.PATH'; allowed: ...``.
    """
    where = str(source) if source is not None else name
    P = SceneParser(where)
    origin = Path(os.path.abspath(Path(origin_dir).expanduser()))
    if data is None:
        P.fail("", "the scene is empty")
    doc = P.mapping(data, "", TOP_KEYS, ("version", "robot", "task"))

    version = doc["version"]
    if isinstance(version, bool) or not isinstance(version, int):
        P.fail("version", f"expected an integer, got {describe(version)}")
    if version not in SCENE_VERSIONS:
        P.fail(
            "version",
            f"unsupported scene format version {show(version)}; this build reads versions "
            f"{', '.join(map(str, SCENE_VERSIONS))}",
        )
    P.version = version
    P.gate(doc, "", "")

    resolution = P.number(
        doc.get("resolution", DEFAULT_RESOLUTION), "resolution", RESOLUTION_RANGE[0], maximum=RESOLUTION_RANGE[1]
    )

    robot = P.mapping(doc["robot"], "robot", ROBOT_KEYS, ("start",))
    preset = P.string(robot.get("preset", DEFAULT_PRESET), "robot.preset")
    if is_path(preset):
        preset_path = resolve(preset, origin)
        if not preset_path.is_file():
            P.fail("robot.preset", f"robot preset file not found: {preset_path}")
        preset = str(preset_path)
    elif preset not in builtin_presets():
        P.fail(
            "robot.preset",
            f"unknown robot '{preset}'; built-in presets: {', '.join(builtin_presets())} (or a path to a robot YAML)",
        )
    start_x, start_y, start_yaw = P.coords(robot["start"], "robot.start", 3)

    maps = None
    if doc.get("maps") is not None:
        maps = str(resolve(P.string(doc["maps"], "maps"), origin))
    layers = parse_base_layers(P, doc, origin)

    for key, most in (
        ("obstacles", MAX_OBSTACLES),
        ("objects", MAX_OBJECTS),
        ("place_locations", MAX_OBJECTS),
        ("trajectories", MAX_OBJECTS),
        ("task", MAX_TASK),
    ):
        if isinstance(doc.get(key), list) and len(doc[key]) > most:
            P.fail(key, f"{len(doc[key])} entries, more than the {most} allowed")
    obstacles = [
        P.obstacle(item, f"obstacles[{i}]") for i, item in enumerate(P.items(doc.get("obstacles"), "obstacles"))
    ]
    objects = [P.scene_object(item, f"objects[{i}]") for i, item in enumerate(P.items(doc.get("objects"), "objects"))]
    places = [
        P.place(item, f"place_locations[{i}]")
        for i, item in enumerate(P.items(doc.get("place_locations"), "place_locations"))
    ]
    trajectories = P.trajectories(doc.get("trajectories"))
    boxes = [(c.min(axis=0), c.max(axis=0)) for c in (o.corners() for o in objects)]
    cloud_path, cloud = parse_cloud(P, doc.get("obstacle_cloud"), origin, boxes)
    task = P.task(doc["task"], objects, places, trajectories)
    planner = parse_planner(P, doc.get("planner"))

    scene = Scene(
        version=version,
        name=name,
        resolution=resolution,
        bounds=(0.0, 0.0, 1.0, 1.0),
        robot_preset=preset,
        start=(start_x, start_y, start_yaw),
        maps=maps,
        occupancy_map=layers.occupancy_map,
        obstacles=tuple(obstacles),
        objects=tuple(objects),
        place_locations=tuple(places),
        task=tuple(task),
        planner=planner,
        trajectories=tuple(trajectories),
        source=Path(source) if source is not None else None,
        occupancy=layers.occupancy,
        keepout_mask=layers.keepout_mask,
        speed_mask=layers.speed_mask,
        keepout=layers.keepout,
        speed=layers.speed,
        obstacle_cloud=cloud_path,
        cloud=cloud,
    )
    if doc.get("bounds") is not None:
        bounds = P.coords(doc["bounds"], "bounds", 4)
        if not (bounds[0] < bounds[2] and bounds[1] < bounds[3]):
            P.fail("bounds", f"expected [xmin, ymin, xmax, ymax] with xmin < xmax and ymin < ymax, got {list(bounds)}")
    else:
        bounds = default_bounds(scene)
    xmin, ymin, xmax, ymax = (float(b) for b in bounds)
    given = doc.get("bounds") is not None
    return check_scene(replace(scene, bounds=(xmin, ymin, xmax, ymax), bounds_given=given), where)
