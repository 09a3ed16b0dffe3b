"""The scene file (SPEC section 6, contract version 1): what the robot must do, and where.

Units are metres and radians; the world frame has z up (ROS REP-103) and yaws turn counter-clockwise
about z. Shapes and objects rotate about z only (a ``yaw``), never by a quaternion. Example::

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
    planner: {}                      # optional overrides, keys in PLANNER_KEYS

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
  vertical prism from the floor of unbounded height, given counter-clockwise or clockwise
  (at least 3 points, non-zero area). ``table: true`` needs a box or a cylinder (a surface).
* Default ``bounds``: the axis-aligned extent of all obstacles (rotated box corners, cylinder
  discs, polygon points), objects (rotated footprints), place locations, the start position and the
  occupancy map, grown by 1 m on every side. The start, every object and every place location must
  lie inside ``bounds``. The grid (``bounds`` / ``resolution``) may not exceed ``MAX_GRID_CELLS``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..errors import PlacementError
from .occupancy import OccupancyMap, OccupancyMapError, load_occupancy_map

SCENE_VERSION = 1
DEFAULT_RESOLUTION = 0.05  # [m]
DEFAULT_PRESET = "pr2"
BOUNDS_MARGIN = 1.0  # [m]
MAX_GRID_CELLS = 50_000_000

#: Keys allowed in ``planner:`` (overrides of the planner's defaults) and what they mean.
PLANNER_KEYS: dict[str, str] = {
    "lambda_n": "weight of the navigation cost [1/m], >= 0 (default 1/20)",
    "lambda_m": "weight of the manipulation cost 1/m, >= 0 (default 0.002353)",
    "lambda_nh": "weight of the heuristic cost towards the next step [1/m], >= 0 (default 1/20)",
    "yaw_steps": "number of base yaws tried per cell, integer >= 1 (default 100)",
    "threshold": "manipulability below which a placement is infeasible, >= 0",
    "velocity_lambda": "lambda of the velocity model (Eq. 4), >= 0 (default 1.3)",
    "velocity_k": "exponent k of the velocity model (Eq. 4), > 0 (default 4)",
    "d_max": "distance [m] beyond which obstacles do not slow the base, > 0 (default 1)",
    "grasp_yaws": "gripper yaws of place steps: a count (integer >= 1, evenly spaced) or a list of yaws [rad]",
}

_TOP_KEYS = ("version", "resolution", "bounds", "robot", "maps", "occupancy_map", "obstacles", "objects",
             "place_locations", "task", "planner")
_ROBOT_KEYS = ("preset", "start")
_SHAPES = ("box", "cylinder", "polygon")
_OBSTACLE_KEYS = ("name", *_SHAPES, "table")
_BOX_KEYS = ("center", "size", "yaw")
_CYLINDER_KEYS = ("center", "radius", "height")
_OBJECT_KEYS = ("name", "position", "yaw", "size")
_PLACE_KEYS = ("name", "position")
_TASK_KEYS = ("pick", "place")
_ROTATION_WORDS = ("orientation", "quaternion", "rotation", "rpy", "roll", "pitch", "euler")


class SceneError(PlacementError):
    """A scene file that cannot be used; the one-line message names the file and the key path."""


class _ArrayEq:
    """Value equality for frozen dataclasses that hold numpy arrays (fields with compare=False skipped)."""

    def __eq__(self, other):
        if type(other) is not type(self):
            return NotImplemented
        for f in fields(self):
            if not f.compare:
                continue
            a, b = getattr(self, f.name), getattr(other, f.name)
            if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
                if not np.array_equal(a, b):
                    return False
            elif a != b:
                return False
        return True

    __hash__ = None


def _frozen_array(values, shape) -> np.ndarray:
    a = np.array(values, dtype=float).reshape(shape)
    a.setflags(write=False)
    return a


def _rot2(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True, eq=False)
class Box(_ArrayEq):
    """A box: ``center`` (3,) centroid [m], ``size`` (3,) full edge lengths along its own axes [m],
    ``yaw`` about z [rad]."""

    center: np.ndarray
    size: np.ndarray
    yaw: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "center", _frozen_array(self.center, (3,)))
        object.__setattr__(self, "size", _frozen_array(self.size, (3,)))
        object.__setattr__(self, "yaw", float(self.yaw))

    def corners_xy(self) -> np.ndarray:
        """(4, 2) footprint corners [m], counter-clockwise."""
        hx, hy = self.size[0] / 2, self.size[1] / 2
        local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
        return local @ _rot2(self.yaw).T + self.center[:2]

    def bounds_xy(self) -> tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of the footprint [m]."""
        c = self.corners_xy()
        return (float(c[:, 0].min()), float(c[:, 1].min()), float(c[:, 0].max()), float(c[:, 1].max()))


@dataclass(frozen=True, eq=False)
class Cylinder(_ArrayEq):
    """A vertical cylinder: ``center`` (3,) centroid [m] (mid-height), ``radius`` and ``height`` [m]."""

    center: np.ndarray
    radius: float
    height: float

    def __post_init__(self):
        object.__setattr__(self, "center", _frozen_array(self.center, (3,)))
        object.__setattr__(self, "radius", float(self.radius))
        object.__setattr__(self, "height", float(self.height))

    def bounds_xy(self) -> tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of the footprint disc [m]."""
        x, y, r = float(self.center[0]), float(self.center[1]), self.radius
        return (x - r, y - r, x + r, y + r)


@dataclass(frozen=True, eq=False)
class Polygon(_ArrayEq):
    """A vertical prism from the floor, unbounded in height: ``points`` (k, 2) [m], k >= 3."""

    points: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "points", _frozen_array(self.points, (-1, 2)))

    def bounds_xy(self) -> tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of the points [m]."""
        p = self.points
        return (float(p[:, 0].min()), float(p[:, 1].min()), float(p[:, 0].max()), float(p[:, 1].max()))


Shape = Box | Cylinder | Polygon


@dataclass(frozen=True, eq=False)
class Obstacle(_ArrayEq):
    """Something the base must avoid; ``table`` marks a surface objects stand on (box or cylinder)."""

    name: str
    shape: Shape
    table: bool = False


@dataclass(frozen=True, eq=False)
class SceneObject(_ArrayEq):
    """A thing to pick: bounding-box centre ``position`` (3,) [m], ``yaw`` [rad], ``size`` (3,) [m]."""

    name: str
    position: np.ndarray
    yaw: float
    size: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "position", _frozen_array(self.position, (3,)))
        object.__setattr__(self, "size", _frozen_array(self.size, (3,)))
        object.__setattr__(self, "yaw", float(self.yaw))

    @property
    def box(self) -> Box:
        """The object's bounding box."""
        return Box(self.position, self.size, self.yaw)

    def bounds_xy(self) -> tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of the footprint [m]."""
        return self.box.bounds_xy()


@dataclass(frozen=True, eq=False)
class PlaceLocation(_ArrayEq):
    """Where an object is put down: the TCP target ``position`` (3,) [m]."""

    name: str
    position: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "position", _frozen_array(self.position, (3,)))


@dataclass(frozen=True)
class TaskStep:
    """One pick/place pair of the task: an object name and a place location name."""

    pick: str
    place: str


@dataclass(frozen=True, eq=False)
class Scene(_ArrayEq):
    """A validated scene (see the module docstring for the file format and the decisions).

    Attributes:
        version: scene format version (1).
        name: scene name (the file stem for :func:`load_scene`).
        resolution: navigation grid cell [m].
        bounds: (xmin, ymin, xmax, ymax) [m], given or computed.
        robot_preset: built-in preset name, or absolute path of a preset YAML.
        start: (x, y, yaw) of the robot's base frame [m, m, rad].
        maps: absolute path of the reachability maps, or None.
        occupancy_map: absolute path of the ROS map YAML, or None.
        obstacles, objects, place_locations, task: tuples, in file order.
        planner: overrides of the planner defaults (keys in :data:`PLANNER_KEYS`).
        source: the scene file, if loaded from one (not compared).
        occupancy: the loaded occupancy map, if any (not compared).
    """

    version: int
    name: str
    resolution: float
    bounds: tuple[float, float, float, float]
    robot_preset: str
    start: tuple[float, float, float]
    maps: str | None
    occupancy_map: Path | None
    obstacles: tuple[Obstacle, ...]
    objects: tuple[SceneObject, ...]
    place_locations: tuple[PlaceLocation, ...]
    task: tuple[TaskStep, ...]
    planner: dict = field(default_factory=dict)
    source: Path | None = field(default=None, compare=False)
    occupancy: OccupancyMap | None = field(default=None, compare=False, repr=False)

    # -- look-ups ------------------------------------------------------
    def object(self, name: str) -> SceneObject:
        """The object called ``name`` (SceneError naming the alternatives)."""
        return _lookup(self.objects, name, "object")

    def place_location(self, name: str) -> PlaceLocation:
        """The place location called ``name`` (SceneError naming the alternatives)."""
        return _lookup(self.place_locations, name, "place location")

    def obstacle(self, name: str) -> Obstacle:
        """The obstacle called ``name`` (SceneError naming the alternatives)."""
        return _lookup(self.obstacles, name, "obstacle")

    @property
    def tables(self) -> tuple[Obstacle, ...]:
        """Obstacles marked ``table: true``."""
        return tuple(o for o in self.obstacles if o.table)

    # -- grid ----------------------------------------------------------
    @property
    def grid_shape(self) -> tuple[int, int]:
        """(ny, nx) cells of ``resolution`` covering ``bounds``; cell (i, j) has its centre at
        ``(xmin + (j + 0.5) res, ymin + (i + 0.5) res)``."""
        return _grid_shape(self.bounds, self.resolution)

    def nav_grid(self):
        """The :class:`~placement.planning.navigation.NavGrid` over ``bounds``."""
        from .navigation import NavGrid

        return NavGrid((self.bounds[0], self.bounds[1]), self.resolution, self.grid_shape)

    # -- serialisation -------------------------------------------------
    def to_dict(self, relative_to: str | Path | None = None) -> dict:
        """The scene as a scene-file mapping (plain Python types, bounds always written).

        Paths are absolute, or relative to ``relative_to`` (the directory the file will be in)
        when given.
        """
        def path(p) -> str:
            if relative_to is None:
                return str(p)
            return os.path.relpath(p, Path(relative_to).absolute())

        preset = self.robot_preset
        if _is_path(preset):
            preset = path(preset)
        out: dict[str, Any] = {
            "version": self.version,
            "resolution": self.resolution,
            "bounds": list(self.bounds),
            "robot": {"preset": preset, "start": list(self.start)},
        }
        if self.maps is not None:
            out["maps"] = path(self.maps)
        if self.occupancy_map is not None:
            out["occupancy_map"] = path(self.occupancy_map)
        out["obstacles"] = [_obstacle_dict(o) for o in self.obstacles]
        out["objects"] = [{"name": o.name, "position": _floats(o.position), "yaw": o.yaw,
                           "size": _floats(o.size)} for o in self.objects]
        out["place_locations"] = [{"name": p.name, "position": _floats(p.position)}
                                  for p in self.place_locations]
        out["task"] = [{"pick": t.pick, "place": t.place} for t in self.task]
        out["planner"] = _plain(self.planner)
        return out


def _floats(a) -> list[float]:
    return [float(v) for v in np.asarray(a).ravel()]


def _plain(value):
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _obstacle_dict(o: Obstacle) -> dict:
    s = o.shape
    if isinstance(s, Box):
        shape = {"box": {"center": _floats(s.center), "size": _floats(s.size), "yaw": s.yaw}}
    elif isinstance(s, Cylinder):
        shape = {"cylinder": {"center": _floats(s.center), "radius": s.radius, "height": s.height}}
    else:
        shape = {"polygon": [_floats(p) for p in s.points]}
    out = {"name": o.name, **shape}
    if o.table:
        out["table"] = True
    return out


def _lookup(items, name: str, kind: str):
    for item in items:
        if item.name == name:
            return item
    names = ", ".join(i.name for i in items) or "(none)"
    raise SceneError(f"no {kind} '{name}'; {kind}s: {names}")


def _grid_shape(bounds, resolution: float) -> tuple[int, int]:
    xmin, ymin, xmax, ymax = bounds
    nx = max(1, math.ceil((xmax - xmin) / resolution - 1e-9))
    ny = max(1, math.ceil((ymax - ymin) / resolution - 1e-9))
    return ny, nx


def _is_path(preset: str) -> bool:
    return preset.endswith((".yaml", ".yml")) or "/" in preset or os.sep in preset


# ---------------------------------------------------------------------------------------------------
# parsing


class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate mapping keys (PyYAML silently keeps the last one)."""


def _construct_mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=True)
        try:
            duplicate = key in seen
        except TypeError:
            continue
        if duplicate:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark)
        seen.add(key)
    return yaml.SafeLoader.construct_mapping(loader, node, deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def _join(path: str, key) -> str:
    return f"{path}.{key}" if path else str(key)


def _type_name(v) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "bool"
    if isinstance(v, dict):
        return "mapping"
    if isinstance(v, list):
        return "list"
    if isinstance(v, str):
        return f"string {v[:30]!r}"
    return type(v).__name__


class _Parser:
    def __init__(self, where: str):
        self.where = where

    def fail(self, path: str, msg: str):
        raise SceneError(f"{self.where}: {path}: {msg}" if path else f"{self.where}: {msg}")

    # -- structure -----------------------------------------------------
    def mapping(self, value, path: str, allowed, required=()) -> dict:
        if not isinstance(value, dict):
            self.fail(path, f"expected a mapping, got {_type_name(value)}")
        for key in value:
            if key not in allowed:
                hint = ""
                if str(key).lower() in _ROTATION_WORDS:
                    hint = " (shapes and objects rotate about z only: use 'yaw' [rad])"
                raise SceneError(f"{self.where}: unknown key '{_join(path, key)}'; allowed: "
                                 f"{', '.join(sorted(allowed))}{hint}")
        for key in required:
            if key not in value:
                raise SceneError(f"{self.where}: missing required key '{_join(path, key)}'")
        return value

    def items(self, value, path: str) -> list:
        if value is None:
            return []
        if not isinstance(value, list):
            self.fail(path, f"expected a list, got {_type_name(value)}")
        return value

    # -- scalars -------------------------------------------------------
    def number(self, value, path: str, minimum: float | None = None, strict: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"expected a number, got {_type_name(value)}")
        v = float(value)
        if not math.isfinite(v):
            self.fail(path, f"expected a finite number, got {value}")
        if minimum is not None and (v <= minimum if strict else v < minimum):
            self.fail(path, f"must be {'>' if strict else '>='} {minimum:g}, got {value}")
        return v

    def positive(self, value, path: str) -> float:
        return self.number(value, path, 0.0, strict=True)

    def integer(self, value, path: str, minimum: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(path, f"expected an integer, got {_type_name(value)}")
        if value < minimum:
            self.fail(path, f"must be >= {minimum}, got {value}")
        return value

    def string(self, value, path: str) -> str:
        if not isinstance(value, str) or not value.strip():
            self.fail(path, f"expected a non-empty string, got {_type_name(value)}")
        return value

    def boolean(self, value, path: str) -> bool:
        if not isinstance(value, bool):
            self.fail(path, f"expected true or false, got {_type_name(value)}")
        return value

    def vector(self, value, path: str, n: int, positive: bool = False) -> tuple[float, ...]:
        if not isinstance(value, list):
            self.fail(path, f"expected a list of {n} numbers, got {_type_name(value)}")
        if len(value) != n:
            self.fail(path, f"expected {n} numbers, got {len(value)}")
        conv = self.positive if positive else self.number
        return tuple(conv(v, f"{path}[{i}]") for i, v in enumerate(value))

    # -- scene parts -----------------------------------------------------
    def shape(self, d: dict, path: str) -> Shape:
        kinds = [k for k in _SHAPES if k in d]
        if len(kinds) != 1:
            got = "none" if not kinds else " and ".join(kinds)
            self.fail(path, f"expected exactly one shape ({', '.join(_SHAPES)}), got {got}")
        kind = kinds[0]
        p = f"{path}.{kind}"
        v = d[kind]
        if kind == "box":
            self.mapping(v, p, _BOX_KEYS, ("center", "size"))
            return Box(self.vector(v["center"], f"{p}.center", 3), self.vector(v["size"], f"{p}.size", 3, True),
                       self.number(v.get("yaw", 0.0), f"{p}.yaw"))
        if kind == "cylinder":
            self.mapping(v, p, _CYLINDER_KEYS, _CYLINDER_KEYS)
            return Cylinder(self.vector(v["center"], f"{p}.center", 3), self.positive(v["radius"], f"{p}.radius"),
                            self.positive(v["height"], f"{p}.height"))
        if not isinstance(v, list):
            self.fail(p, f"expected a list of [x, y] points, got {_type_name(v)}")
        if len(v) < 3:
            self.fail(p, f"expected at least 3 points, got {len(v)}")
        pts = np.array([self.vector(q, f"{p}[{i}]", 2) for i, q in enumerate(v)])
        x, y = pts[:, 0], pts[:, 1]
        area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
        scale = max(float(np.ptp(x)), float(np.ptp(y)), 1.0)
        if area <= 1e-12 * scale * scale:
            self.fail(p, "the polygon has zero area (collinear or repeated points)")
        return Polygon(pts)


def _origin_dir(origin_dir) -> Path:
    return Path(os.path.abspath(Path(origin_dir).expanduser()))


def _resolve(value: str, origin: Path) -> Path:
    p = Path(value).expanduser()
    return Path(os.path.normpath(p if p.is_absolute() else origin / p))


def _extend(box, b) -> tuple[float, float, float, float]:
    if box is None:
        return tuple(float(v) for v in b)
    return (min(box[0], b[0]), min(box[1], b[1]), max(box[2], b[2]), max(box[3], b[3]))


def _fmt(v: float) -> str:
    return f"{v:.6g}"


def parse_scene(data: Any, origin_dir: str | Path = ".", name: str = "scene",
                source: str | Path | None = None) -> Scene:
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
    P = _Parser(where)
    origin = _origin_dir(origin_dir)
    if data is None:
        P.fail("", "the scene is empty")
    doc = P.mapping(data, "", _TOP_KEYS, ("version", "robot", "task"))

    version = doc["version"]
    if isinstance(version, bool) or not isinstance(version, int):
        P.fail("version", f"expected an integer, got {_type_name(version)}")
    if version != SCENE_VERSION:
        P.fail("version", f"unsupported scene format version {version}; this build reads version {SCENE_VERSION}")

    resolution = P.positive(doc.get("resolution", DEFAULT_RESOLUTION), "resolution")

    robot = P.mapping(doc["robot"], "robot", _ROBOT_KEYS, ("start",))
    preset = P.string(robot.get("preset", DEFAULT_PRESET), "robot.preset")
    if _is_path(preset):
        preset_path = _resolve(preset, origin)
        if not preset_path.is_file():
            P.fail("robot.preset", f"robot preset file not found: {preset_path}")
        preset = str(preset_path)
    else:
        from ..robots.preset import builtin_presets

        if preset not in builtin_presets():
            P.fail("robot.preset", f"unknown robot '{preset}'; built-in presets: {', '.join(builtin_presets())} "
                                   "(or a path to a robot YAML)")
    start = P.vector(robot["start"], "robot.start", 3)

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

    names: dict[str, str] = {}

    def unique(value, path: str) -> str:
        n = P.string(value, path)
        if n in names:
            P.fail(path, f"duplicate name '{n}' (already used by {names[n]})")
        names[n] = path.rsplit(".", 1)[0]
        return n

    obstacles = []
    for i, item in enumerate(P.items(doc.get("obstacles"), "obstacles")):
        p = f"obstacles[{i}]"
        P.mapping(item, p, _OBSTACLE_KEYS, ("name",))
        nm = unique(item["name"], f"{p}.name")
        shape = P.shape(item, p)
        table = P.boolean(item.get("table", False), f"{p}.table")
        if table and isinstance(shape, Polygon):
            P.fail(f"{p}.table", "a polygon has no height: a table must be a box or a cylinder")
        obstacles.append(Obstacle(nm, shape, table))

    objects = []
    for i, item in enumerate(P.items(doc.get("objects"), "objects")):
        p = f"objects[{i}]"
        P.mapping(item, p, _OBJECT_KEYS, ("name", "position", "size"))
        nm = unique(item["name"], f"{p}.name")
        objects.append(SceneObject(nm, P.vector(item["position"], f"{p}.position", 3),
                                   P.number(item.get("yaw", 0.0), f"{p}.yaw"),
                                   P.vector(item["size"], f"{p}.size", 3, positive=True)))

    places = []
    for i, item in enumerate(P.items(doc.get("place_locations"), "place_locations")):
        p = f"place_locations[{i}]"
        P.mapping(item, p, _PLACE_KEYS, _PLACE_KEYS)
        nm = unique(item["name"], f"{p}.name")
        places.append(PlaceLocation(nm, P.vector(item["position"], f"{p}.position", 3)))

    task_items = doc["task"]
    if not isinstance(task_items, list):
        P.fail("task", f"expected a list of {{pick, place}} steps, got {_type_name(task_items)}")
    if not task_items:
        P.fail("task", "expected at least one {pick, place} step, got an empty list")
    object_names = [o.name for o in objects]
    place_names = [p.name for p in places]
    picked: dict[str, str] = {}
    task = []
    for i, item in enumerate(task_items):
        p = f"task[{i}]"
        P.mapping(item, p, _TASK_KEYS, _TASK_KEYS)
        pick = P.string(item["pick"], f"{p}.pick")
        place = P.string(item["place"], f"{p}.place")
        if pick not in object_names:
            P.fail(f"{p}.pick", f"'{pick}' is not an object; objects: {', '.join(object_names) or '(none)'}")
        if pick in picked:
            P.fail(f"{p}.pick", f"object '{pick}' is already picked in {picked[pick]}")
        if place not in place_names:
            P.fail(f"{p}.place",
                   f"'{place}' is not a place location; place locations: {', '.join(place_names) or '(none)'}")
        picked[pick] = p
        task.append(TaskStep(pick, place))

    planner = {}
    raw_planner = doc.get("planner")
    if raw_planner is not None:
        P.mapping(raw_planner, "planner", PLANNER_KEYS)
        for key, value in raw_planner.items():
            p = f"planner.{key}"
            if key == "yaw_steps":
                planner[key] = P.integer(value, p, 1)
            elif key == "grasp_yaws":
                if isinstance(value, list):
                    if not value:
                        P.fail(p, "expected a count or a non-empty list of yaws [rad], got an empty list")
                    planner[key] = [P.number(v, f"{p}[{j}]") for j, v in enumerate(value)]
                else:
                    planner[key] = P.integer(value, p, 1)
            elif key in ("velocity_k", "d_max"):
                planner[key] = P.positive(value, p)
            else:
                planner[key] = P.number(value, p, 0.0)

    extent = None
    for o in obstacles:
        extent = _extend(extent, o.shape.bounds_xy())
    for o in objects:
        extent = _extend(extent, o.bounds_xy())
    for pl in places:
        extent = _extend(extent, (pl.position[0], pl.position[1]) * 2)
    extent = _extend(extent, (start[0], start[1]) * 2)
    if occupancy is not None:
        extent = _extend(extent, occupancy.extent)

    if doc.get("bounds") is not None:
        bounds = P.vector(doc["bounds"], "bounds", 4)
        if not (bounds[0] < bounds[2] and bounds[1] < bounds[3]):
            P.fail("bounds", f"expected [xmin, ymin, xmax, ymax] with xmin < xmax and ymin < ymax, "
                             f"got {list(bounds)}")
    else:
        m = BOUNDS_MARGIN
        bounds = (extent[0] - m, extent[1] - m, extent[2] + m, extent[3] + m)
    ny, nx = _grid_shape(bounds, resolution)
    if nx * ny > MAX_GRID_CELLS:
        P.fail("resolution", f"bounds [{', '.join(_fmt(b) for b in bounds)}] at {resolution} m give a {nx} x {ny} grid "
                             f"({nx * ny:.3g} cells); at most {MAX_GRID_CELLS:.3g}: coarsen the resolution or "
                             "set smaller bounds")

    def inside(xy, path: str, what: str):
        x, y = float(xy[0]), float(xy[1])
        if not (bounds[0] <= x <= bounds[2] and bounds[1] <= y <= bounds[3]):
            P.fail(path, f"{what} at ({_fmt(x)}, {_fmt(y)}) is outside bounds "
                         f"[{', '.join(_fmt(b) for b in bounds)}]")

    inside(start, "robot.start", "the start position")
    for i, o in enumerate(objects):
        inside(o.position, f"objects[{i}].position", f"object '{o.name}'")
    for i, pl in enumerate(places):
        inside(pl.position, f"place_locations[{i}].position", f"place location '{pl.name}'")

    return Scene(
        version=version, name=name, resolution=resolution, bounds=tuple(float(b) for b in bounds),
        robot_preset=preset, start=tuple(start), maps=maps, occupancy_map=occ_path,
        obstacles=tuple(obstacles), objects=tuple(objects), place_locations=tuple(places), task=tuple(task),
        planner=planner, source=Path(source) if source is not None else None, occupancy=occupancy,
    )


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file (YAML, contract version 1); its name is the file stem.

    Relative paths inside it are resolved against the file's directory. Raises :class:`SceneError`
    (one line naming the file and the key path) for anything that is not a valid scene.
    """
    path = Path(path)
    if not path.is_file():
        raise SceneError(f"scene file not found: {path}")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{path}: cannot read the scene file: {exc}") from None
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise SceneError(f"{path}: not valid YAML: {problem}{where}") from None
    return parse_scene(data, path.parent, path.stem, source=path)


def save_scene(scene: Scene, path: str | Path) -> Path:
    """Write ``scene`` as a scene file (paths relative to its directory); returns the path."""
    path = Path(path)
    path.write_text(yaml.safe_dump(scene.to_dict(relative_to=path.parent), sort_keys=False,
                                   default_flow_style=None))
    return path
