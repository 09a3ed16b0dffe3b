"""ROS 2 standard messages to and from the planner's world: checked on the way in, built on the way out.

In: ``nav_msgs/OccupancyGrid`` (the robot's map) becomes an
:class:`~placement.scene.OccupancyMap`; ``geometry_msgs/PoseStamped`` and
``PoseWithCovarianceStamped`` become a position [m] and a unit quaternion [x, y, z, w]. Each is
refused with a :class:`RosInputError` (one line) when its frame is not the map frame, a number is
not finite, a quaternion is not a rotation, or a grid is malformed or too large.

Out: the plan as ``nav_msgs/Path`` (the base poses in task order) and as a
``visualization_msgs/MarkerArray`` (a footprint, a TCP arrow and a label per placement, the object
set down at each place), all in the map frame; a base pose as ``geometry_msgs/PoseStamped``.
Units are ROS's: metres, radians, quaternions x y z w, z up.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseStamped, PoseWithCovarianceStamped, Quaternion
from nav_msgs.msg import OccupancyGrid, Path
from std_msgs.msg import ColorRGBA, Header, String
from visualization_msgs.msg import Marker, MarkerArray

from placement.errors import PlacementError
from placement.evaluation import task_time
from placement.planning import PlanResult
from placement.robots import Robot
from placement.scene import OccupancyMap, Scene
from placement.scene.grid_values import OCCUPIED_PERCENT, GridValues
from placement.scene.occupancy import DEFAULT_UNKNOWN_COST, MAX_COORD, MAX_IMAGE_PIXELS
from placement.scene.poses import UNIT_TOLERANCE, matrix_yaw, normalised, quaternion_matrix, yaw_quaternion
from placement.validation import strict_json

log = logging.getLogger(__name__)

#: Most cells an OccupancyGrid may hold (the limit of a map image in a scene file).
MAX_GRID_CELLS = MAX_IMAGE_PIXELS
#: [m] a map cell may be this small or this large.
RESOLUTION_RANGE = (1e-3, 10.0)
#: Points of a round footprint's outline.
CIRCLE_POINTS = 24


class RosInputError(PlacementError):
    """A message the planner cannot use (named by its topic, with what is wrong)."""


def _finite(values: Sequence[float], what: str) -> npt.NDArray[np.float64]:
    a = np.array([float(v) for v in values])
    if not np.all(np.isfinite(a)):
        raise RosInputError(f"{what}: not finite ({', '.join(f'{v:g}' for v in a)})")
    if np.any(np.abs(a) > MAX_COORD):
        raise RosInputError(f"{what}: beyond +-{MAX_COORD:g} m ({', '.join(f'{v:g}' for v in a)})")
    return a


def _quaternion(q: Quaternion, what: str) -> npt.NDArray[np.float64]:
    a = np.array([q.x, q.y, q.z, q.w], dtype=float)
    if not np.all(np.isfinite(a)):
        raise RosInputError(f"{what}: orientation not finite ({', '.join(f'{v:g}' for v in a)})")
    n = float(np.linalg.norm(a))
    if abs(n - 1.0) > 1e-3:  # ROS tools send float32-rounded quaternions; 1e-3 accepts those only
        raise RosInputError(f"{what}: orientation is not a unit quaternion [x, y, z, w] (norm {n:.6g})")
    return normalised(a) if abs(n - 1.0) > UNIT_TOLERANCE else a


def check_frame(header: Header, frame: str, what: str) -> None:
    """RosInputError unless ``header.frame_id`` is ``frame`` (a leading '/' ignored, as tf2 does)."""
    got = header.frame_id.lstrip("/")
    if got != frame.lstrip("/"):
        said = f"'{got}'" if got else "no frame_id"
        raise RosInputError(
            f"{what}: pose in {said}, expected the map frame '{frame}' (no tf here: send it in '{frame}')"
        )


def pose_of(pose: Pose, what: str) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(position (3,) [m], unit quaternion (4,) [x, y, z, w]) of a ``geometry_msgs/Pose``."""
    p = pose.position
    return _finite((p.x, p.y, p.z), f"{what}: position"), _quaternion(pose.orientation, what)


def stamped_pose(
    msg: PoseStamped | PoseWithCovarianceStamped, frame: str, what: str
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """:func:`pose_of` a stamped pose after :func:`check_frame`."""
    check_frame(msg.header, frame, what)
    pose = msg.pose.pose if isinstance(msg, PoseWithCovarianceStamped) else msg.pose
    return pose_of(pose, what)


def base_of(msg: PoseStamped | PoseWithCovarianceStamped, frame: str, what: str) -> tuple[float, float, float]:
    """(x [m], y [m], yaw [rad]) of a base pose message (its z and tilt ignored, as Nav2 does)."""
    position, q = stamped_pose(msg, frame, what)
    return float(position[0]), float(position[1]), matrix_yaw(quaternion_matrix(q))


def grid_of(msg: OccupancyGrid, frame: str | None) -> GridValues:
    """The checked values of a ``nav_msgs/OccupancyGrid`` (``frame`` None: any frame but none).

    Refused: no frame or another, a size whose cells do not match ``data``, more than
    :data:`MAX_GRID_CELLS` cells, a resolution outside :data:`RESOLUTION_RANGE`, a tilted or
    non-finite origin, values outside -1..100. An origin turned about z is read as Nav2's costmap and
    AMCL read it (the grid unrotated at its x and y), with a warning.
    """
    what = "/map"
    if frame is None:
        if not msg.header.frame_id.lstrip("/"):
            raise RosInputError(f"{what}: the grid has no frame_id")
    else:
        check_frame(msg.header, frame, what)
    info = msg.info
    w, h = int(info.width), int(info.height)
    if w * h > MAX_GRID_CELLS:
        raise RosInputError(f"{what}: {w} x {h} = {w * h:,} cells, more than the {MAX_GRID_CELLS:,} a map may hold")
    if w == 0 or h == 0:
        raise RosInputError(f"{what}: the grid is empty ({w} x {h} cells)")
    if len(msg.data) != w * h:
        raise RosInputError(f"{what}: data holds {len(msg.data):,} values for {w} x {h} = {w * h:,} cells")
    # a float32 field: 0.05 in the map YAML arrives as 0.0500000007, which shifts a 200th cell by
    # 1.5e-7 m; its shortest float32 decimal is what the map's author wrote
    res = float(str(np.float32(info.resolution))) if math.isfinite(info.resolution) else float(info.resolution)
    if not (math.isfinite(res) and RESOLUTION_RANGE[0] <= res <= RESOLUTION_RANGE[1]):
        raise RosInputError(
            f"{what}: resolution {res:g} m, expected {RESOLUTION_RANGE[0]:g} to {RESOLUTION_RANGE[1]:g} m"
        )
    position, q = pose_of(info.origin, f"{what}: origin")
    if abs(float(q[0])) > 1e-9 or abs(float(q[1])) > 1e-9:
        raise RosInputError(f"{what}: the origin is tilted (quaternion {list(q)}); a map lies in the floor's plane")
    if abs(abs(float(q[3])) - 1.0) > 1e-9:  # as Nav2's costmap and AMCL: the grid unrotated at the origin
        log.warning(
            "%s: origin yaw %.6g rad ignored, as Nav2's costmap and AMCL ignore it: the grid lies unrotated",
            what,
            2.0 * math.atan2(float(q[2]), float(q[3])),
        )
    far = max(abs(position[0]), abs(position[1])) + max(w, h) * res
    if far > MAX_COORD:
        raise RosInputError(f"{what}: the map reaches {far:.3g} m from the origin, beyond +-{MAX_COORD:g} m")
    try:  # rclpy holds the values as array.array('b'): read in place
        values = np.frombuffer(msg.data, dtype=np.int8).reshape(h, w)
    except (TypeError, ValueError):
        values = np.asarray(msg.data, dtype=np.int8).reshape(h, w)
    if np.any(values < -1) or np.any(values > 100):
        raise RosInputError(
            f"{what}: values must be -1 (unknown) or 0..100, got {int(values.min())}..{int(values.max())}"
        )
    return GridValues(values, res, (float(position[0]), float(position[1])), msg.header.frame_id.lstrip("/"))


def occupancy_of(
    msg: OccupancyGrid,
    frame: str | None,
    unknown: str = "occupied",
    occupied_percent: int = OCCUPIED_PERCENT,
    unknown_cost: float = DEFAULT_UNKNOWN_COST,
) -> OccupancyMap:
    """The occupancy map of a checked OccupancyGrid (:func:`grid_of`): cells at or above
    ``occupied_percent`` occupied, -1 unknown (``occupied``, ``free`` or ``cost`` as ``unknown``
    says), the rest free."""
    return grid_of(msg, frame).occupancy(unknown, occupied_percent, unknown_cost)


def header(frame: str, stamp: Time) -> Header:
    return Header(frame_id=frame, stamp=stamp)


def grid_message(
    values: npt.NDArray[np.int8], resolution: float, origin: Sequence[float], frame: str, stamp: Time
) -> OccupancyGrid:
    """An OccupancyGrid of ``values`` (rows, cols) int8 (-1, 0..100; row 0 the lowest y), cell size
    ``resolution`` [m], lower-left corner at ``origin`` (x, y) [m]."""
    msg = OccupancyGrid(header=header(frame, stamp))
    h, w = values.shape
    msg.info.resolution = float(resolution)
    msg.info.width, msg.info.height = int(w), int(h)
    msg.info.map_load_time = stamp
    msg.info.origin.position.x, msg.info.origin.position.y = float(origin[0]), float(origin[1])
    msg.data = np.ascontiguousarray(values, dtype=np.int8).ravel().tolist()
    return msg


def occupancy_grid(occupancy: OccupancyMap, frame: str, stamp: Time) -> OccupancyGrid:
    """An OccupancyGrid of a boolean occupancy map (occupied 100, free 0)."""
    values = np.where(occupancy.occupied, 100, 0).astype(np.int8)
    return grid_message(values, occupancy.resolution, occupancy.origin, frame, stamp)


def pose_message(position: npt.ArrayLike, q: npt.ArrayLike) -> Pose:
    x, y, z = (float(v) for v in np.asarray(position, dtype=float))
    qx, qy, qz, qw = (float(v) for v in np.asarray(q, dtype=float))
    return Pose(position=Point(x=x, y=y, z=z), orientation=Quaternion(x=qx, y=qy, z=qz, w=qw))


def base_pose(base: Sequence[float], frame: str, stamp: Time) -> PoseStamped:
    """A base pose (x [m], y [m], yaw [rad]) on the floor as a PoseStamped."""
    return PoseStamped(header=header(frame, stamp), pose=pose_message((base[0], base[1], 0.0), yaw_quaternion(base[2])))


def matrix_pose(T: npt.NDArray[np.float64]) -> Pose:
    """A (4, 4) homogeneous pose as a Pose."""
    from scipy.spatial.transform import Rotation

    return pose_message(T[:3, 3], Rotation.from_matrix(T[:3, :3]).as_quat())


def plan_path(result: PlanResult, frame: str, stamp: Time) -> Path:
    """The planned steps' base poses in task order (for NavigateThroughPoses); failed steps left out."""
    return Path(
        header=header(frame, stamp), poses=[base_pose(s.base, frame, stamp) for s in result.steps if s.ok and s.base]
    )


def _color(r: float, g: float, b: float, a: float = 1.0) -> ColorRGBA:
    return ColorRGBA(r=r, g=g, b=b, a=a)


def footprint_outline(robot: Robot) -> list[tuple[float, float]]:
    """The base outline in the base frame [m], closed: the polygon, or the circle of its radius."""
    if robot.footprint is not None:
        pts = [(float(x), float(y)) for x, y in robot.footprint]
    else:
        r = robot.footprint_radius
        pts = [(r * math.cos(a), r * math.sin(a)) for a in np.linspace(0, 2 * math.pi, CIRCLE_POINTS, endpoint=False)]
    return [*pts, pts[0]]


def plan_markers(
    result: PlanResult, scene: Scene, robot: Robot, frame: str, stamp: Time, step_times: Sequence[float] | None = None
) -> MarkerArray:
    """RViz markers of a plan: first a DELETEALL (a new plan replaces the old markers), then per
    planned step a footprint (namespace ``footprint``), the final TCP pose (``tcp``, an arrow along
    the TCP's x axis), a label ``step action target / arm / time`` (``label``), and at a place the
    object set down (``object``); ids are the step indices. ``step_times``: each step's time [s]."""
    markers: list[Marker] = [Marker(header=header(frame, stamp), action=Marker.DELETEALL)]
    sizes = {o.name: o.size for o in scene.objects}
    outline = [Point(x=x, y=y, z=0.02) for x, y in footprint_outline(robot)]
    for i, s in enumerate(result.steps):
        if not s.ok:
            continue
        base = pose_message((s.base[0], s.base[1], 0.0), yaw_quaternion(s.base[2]))

        def marker(ns: str, kind: int, pose: Pose, color: ColorRGBA, step: int = s.step) -> Marker:
            return Marker(
                header=header(frame, stamp), ns=ns, id=step, type=kind, action=Marker.ADD, pose=pose, color=color
            )

        fp = marker("footprint", Marker.LINE_STRIP, base, _color(0.1, 0.5, 1.0))
        fp.scale.x = 0.02
        fp.points = outline
        markers.append(fp)
        arrow = marker("tcp", Marker.ARROW, matrix_pose(s.tcp[-1]), _color(1.0, 0.4, 0.0))
        arrow.scale.x, arrow.scale.y, arrow.scale.z = 0.12, 0.015, 0.015
        markers.append(arrow)
        if s.placed_pose is not None and s.object in sizes:
            box = marker("object", Marker.CUBE, matrix_pose(s.placed_pose), _color(0.2, 0.8, 0.3, 0.8))
            box.scale.x, box.scale.y, box.scale.z = (float(v) for v in sizes[s.object])
            markers.append(box)
        when = "" if step_times is None else f" / {step_times[i]:.1f} s"
        label_pose = pose_message((s.base[0], s.base[1], 1.6), (0.0, 0.0, 0.0, 1.0))
        label = marker("label", Marker.TEXT_VIEW_FACING, label_pose, _color(1.0, 1.0, 1.0))
        label.scale.z = 0.12
        label.text = f"{s.step} {s.action} {s.target} / {s.arm}{when}"
        markers.append(label)
    return MarkerArray(markers=markers)


def plan_text(result: PlanResult) -> str:
    """The plan document as ``placement query --json`` prints it."""
    return strict_json(result.to_json(), PlacementError, 2)


def plan_messages(
    result: PlanResult, scene: Scene, robot: Robot, frame: str, stamp: Time, path: Path | None = None
) -> dict[str, object]:
    """What the node publishes for a plan, by topic name under the node: ``plan`` (String, the
    document), ``base_poses`` (Path; ``path`` when it is made already) and ``markers`` (MarkerArray,
    labels with each step's time)."""
    times = task_time(robot, result, scene.start) if result.ok else None
    step_times = None if times is None else [x["step_s"] for x in times["steps"]]
    return {
        "plan": String(data=plan_text(result)),
        "base_poses": plan_path(result, frame, stamp) if path is None else path,
        "markers": plan_markers(result, scene, robot, frame, stamp, step_times),
    }
