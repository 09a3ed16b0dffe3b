"""The scene file (SPEC section 6, contract versions 1 and 2): what the robot must do, and where.

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
    occupancy_map: floor.yaml        # optional: ROS map_server map, merged with the obstacles
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
    planner: {}                      # optional overrides, keys in PLANNER_KEYS (config.py)

Version 2 adds keys (6D objects, grasps, place orientations, trajectories, reach steps): see v2.py.

Decisions (where the SPEC is silent):

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

import numpy as np

from placement.planning.config import PLANNER_BOUNDS, PLANNER_KEYS
from placement.robots.preset import builtin_presets
from placement.scene.checks import TOLERANCE, object_penetrates, obstacles_near, overlapping_objects, point_inside
from placement.scene.limits import (
    MAX_COORD,
    MAX_GRID_CELLS,
    MAX_OBJECTS,
    MAX_OBSTACLES,
    MAX_POLYGON_VERTICES,
    MAX_TOTAL_VERTICES,
    RESOLUTION_RANGE,
    default_bounds,
)
from placement.scene.model import (
    Box,
    Cylinder,
    Obstacle,
    PlaceLocation,
    Polygon,
    Scene,
    SceneError,
    SceneObject,
    Shape,
    TaskStep,
    Trajectory,
    grid_shape,
    is_path,
)
from placement.scene.occupancy import OccupancyMapError, load_occupancy_map
from placement.scene.places import check_place_orientations
from placement.scene.v2 import V2, PoseParser
from placement.scene.validate import Validator, fmt
from placement.simplicity import self_crossing
from placement.validation import describe, show

SCENE_VERSIONS = (1, V2)
SCENE_VERSION = V2  # the newest
DEFAULT_RESOLUTION = 0.05  # [m]
DEFAULT_PRESET = "pr2"

TOP_KEYS = (
    "version",
    "resolution",
    "bounds",
    "robot",
    "maps",
    "occupancy_map",
    "obstacles",
    "objects",
    "place_locations",
    "task",
    "planner",
    "trajectories",
)
ROBOT_KEYS = ("preset", "start")
SHAPES = ("box", "cylinder", "polygon")
OBSTACLE_KEYS = ("name", *SHAPES, "table")
BOX_KEYS = ("center", "size", "yaw")
CYLINDER_KEYS = ("center", "radius", "height")
OBJECT_KEYS_V1 = ("name", "position", "yaw", "size")
OBJECT_KEYS = (*OBJECT_KEYS_V1, "orientation", "grasps")
PLACE_KEYS_V1 = ("name", "position")
PLACE_KEYS = (*PLACE_KEYS_V1, "orientations")
TASK_KEYS = ("pick", "place")


class SceneParser(PoseParser):
    """The parts of a scene file; ``names`` collects the names used so far (they are unique).
    ``version``: the scene's format version (version 2 keys are refused below 2)."""

    def __init__(self, where: str, version: int = SCENE_VERSION):
        super().__init__(where, SceneError)
        self.names: dict[str, str] = {}
        self.version = version
        self.vertices = 0  # polygon points so far

    def coords(self, value, path: str, n: int) -> tuple[float, ...]:
        return self.vector(value, path, n, maximum=MAX_COORD)

    def sizes(self, value, path: str, n: int) -> tuple[float, ...]:
        return self.vector(value, path, n, positive=True, maximum=MAX_COORD)

    def unique(self, value, path: str) -> str:
        n = self.string(value, path)
        if n in self.names:
            self.fail(path, f"duplicate name '{n}' (already used by {self.names[n]})")
        self.names[n] = path.rsplit(".", 1)[0]
        return n

    def shape(self, d: dict, path: str) -> Shape:
        kinds = [k for k in SHAPES if k in d]
        if len(kinds) != 1:
            got = "none" if not kinds else " and ".join(kinds)
            self.fail(path, f"expected exactly one shape ({', '.join(SHAPES)}), got {got}")
        kind = kinds[0]
        p = f"{path}.{kind}"
        v = d[kind]
        if kind == "box":
            self.mapping(v, p, BOX_KEYS, ("center", "size"))
            return Box(
                self.coords(v["center"], f"{p}.center", 3),
                self.sizes(v["size"], f"{p}.size", 3),
                self.number(v.get("yaw", 0.0), f"{p}.yaw"),
            )
        if kind == "cylinder":
            self.mapping(v, p, CYLINDER_KEYS, CYLINDER_KEYS)
            return Cylinder(
                self.coords(v["center"], f"{p}.center", 3),
                self.positive(v["radius"], f"{p}.radius", MAX_COORD),
                self.positive(v["height"], f"{p}.height", MAX_COORD),
            )
        if isinstance(v, list) and len(v) > MAX_POLYGON_VERTICES:
            self.fail(p, f"{len(v)} points, more than the {MAX_POLYGON_VERTICES} allowed in one polygon")
        pts = self.points(v, p, 3, MAX_COORD)
        self.vertices += len(pts)
        if self.vertices > MAX_TOTAL_VERTICES:
            self.fail(
                p,
                f"the polygons so far have {self.vertices} points, more than the {MAX_TOTAL_VERTICES} "
                "allowed in one scene",
            )
        for i in range(len(pts)):
            if np.array_equal(pts[i], pts[i - 1]):
                self.fail(f"{p}[{i}]", f"repeats the point before it {[float(c) for c in pts[i]]}")
        x, y = pts[:, 0], pts[:, 1]
        area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
        scale = max(float(np.ptp(x)), float(np.ptp(y)), 1.0)
        if area <= 1e-12 * scale * scale:
            self.fail(p, "the polygon has zero area (collinear or repeated points)")
        crossing = self_crossing(pts)
        if crossing is not None:
            i, j = crossing
            self.fail(
                p,
                f"the polygon crosses or touches itself (edge {i}-{(i + 1) % len(pts)} meets edge "
                f"{j}-{(j + 1) % len(pts)}); list the corners in order around it",
            )
        return Polygon(pts)

    def obstacle(self, item, p: str) -> Obstacle:
        self.mapping(item, p, OBSTACLE_KEYS, ("name",))
        nm = self.unique(item["name"], f"{p}.name")
        shape = self.shape(item, p)
        table = self.boolean(item.get("table", False), f"{p}.table")
        if table and isinstance(shape, Polygon):
            self.fail(f"{p}.table", "a polygon has no height: a table must be a box or a cylinder")
        return Obstacle(nm, shape, table)

    def scene_object(self, item, p: str) -> SceneObject:
        self.gate(item, p, "objects")
        self.mapping(item, p, OBJECT_KEYS if self.version >= V2 else OBJECT_KEYS_V1, ("name", "position", "size"))
        nm = self.unique(item["name"], f"{p}.name")
        position = self.coords(item["position"], f"{p}.position", 3)
        if "orientation" in item and "yaw" in item:
            self.fail(p, "give 'orientation' [x, y, z, w] or 'yaw' [rad], not both")
        yaw = self.number(item.get("yaw", 0.0), f"{p}.yaw")
        q = self.quaternion(item["orientation"], f"{p}.orientation") if "orientation" in item else None
        size = self.sizes(item["size"], f"{p}.size", 3)
        grasps = self.grasps(item["grasps"], f"{p}.grasps", MAX_COORD) if "grasps" in item else ()
        return SceneObject(nm, position, yaw, size, q, grasps)

    def place(self, item, p: str) -> PlaceLocation:
        self.gate(item, p, "place_locations")
        self.mapping(item, p, PLACE_KEYS if self.version >= V2 else PLACE_KEYS_V1, PLACE_KEYS_V1)
        orientations = self.orientations(item["orientations"], f"{p}.orientations") if "orientations" in item else None
        return PlaceLocation(
            self.unique(item["name"], f"{p}.name"), self.coords(item["position"], f"{p}.position", 3), orientations
        )

    def trajectories(self, items) -> list[Trajectory]:
        out = []
        for i, item in enumerate(self.items(items, "trajectories")):
            t = self.trajectory(item, f"trajectories[{i}]", MAX_COORD)
            self.unique(t.name, f"trajectories[{i}].name")
            out.append(t)
        return out

    def planner(self, raw) -> dict:
        out = {}
        if raw is None:
            return out
        self.mapping(raw, "planner", PLANNER_KEYS)
        for key, value in raw.items():
            p, b = f"planner.{key}", PLANNER_BOUNDS[key]
            if b.get("or_list") and isinstance(value, list):
                if not value:
                    self.fail(p, "expected a count or a non-empty list of yaws [rad], got an empty list")
                if len(value) > b["maximum"]:
                    self.fail(p, f"expected at most {b['maximum']} yaws, got {len(value)}")
                out[key] = [self.number(v, f"{p}[{j}]") for j, v in enumerate(value)]
            elif b.get("integer"):
                out[key] = self.integer(value, p, b["minimum"], b["maximum"])
            else:
                out[key] = self.number(value, p, b["minimum"], b.get("strict", False), b["maximum"])
        return out

    def task(self, items, objects, places, trajectories=()) -> list[TaskStep]:
        kind = "{pick, place} or {reach} step" if self.version >= V2 else "{pick, place} step"
        if not isinstance(items, list):
            self.fail("task", f"expected a list of {kind}s, got {describe(items)}")
        if not items:
            self.fail("task", f"expected at least one {kind}, got an empty list")
        object_names = [o.name for o in objects]
        place_names = [p.name for p in places]
        picked: dict[str, str] = {}
        task = []
        for i, item in enumerate(items):
            p = f"task[{i}]"
            self.gate(item, p, "task")
            if self.version >= V2 and isinstance(item, dict) and "reach" in item:
                if "pick" in item or "place" in item:
                    self.fail(p, "a step is {pick, place} or {reach}, not both")
                self.mapping(item, p, ("reach",), ("reach",))
                task.append(TaskStep(reach=self.reach(item["reach"], f"{p}.reach", trajectories)))
                continue
            self.mapping(item, p, (*TASK_KEYS, "reach") if self.version >= V2 else TASK_KEYS, TASK_KEYS)
            pick = self.string(item["pick"], f"{p}.pick")
            place = self.string(item["place"], f"{p}.place")
            if pick not in object_names:
                self.fail(f"{p}.pick", f"'{pick}' is not an object; objects: {', '.join(object_names) or '(none)'}")
            if pick in picked:
                self.fail(f"{p}.pick", f"object '{pick}' is already picked in {picked[pick]}")
            if place not in place_names:
                self.fail(
                    f"{p}.place",
                    f"'{place}' is not a place location; place locations: {', '.join(place_names) or '(none)'}",
                )
            picked[pick] = p
            task.append(TaskStep(pick, place))
        return task


def _resolve(value: str, origin: Path) -> Path:
    p = Path(value).expanduser()
    return Path(os.path.normpath(p if p.is_absolute() else origin / p))


def check_scene(
    scene: Scene, where: str, objects: set[str] | None = None, new_obstacles: set[str] | None = None
) -> Scene:
    """The checks that need the whole scene: the grid size, everything inside ``bounds``, nothing
    inside an obstacle's volume. Raises :class:`SceneError` naming the key path.

    For a change to a scene that passed: ``objects`` (the moved objects) and ``new_obstacles`` (the
    added ones) limit the volume checks to the pairs the change can affect; None checks them all.
    """

    def pair(name: str, obstacle: str) -> bool:
        if objects is None and new_obstacles is None:
            return True
        return name in (objects or ()) or obstacle in (new_obstacles or ())

    P = Validator(where, SceneError)
    if len(scene.obstacles) > MAX_OBSTACLES:
        P.fail("obstacles", f"{len(scene.obstacles)} obstacles, more than the {MAX_OBSTACLES} allowed")
    vertices = sum(len(o.shape.points) for o in scene.obstacles if isinstance(o.shape, Polygon))
    if vertices > MAX_TOTAL_VERTICES:
        P.fail("obstacles", f"the polygons have {vertices} points, more than the {MAX_TOTAL_VERTICES} allowed")
    bounds, resolution = scene.bounds, scene.resolution
    ny, nx = grid_shape(bounds, resolution)
    if nx * ny > MAX_GRID_CELLS:
        P.fail(
            "resolution",
            f"bounds [{', '.join(fmt(b) for b in bounds)}] at {resolution} m give a {nx} x {ny} "
            f"grid ({nx * ny:.3g} cells); at most {MAX_GRID_CELLS:.3g}: coarsen the resolution or "
            "set smaller bounds",
        )

    def inside(xy, path: str, what: str):
        x, y = float(xy[0]), float(xy[1])
        if not (bounds[0] <= x <= bounds[2] and bounds[1] <= y <= bounds[3]):
            P.fail(path, f"{what} at ({fmt(x)}, {fmt(y)}) is outside bounds [{', '.join(fmt(b) for b in bounds)}]")

    inside(scene.start, "robot.start", "the start position")
    near = obstacles_near(scene.obstacles)
    for i, o in enumerate(scene.objects):
        inside(o.position, f"objects[{i}].position", f"object '{o.name}'")
        for ob in near(o.bounds_xy()):
            if pair(o.name, ob.name) and object_penetrates(o, ob.shape):
                P.fail(
                    f"objects[{i}]",
                    f"object '{o.name}' is inside obstacle '{ob.name}' (its bounding box enters "
                    "the obstacle's volume; objects may only touch, e.g. stand on a table)",
                )
    hit = overlapping_objects(scene.objects, objects)
    if hit is not None:
        a, b = (scene.objects[k].name for k in hit)
        P.fail(
            f"objects[{hit[1]}]",
            f"object '{b}' overlaps object '{a}' (their bounding boxes share more than "
            f"{TOLERANCE * 1000:g} mm; objects may touch, e.g. stand on each other)",
        )
    for i, t in enumerate(scene.trajectories):
        inside(t.poses[-1], f"trajectories[{i}].poses[{len(t.poses) - 1}]", f"the end of trajectory '{t.name}'")
    if scene.version >= V2:
        from placement.planning.grasps import (  # grasps imports scene.poses: circular at the top
            GRIPPER_OPENING,
            box_grasps,
        )

        picked = {t.pick for t in scene.task if t.pick is not None}
        for i, o in enumerate(scene.objects):
            if (
                o.name in picked
                and not o.grasps
                and (objects is None or o.name in objects)
                and not box_grasps(o.pose, o.size)
            ):
                P.fail(
                    f"objects[{i}].size",
                    f"object '{o.name}' is wider than the gripper opening "
                    f"({GRIPPER_OPENING} m) across every side: no grasp can be generated; "
                    "give its 'grasps'",
                )
    for i, pl in enumerate(scene.place_locations):
        inside(pl.position, f"place_locations[{i}].position", f"place location '{pl.name}'")
        for ob in near((pl.position[0], pl.position[1]) * 2):
            if pair(pl.name, ob.name) and point_inside(pl.position, ob.shape):
                P.fail(f"place_locations[{i}].position", f"place location '{pl.name}' is inside obstacle '{ob.name}'")
    check_place_orientations(scene, P)
    return scene


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
        preset_path = _resolve(preset, origin)
        if not preset_path.is_file():
            P.fail("robot.preset", f"robot preset file not found: {preset_path}")
        preset = str(preset_path)
    elif preset not in builtin_presets():
        P.fail(
            "robot.preset",
            f"unknown robot '{preset}'; built-in presets: {', '.join(builtin_presets())} (or a path to a robot YAML)",
        )
    start = P.coords(robot["start"], "robot.start", 3)

    maps = None
    if doc.get("maps") is not None:
        maps = str(_resolve(P.string(doc["maps"], "maps"), origin))
    occ_path, occupancy = None, None
    if doc.get("occupancy_map") is not None:
        occ_path = _resolve(P.string(doc["occupancy_map"], "occupancy_map"), origin)
        try:
            occupancy = load_occupancy_map(occ_path)
        except OccupancyMapError as exc:
            P.fail("occupancy_map", str(exc))

    for key, most in (
        ("obstacles", MAX_OBSTACLES),
        ("objects", MAX_OBJECTS),
        ("place_locations", MAX_OBJECTS),
        ("trajectories", MAX_OBJECTS),
        ("task", MAX_OBJECTS),
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
    task = P.task(doc["task"], objects, places, trajectories)
    planner = P.planner(doc.get("planner"))

    scene = Scene(
        version=version,
        name=name,
        resolution=resolution,
        bounds=(0.0, 0.0, 1.0, 1.0),
        robot_preset=preset,
        start=tuple(start),
        maps=maps,
        occupancy_map=occ_path,
        obstacles=tuple(obstacles),
        objects=tuple(objects),
        place_locations=tuple(places),
        task=tuple(task),
        planner=planner,
        trajectories=tuple(trajectories),
        source=Path(source) if source is not None else None,
        occupancy=occupancy,
    )
    if doc.get("bounds") is not None:
        bounds = P.coords(doc["bounds"], "bounds", 4)
        if not (bounds[0] < bounds[2] and bounds[1] < bounds[3]):
            P.fail("bounds", f"expected [xmin, ymin, xmax, ymax] with xmin < xmax and ymin < ymax, got {list(bounds)}")
    else:
        bounds = default_bounds(scene)
    return check_scene(replace(scene, bounds=tuple(float(b) for b in bounds)), where)
