"""The scene model: validated, immutable shapes, objects, place locations and the task.

Units are metres and radians; the world frame has z up (ROS REP-103). Built by
:func:`placement.scene.parse_scene`; see that module for the file format.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import Field, dataclass, field, fields
from pathlib import Path
from typing import Any, ClassVar, Protocol, TypeVar

import numpy as np
import numpy.typing as npt

from placement.errors import PlacementError
from placement.scene.cloud import VoxelCloud
from placement.scene.masks import KeepoutMask, SpeedMask
from placement.scene.navgrid import NavGrid
from placement.scene.occupancy import OccupancyMap
from placement.scene.poses import box_corners, matrix_yaw, pose_matrices, pose_matrix, quaternion_matrix, yaw_quaternion


class SceneError(PlacementError):
    """A scene file that cannot be used; the one-line message names the file and the key path."""


class ArrayEq:
    """Value equality for frozen dataclasses that hold numpy arrays (fields with compare=False skipped)."""

    __dataclass_fields__: ClassVar[dict[str, Field[Any]]]  # set by @dataclass on every subclass

    def __eq__(self, other: object) -> bool:
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

    # unhashable, as a dataclass with eq=True is; typeshed declares object.__hash__ a method, not Optional
    __hash__ = None  # type: ignore[assignment]


def frozen_array(values: npt.ArrayLike, shape: int | tuple[int, ...]) -> npt.NDArray[np.float64]:
    """``values`` as a read-only float array of ``shape``."""
    a = np.array(values, dtype=float).reshape(shape)
    a.setflags(write=False)
    return a


def rot2(yaw: float) -> npt.NDArray[np.float64]:
    """(2, 2) rotation by ``yaw`` [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True, eq=False)
class Box(ArrayEq):
    """A box: ``center`` (3,) centroid [m], ``size`` (3,) full edge lengths along its own axes [m],
    ``yaw`` about z [rad]."""

    center: npt.NDArray[np.float64]
    size: npt.NDArray[np.float64]
    yaw: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", frozen_array(self.center, (3,)))
        object.__setattr__(self, "size", frozen_array(self.size, (3,)))
        object.__setattr__(self, "yaw", float(self.yaw))

    def corners_xy(self) -> npt.NDArray[np.float64]:
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

    center: npt.NDArray[np.float64]
    radius: float
    height: float

    def __post_init__(self) -> None:
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

    points: npt.NDArray[np.float64]

    def __post_init__(self) -> None:
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
class Trajectory(ArrayEq):
    """A named TCP trajectory: ``poses`` (P, 7) rows ``[x, y, z, qx, qy, qz, qw]`` ([m], unit
    quaternions in ROS order), pre-pose first, P >= 1. In the world frame (scene ``trajectories``)
    or in an object's frame (its ``grasps``)."""

    name: str
    poses: npt.NDArray[np.float64]

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", frozen_array(self.poses, (-1, 7)))

    def matrices(self) -> npt.NDArray[np.float64]:
        """(P, 4, 4) the poses as homogeneous matrices."""
        return pose_matrices(self.poses)


@dataclass(frozen=True, eq=False)
class SceneObject(ArrayEq):
    """A thing to pick: its bounding box, centred at ``position`` (3,) [m], with edge lengths
    ``size`` (3,) [m] along its own axes, rotated by ``orientation`` (4,) [x, y, z, w].

    ``yaw`` [rad] is the ZYX yaw of the orientation (the whole rotation for an upright object).
    Without ``orientation`` the object turns by ``yaw`` about z (scene version 1); when both are
    given and disagree, the orientation wins and ``yaw`` is recomputed from it. ``grasps``: the
    user's grasps (TCP trajectories in the object frame), or () to generate them from the box.
    """

    name: str
    position: npt.NDArray[np.float64]
    yaw: float
    size: npt.NDArray[np.float64]
    orientation: npt.NDArray[np.float64] | None = None  # set from ``yaw`` by __post_init__ when None
    grasps: tuple[Trajectory, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", frozen_array(self.position, (3,)))
        object.__setattr__(self, "size", frozen_array(self.size, (3,)))
        yaw = float(self.yaw)
        if self.orientation is None:
            q = yaw_quaternion(yaw)
        else:
            q = np.asarray(self.orientation, dtype=float)
            same = yaw_quaternion(yaw)
            if not (np.allclose(q, same, rtol=0, atol=1e-12) or np.allclose(q, -same, rtol=0, atol=1e-12)):
                yaw = matrix_yaw(quaternion_matrix(q))
        object.__setattr__(self, "orientation", frozen_array(q, (4,)))
        object.__setattr__(self, "yaw", yaw)
        object.__setattr__(self, "grasps", tuple(self.grasps))

    @property
    def upright(self) -> bool:
        """Whether the object turns about z only (its box is a yaw-only :class:`Box`)."""
        q = self.orientation
        assert q is not None  # set by __post_init__
        return bool(q[0] == 0.0 and q[1] == 0.0)

    @property
    def pose(self) -> npt.NDArray[np.float64]:
        """(4, 4) the object frame in the world (bounding-box centre, its axes)."""
        assert self.orientation is not None  # set by __post_init__
        return pose_matrix(self.position, self.orientation)

    @property
    def box(self) -> Box:
        """The object's bounding box about z (exact for an :attr:`upright` object)."""
        return Box(self.position, self.size, self.yaw)

    def corners(self) -> npt.NDArray[np.float64]:
        """(8, 3) corners of the bounding box [m]."""
        return box_corners(self.pose, self.size)

    def bounds_xy(self) -> tuple[float, float, float, float]:
        """Axis-aligned (xmin, ymin, xmax, ymax) of the footprint [m]."""
        if self.upright:
            return self.box.bounds_xy()
        c = self.corners()
        return (float(c[:, 0].min()), float(c[:, 1].min()), float(c[:, 0].max()), float(c[:, 1].max()))


@dataclass(frozen=True, eq=False)
class PlaceLocation(ArrayEq):
    """Where an object is set down: centred on ``position`` (3,) [m] x, y, resting on the highest
    obstacle top at most 0.25 m below its z (else with its lowest point at z; a version 1 file's
    TCP target 0.1 m above a table finds the table), and optionally the object's allowed world
    ``orientations`` (k, 4) [x, y, z, w], each its picked orientation turned about z (None: turned
    by the planner's ``grasp_yaws``). See :mod:`placement.planning.problems.transfer`."""

    name: str
    position: npt.NDArray[np.float64]
    orientations: npt.NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", frozen_array(self.position, (3,)))
        if self.orientations is not None:
            object.__setattr__(self, "orientations", frozen_array(self.orientations, (-1, 4)))


@dataclass(frozen=True)
class TaskStep:
    """One entry of the task: a pick/place pair (an object name and a place location name), or a
    ``reach`` of one of the named world-frame trajectories (alternatives; the planner picks)."""

    pick: str | None = None
    place: str | None = None
    reach: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class Scene(ArrayEq):
    """A validated scene (see the module docstring for the file format and the decisions).

    Attributes:
        version: scene format version (1 or 2).
        name: scene name (the file stem for :func:`load_scene`).
        resolution: navigation grid cell [m].
        bounds: (xmin, ymin, xmax, ymax) [m], given or computed.
        robot_preset: built-in preset name, or absolute path of a preset YAML.
        start: (x, y, yaw) of the robot's base frame [m, m, rad].
        maps: absolute path of the reachability maps, or None.
        occupancy_map: absolute path of the ROS map YAML, or None (the base's map; never the arm's).
        obstacles, objects, place_locations, task: tuples, in file order.
        planner: overrides of the planner defaults (keys in :data:`PLANNER_KEYS`).
        trajectories: named world-frame TCP trajectories for ``reach`` steps (version 2).
        source: the scene file, if loaded from one (not compared).
        occupancy: the loaded occupancy map, if any (not compared).
        keepout_mask, speed_mask: absolute paths of Nav2 filter masks, or None.
        keepout, speed: the loaded masks (not compared; see :mod:`placement.scene.masks`).
        obstacle_cloud: absolute path of a point cloud for the arm's collision model, or None; cloud: it
            as boxes (not compared; see :mod:`placement.scene.cloud`).
        bounds_given: the file gave ``bounds`` (not compared; without them a scene on an occupancy
            map is planned on a window around its task: :mod:`placement.planning.world.window`).
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
    planner: dict[str, Any] = field(default_factory=dict)
    trajectories: tuple[Trajectory, ...] = ()
    source: Path | None = field(default=None, compare=False)
    occupancy: OccupancyMap | None = field(default=None, compare=False, repr=False)
    keepout_mask: Path | None = None
    speed_mask: Path | None = None
    keepout: KeepoutMask | None = field(default=None, compare=False, repr=False)
    speed: SpeedMask | None = field(default=None, compare=False, repr=False)
    bounds_given: bool = field(default=False, compare=False)
    obstacle_cloud: Path | None = None
    cloud: VoxelCloud | None = field(default=None, compare=False, repr=False)

    # -- look-ups ------------------------------------------------------
    def object(self, name: str) -> SceneObject:
        """The object called ``name`` (SceneError naming the alternatives)."""
        return lookup(self.objects, name, "object")

    def place_location(self, name: str) -> PlaceLocation:
        """The place location called ``name`` (SceneError naming the alternatives)."""
        return lookup(self.place_locations, name, "place location")

    def trajectory(self, name: str) -> Trajectory:
        """The trajectory called ``name`` (SceneError naming the alternatives)."""
        return lookup(self.trajectories, name, "trajectory")

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
        """The :class:`~placement.scene.navgrid.NavGrid` over ``bounds``."""
        return NavGrid((self.bounds[0], self.bounds[1]), self.resolution, self.grid_shape)


class Named(Protocol):
    @property
    def name(self) -> str: ...


N = TypeVar("N", bound=Named)


def lookup(items: Sequence[N], name: str, kind: str) -> N:
    """The item of ``items`` called ``name``; SceneError naming the alternatives (``kind``: what they are)."""
    for item in items:
        if item.name == name:
            return item
    names = ", ".join(i.name for i in items) or "(none)"
    plural = kind[:-1] + "ies" if kind.endswith("y") else kind + "s"
    raise SceneError(f"no {kind} '{name}'; {plural}: {names}")


def grid_shape(bounds: Sequence[float], resolution: float) -> tuple[int, int]:
    """(ny, nx) cells of ``resolution`` [m] covering ``bounds`` (xmin, ymin, xmax, ymax) [m]."""
    xmin, ymin, xmax, ymax = bounds
    nx = max(1, math.ceil((xmax - xmin) / resolution - 1e-9))
    ny = max(1, math.ceil((ymax - ymin) / resolution - 1e-9))
    return ny, nx


def is_path(preset: str) -> bool:
    """Whether a robot preset is given as a file path (else it is a built-in preset's name)."""
    return preset.endswith((".yaml", ".yml")) or "/" in preset or os.sep in preset
