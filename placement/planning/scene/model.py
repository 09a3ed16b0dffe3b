"""The scene model: validated, immutable shapes, objects, place locations and the task.

Units are metres and radians; the world frame has z up (ROS REP-103). Built by
:func:`placement.planning.scene.parse_scene`; see that module for the file format.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from ...errors import PlacementError
from ..navgrid import NavGrid
from .occupancy import OccupancyMap

class SceneError(PlacementError):
    """A scene file that cannot be used; the one-line message names the file and the key path."""


class ArrayEq:
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


def frozen_array(values, shape) -> np.ndarray:
    a = np.array(values, dtype=float).reshape(shape)
    a.setflags(write=False)
    return a


def rot2(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True, eq=False)
class Box(ArrayEq):
    """A box: ``center`` (3,) centroid [m], ``size`` (3,) full edge lengths along its own axes [m],
    ``yaw`` about z [rad]."""

    center: np.ndarray
    size: np.ndarray
    yaw: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "center", frozen_array(self.center, (3,)))
        object.__setattr__(self, "size", frozen_array(self.size, (3,)))
        object.__setattr__(self, "yaw", float(self.yaw))

    def corners_xy(self) -> np.ndarray:
        """(4, 2) footprint corners [m], counter-clockwise."""
        hx, hy = self.size[0] / 2, self.size[1] / 2
        local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
        return local @ rot2(self.yaw).T + self.center[:2]

    def bounds_xy(self) -> tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of the footprint [m]."""
        c = self.corners_xy()
        return (float(c[:, 0].min()), float(c[:, 1].min()), float(c[:, 0].max()), float(c[:, 1].max()))


@dataclass(frozen=True, eq=False)
class Cylinder(ArrayEq):
    """A vertical cylinder: ``center`` (3,) centroid [m] (mid-height), ``radius`` and ``height`` [m]."""

    center: np.ndarray
    radius: float
    height: float

    def __post_init__(self):
        object.__setattr__(self, "center", frozen_array(self.center, (3,)))
        object.__setattr__(self, "radius", float(self.radius))
        object.__setattr__(self, "height", float(self.height))

    def bounds_xy(self) -> tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of the footprint disc [m]."""
        x, y, r = float(self.center[0]), float(self.center[1]), self.radius
        return (x - r, y - r, x + r, y + r)


@dataclass(frozen=True, eq=False)
class Polygon(ArrayEq):
    """A vertical prism from the floor, unbounded in height: ``points`` (k, 2) [m], k >= 3."""

    points: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "points", frozen_array(self.points, (-1, 2)))

    def bounds_xy(self) -> tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of the points [m]."""
        p = self.points
        return (float(p[:, 0].min()), float(p[:, 1].min()), float(p[:, 0].max()), float(p[:, 1].max()))


Shape = Box | Cylinder | Polygon


@dataclass(frozen=True, eq=False)
class Obstacle(ArrayEq):
    """Something the base must avoid; ``table`` marks a surface objects stand on (box or cylinder)."""

    name: str
    shape: Shape
    table: bool = False


@dataclass(frozen=True, eq=False)
class SceneObject(ArrayEq):
    """A thing to pick: bounding-box centre ``position`` (3,) [m], ``yaw`` [rad], ``size`` (3,) [m]."""

    name: str
    position: np.ndarray
    yaw: float
    size: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "position", frozen_array(self.position, (3,)))
        object.__setattr__(self, "size", frozen_array(self.size, (3,)))
        object.__setattr__(self, "yaw", float(self.yaw))

    @property
    def box(self) -> Box:
        """The object's bounding box."""
        return Box(self.position, self.size, self.yaw)

    def bounds_xy(self) -> tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of the footprint [m]."""
        return self.box.bounds_xy()


@dataclass(frozen=True, eq=False)
class PlaceLocation(ArrayEq):
    """Where an object is put down: the TCP target ``position`` (3,) [m]."""

    name: str
    position: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "position", frozen_array(self.position, (3,)))


@dataclass(frozen=True)
class TaskStep:
    """One pick/place pair of the task: an object name and a place location name."""

    pick: str
    place: str


@dataclass(frozen=True, eq=False)
class Scene(ArrayEq):
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
        return lookup(self.objects, name, "object")

    def place_location(self, name: str) -> PlaceLocation:
        """The place location called ``name`` (SceneError naming the alternatives)."""
        return lookup(self.place_locations, name, "place location")

    def obstacle(self, name: str) -> Obstacle:
        """The obstacle called ``name`` (SceneError naming the alternatives)."""
        return lookup(self.obstacles, name, "obstacle")

    @property
    def tables(self) -> tuple[Obstacle, ...]:
        """Obstacles marked ``table: true``."""
        return tuple(o for o in self.obstacles if o.table)

    # -- grid ----------------------------------------------------------
    @property
    def grid_shape(self) -> tuple[int, int]:
        """(ny, nx) cells of ``resolution`` covering ``bounds``; cell (i, j) has its centre at
        ``(xmin + (j + 0.5) res, ymin + (i + 0.5) res)``."""
        return grid_shape(self.bounds, self.resolution)

    def nav_grid(self) -> NavGrid:
        """The :class:`~placement.planning.navgrid.NavGrid` over ``bounds``."""
        return NavGrid((self.bounds[0], self.bounds[1]), self.resolution, self.grid_shape)


def lookup(items, name: str, kind: str):
    for item in items:
        if item.name == name:
            return item
    names = ", ".join(i.name for i in items) or "(none)"
    raise SceneError(f"no {kind} '{name}'; {kind}s: {names}")


def grid_shape(bounds, resolution: float) -> tuple[int, int]:
    xmin, ymin, xmax, ymax = bounds
    nx = max(1, math.ceil((xmax - xmin) / resolution - 1e-9))
    ny = max(1, math.ceil((ymax - ymin) / resolution - 1e-9))
    return ny, nx


def is_path(preset: str) -> bool:
    return preset.endswith((".yaml", ".yml")) or "/" in preset or os.sep in preset
