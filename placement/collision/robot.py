"""The robot's collision model: the URDF's ``<collision>`` shapes loaded by pinocchio (meshes through coal).

Mesh files are looked up before pinocchio sees the URDF: ``package://name/rest`` in the given package
folders, then in ``ROS_PACKAGE_PATH`` and the URDF's ancestor folders; ``file://`` and plain paths
(relative to the URDF). With ``strict=False`` (collision checking) a ``<collision>`` element whose mesh
is not found is left out and one :class:`CollisionGeometryWarning` names its links: the check then uses
the shapes that exist (none at all for a URDF without meshes: it always finds the arm free). With
``strict=True`` (map building) a missing mesh is a :class:`~placement.PlacementError`.

Links that carry only a ``<visual>`` have no body for collision checking, as in pinocchio.

Self pairs: every pair with a shape moved by the arm, minus shapes on the same or adjacent links, the
SRDF's disabled pairs, the preset's ``ignore_collisions`` link pairs (modelling artefacts such as
overlapping meshes two joints apart, found by ``placement robots init`` as MoveIt's Setup Assistant
does) and pairs already in contact with every arm idle.
"""

from __future__ import annotations

import threading
import warnings
import weakref
import xml.etree.ElementTree as ET
from collections import OrderedDict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import coal
import numpy as np
import numpy.typing as npt
import pinocchio as pin

from placement.errors import PlacementError
from placement.robots import Robot
from placement.robots.description import package_dirs, read_description, readable_urdf
from placement.robots.model_cache import frame_id


class CollisionGeometryWarning(UserWarning):
    """Some (or all) of a robot's collision shapes could not be loaded; the check uses the rest."""


def resolve_mesh(filename: str, urdf: Path, dirs: list[str]) -> Path | None:
    """The file a URDF mesh ``filename`` names, or None if it does not exist."""
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        for d in dirs:
            p = Path(d) / rest
            if p.is_file():
                return p
        return None
    if filename.startswith("file://"):
        filename = filename[len("file://") :]
    p = Path(filename)
    p = p if p.is_absolute() else Path(urdf).resolve().parent / p
    return p if p.is_file() else None


def usable_urdf(urdf: Path, dirs: list[str]) -> tuple[str, list[str], list[str]]:
    """(URDF text with every mesh path made absolute and the ``<collision>`` elements of unfound meshes
    and degenerate shapes removed, links that lost a shape, what was removed in words)."""
    text, _ = readable_urdf(read_description(Path(urdf), "collision geometry").decode("utf-8", "replace"))
    root = ET.fromstring(text)
    lost: list[str] = []
    missing: list[str] = []
    for link in root.iter("link"):
        name = str(link.get("name"))  # "None" for a nameless link (pinocchio rejects it later)
        for col in link.findall("collision"):
            if degenerate(col):  # a zero, NaN or infinite scale or size: no body (and coal's hull fails)
                link.remove(col)
                missing.append(f"a degenerate shape of link {name}")
                if name not in lost:
                    lost.append(name)
                continue
            mesh = col.find("geometry/mesh")
            if mesh is None:
                continue
            found = resolve_mesh(mesh.get("filename", ""), urdf, dirs)
            if found is None:
                link.remove(col)
                missing.append(f"mesh {mesh.get('filename', '')} not found")
                if name not in lost:
                    lost.append(name)
            else:
                mesh.set("filename", str(found))
    return ET.tostring(root, encoding="unicode"), lost, missing


#: URDF geometry attributes that hold sizes [m] or scale factors, per shape element
SIZES = {"mesh": ("scale",), "box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",)}


def degenerate(collision: ET.Element) -> bool:
    """Whether a ``<collision>`` element's shape has a size or scale that is zero, NaN, infinite or
    not a number (such a shape has no volume to check)."""
    for tag, attrs in SIZES.items():
        el = collision.find(f"geometry/{tag}")
        if el is None:
            continue
        for attr in attrs:
            text = el.get(attr)
            if text is None:
                continue
            try:
                values = [float(v) for v in text.split()]
            except ValueError:
                return True
            if not values or not all(np.isfinite(values)) or any(v == 0.0 for v in values):
                return True
    return False


def load_geometry(
    robot: Robot, extra_dirs: Sequence[Path | str] = (), strict: bool = False
) -> tuple[pin.GeometryModel, list[str]]:
    """(collision GeometryModel without pairs, links whose shapes were left out) of ``robot``.

    Raises :class:`PlacementError` naming the robot when the URDF's geometry does not load, and with
    ``strict`` also when a mesh is missing or there is no shape at all.
    """
    dirs = package_dirs(robot.urdf_path, extra_dirs)
    try:
        text, lost, missing = usable_urdf(robot.urdf_path, dirs)
        if strict and missing:
            raise PlacementError(
                f"robot '{robot.name}': collision geometry of {robot.urdf_path} does not load "
                f"({missing[0]}); build without self-collision"
            )
        geom = pin.buildGeomFromUrdfString(robot.model, text, pin.GeometryType.COLLISION, None, dirs)
    except PlacementError:
        raise
    except Exception as exc:  # ET.ParseError, pinocchio's ValueError/RuntimeError with multi-line messages
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise PlacementError(
            f"robot '{robot.name}': collision geometry of {robot.urdf_path} does not load ({first})"
        ) from None
    if strict and geom.ngeoms == 0:
        raise PlacementError(
            f"robot '{robot.name}': the URDF has no <collision> shapes (collision geometry); "
            "build without self-collision"
        )
    return geom, lost


def moved_joints(model: pin.Model, joint_ids: Iterable[int]) -> set[int]:
    """The joints ``joint_ids`` and every joint below them in the kinematic tree."""
    moved = set(int(j) for j in joint_ids)
    for j in range(1, model.njoints):
        k = j
        while k > 0:
            if k in moved:
                moved.add(j)
                break
            k = model.parents[k]
    return moved


def adjacent(model: pin.Model, j1: int, j2: int) -> bool:
    """Shapes on the same or on parent/child joints touch by design."""
    return j1 == j2 or model.parents[j1] == j2 or model.parents[j2] == j1


def convex_hull(geometry: coal.CollisionGeometry) -> tuple[coal.CollisionGeometry, bool]:
    """(convex hull of a mesh, False), or (the geometry itself, True) for primitives, convex shapes and
    meshes that span no volume (flat, a line, a point: their own bound)."""
    if isinstance(geometry, coal.BVHModelBase):
        if not spans_volume(np.asarray(geometry.vertices(), dtype=float)):
            return geometry, True  # qhull inside coal ends the process on such a mesh, it does not raise
        try:
            geometry.buildConvexHull(False, "Qt")
            return geometry.convex, False
        except Exception:  # qhull refused the mesh: then it is its own bound
            return geometry, True
    return geometry, True


#: A mesh thinner than this [m], or than this share of its largest extent, spans no volume for qhull.
FLAT_M = 1e-6


def spans_volume(vertices: npt.NDArray[np.float64]) -> bool:
    """Whether the (n, 3) ``vertices`` [m] span three dimensions: at least 4, finite, and thicker than
    :data:`FLAT_M` (absolute and relative to the largest extent) along every principal axis (an ArUco
    marker's plate of 4 vertices, as the Stretch's URDF holds, is flat)."""
    v = np.asarray(vertices, dtype=float).reshape(-1, 3)
    if len(v) < 4 or not np.isfinite(v).all():
        return False
    centred = v - v.mean(axis=0)
    axes = np.linalg.svd(centred, full_matrices=False)[2]
    extents = np.ptp(centred @ axes.T, axis=0)  # along each principal axis, largest first
    return bool(extents[-1] > max(FLAT_M, FLAT_M * extents[0]))


def transform(M: pin.SE3) -> coal.Transform3s:
    return coal.Transform3s(M.rotation, M.translation)


@dataclass(frozen=True)
class ArmShapes:
    """Shape indices of one arm: ``moving`` (moved by its joints), ``gripper`` (moved by its last joint
    or carrying the tip frame), ``static`` (the rest) and ``self_pairs`` (K, 2) checked against each other."""

    moving: npt.NDArray[np.int_]
    gripper: npt.NDArray[np.int_]
    static: npt.NDArray[np.int_]
    self_pairs: npt.NDArray[np.int_]


class RobotGeometry:
    """A robot's collision shapes and what the scene checker needs of them. Use :func:`robot_geometry`.

    Attributes:
        geom: pinocchio GeometryModel (no collision pairs registered).
        names: (G,) link name of each shape (culprit names).
        lost: links whose shapes were left out (missing meshes).
        centre, radius: (G, 3), (G,) bounding sphere of each shape in its own frame [m].
        half: (G, 3) half extents [m] of each shape's bounding box in its own frame, centred on ``centre``.
        home_q: pinocchio configuration: the preset's fixed joints, every arm at its ``idle``
            configuration (the preset's, by default home).
        base_in_model: (4, 4) pose of the base frame in the model's root frame at ``home_q``.
    """

    def __init__(self, robot: Robot, extra_dirs: Sequence[Path | str] = ()):
        self.robot = robot
        model = robot.model
        self.geom, self.lost, hulls = _shapes(robot, extra_dirs)
        if self.lost_message():
            warnings.warn(f"robot '{robot.name}': {self.lost_message()}", CollisionGeometryWarning, stacklevel=3)
        objs = self.geom.geometryObjects
        self.names = [model.frames[o.parentFrame].name for o in objs]
        self.joint = np.array([o.parentJoint for o in objs], dtype=int)
        self.hulls = [h for h, _ in hulls]
        self.exact = np.array([e for _, e in hulls], dtype=bool)  # the hull is the shape itself
        self.centre = np.array([np.asarray(o.geometry.aabb_center) for o in objs]).reshape(-1, 3)
        self.radius = np.array([o.geometry.aabb_radius for o in objs], dtype=float)
        self.half = np.array(
            [0.5 * (np.asarray(o.geometry.aabb_local.max_) - np.asarray(o.geometry.aabb_local.min_)) for o in objs]
        ).reshape(-1, 3)
        q = robot.reference_q()
        for name in robot.arms:
            q = robot.full_q(name, cast(np.ndarray, robot.arm(name).idle), q)  # (never None: Arm.__post_init__)
        self.home_q = q
        self.data = model.createData()
        self.gdata = pin.GeometryData(self.geom)
        pin.framesForwardKinematics(model, self.data, q)
        self.base_in_model = self.data.oMf[robot.base_frame_id].homogeneous.copy()
        pin.updateGeometryPlacements(model, self.data, self.geom, self.gdata, q)
        self.home_placements = [pin.SE3(M) for M in self.gdata.oMg]
        self._arms: dict[str, ArmShapes] = {}

    def lost_message(self) -> str:
        """What of the robot's collision geometry did not load ("" when everything did)."""
        if not self.lost and self.geom.ngeoms:
            return ""
        what = (
            f"links without their collision meshes: {', '.join(self.lost)}"
            if self.lost
            else "the URDF has no <collision> shapes"
        )
        return f"{what}; collision checks use the {self.geom.ngeoms} shapes that loaded"

    def arm_shapes(self, arm: str) -> ArmShapes:
        """The :class:`ArmShapes` of ``arm`` (computed once)."""
        if arm not in self._arms:
            self._arms[arm] = self._make_arm(arm)
        return self._arms[arm]

    def _make_arm(self, arm: str) -> ArmShapes:
        robot, model, geom = self.robot, self.robot.model, self.geom
        a = robot.arm(arm)
        moved = moved_joints(model, a.joint_ids)
        tip_joint = model.frames[frame_id(model, a.tip_frame)].parentJoint
        hand = moved_joints(model, [a.joint_ids[-1], tip_joint])
        moving = np.array([g for g in range(geom.ngeoms) if int(self.joint[g]) in moved], dtype=int)
        gripper = np.array([g for g in range(geom.ngeoms) if int(self.joint[g]) in hand], dtype=int)
        static = np.array([g for g in range(geom.ngeoms) if int(self.joint[g]) not in moved], dtype=int)
        return ArmShapes(moving, gripper, static, self._self_pairs(moved))

    def _self_pairs(self, moved: set[int]) -> npt.NDArray[np.int_]:
        """Pairs with a shape moved by the arm, minus same/adjacent links, the SRDF's disabled pairs, the
        preset's ``ignore_collisions`` and pairs already in contact with every arm at home (they touch by
        design or by the model's slack)."""
        robot, model = self.robot, self.robot.model
        work = pin.GeometryModel()
        for o in self.geom.geometryObjects:
            work.addGeometryObject(o)
        work.addAllCollisionPairs()
        if robot.srdf_path is not None:
            pin.removeCollisionPairs(model, work, str(robot.srdf_path))
        req, res = coal.CollisionRequest(), coal.CollisionResult()
        keep = []
        for cp in work.collisionPairs:
            i, j = cp.first, cp.second
            ji, jj = int(self.joint[i]), int(self.joint[j])
            if adjacent(model, ji, jj) or (ji not in moved and jj not in moved):
                continue
            if frozenset((self.names[i], self.names[j])) in robot.ignore_collisions:
                continue
            res.clear()
            if coal.collide(
                self.geom.geometryObjects[i].geometry,
                transform(self.home_placements[i]),
                self.geom.geometryObjects[j].geometry,
                transform(self.home_placements[j]),
                req,
                res,
            ):
                continue
            keep.append((i, j))
        return np.array(keep, dtype=int).reshape(-1, 2)


#: Robots' shapes (meshes loaded, convex hulls built) and geometries kept in memory, by content.
GEOMETRY_CACHE_SIZE = 16
_SHAPES: OrderedDict[
    tuple[str, ...], tuple[pin.GeometryModel, list[str], list[tuple[coal.CollisionGeometry, bool]]]
] = OrderedDict()
_GEOMETRIES: OrderedDict[tuple[object, ...], RobotGeometry] = OrderedDict()
_LOCK = threading.Lock()
#: robot objects told already what of their geometry did not load
_WARNED: weakref.WeakSet[Robot] = weakref.WeakSet()


def _remember(cache: OrderedDict[Any, Any], key: Any, value: Any) -> Any:
    with _LOCK:
        cache[key] = cache.get(key, value)
        cache.move_to_end(key)
        while len(cache) > GEOMETRY_CACHE_SIZE:
            cache.popitem(last=False)
        return cache[key]


def _shapes(
    robot: Robot, extra_dirs: Sequence[Path | str]
) -> tuple[pin.GeometryModel, list[str], list[tuple[coal.CollisionGeometry, bool]]]:
    """(shapes, links left out, (convex hull, hull is the shape) per shape) of the robot's URDF, loaded
    once per URDF content and package folders: a robot with other fixed joints (a torso setting, a
    preset loaded again) has the same shapes."""
    key = (str(robot.urdf_path), robot.urdf_sha256, *(str(d) for d in extra_dirs))
    with _LOCK:
        hit = _SHAPES.get(key)
    if hit is None:
        geom, lost = load_geometry(robot, extra_dirs, strict=False)
        for o in geom.geometryObjects:
            o.geometry.computeLocalAABB()
        # convex hulls of the meshes: GJK on them is 10-100x faster than on the triangles, and their
        # distances are lower bounds of the meshes' (exact queries are made only when that can matter)
        hit = _remember(_SHAPES, key, (geom, lost, [convex_hull(o.geometry) for o in geom.geometryObjects]))
    return hit


def robot_geometry(robot: Robot, extra_dirs: Sequence[Path | str] = ()) -> RobotGeometry:
    """The :class:`RobotGeometry` of ``robot`` and package folders, made once per content (the URDF, the
    SRDF, the base frame, the fixed joints, the arms' idle configurations and ignored pairs): a planner
    made again for the same robot reuses its shapes and each arm's self pairs."""
    key = (
        str(robot.urdf_path),
        robot.urdf_sha256,
        str(robot.srdf_path),
        robot.base_frame,
        tuple(sorted(robot.fixed_joints.items())),
        tuple((a, np.asarray(robot.arm(a).idle, dtype=float).tobytes()) for a in robot.arms),
        robot.ignore_collisions,
        tuple(str(d) for d in extra_dirs),
    )
    with _LOCK:
        hit = _GEOMETRIES.get(key)
    if hit is not None:
        if hit.lost_message() and robot not in _WARNED:  # said once for every robot object that loads it
            warnings.warn(f"robot '{robot.name}': {hit.lost_message()}", CollisionGeometryWarning, stacklevel=2)
        _WARNED.add(robot)
        return hit
    _WARNED.add(robot)
    made: RobotGeometry = _remember(_GEOMETRIES, key, RobotGeometry(robot, extra_dirs))
    return made
