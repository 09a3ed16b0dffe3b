"""The parts of the scene file that version 2 adds: quaternions, poses and named TCP trajectories::

    objects:
      - {name: can, position: [x, y, z], orientation: [qx, qy, qz, qw], size: [sx, sy, sz],
         grasps: [{name: g, poses: [[x, y, z, qx, qy, qz, qw], ...]}]}   # object frame, pre-pose first
    place_locations:
      - {name: shelf, position: [x, y, z], orientations: [[qx, qy, qz, qw], ...]}   # allowed object rotations
    trajectories:                    # world frame, pre-pose first
      - {name: drawer, poses: [[x, y, z, qx, qy, qz, qw], ...]}
    task:
      - {reach: drawer}              # or {reach: [drawer_a, drawer_b]}: the planner picks one

A version 1 file using one of these keys gets "'KEY' needs version: 2". ``orientation`` and ``yaw``
exclude each other; an object without ``grasps`` gets generated ones (grasps.py), and a picked
object for which none fits the gripper is an error.

A pose is ``[x, y, z, qx, qy, qz, qw]`` ([m], quaternion in ROS order); a quaternion must have norm
1 within :data:`~.poses.UNIT_TOLERANCE` and is normalised. A trajectory is ``{name, poses}`` with
1 .. :data:`MAX_POSES` poses, pre-pose first.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np
import numpy.typing as npt

from placement.scene.model import Trajectory
from placement.scene.poses import UNIT_TOLERANCE, normalised
from placement.scene.validate import Validator, fmt
from placement.validation import describe

V2 = 2
MAX_POSES = 100  # poses per trajectory: each is an IK solve when a placement is verified
TRAJECTORY_KEYS = ("name", "poses")
#: keys that only a version 2 scene may use, per part of the file
V2_KEYS = {
    "": ("trajectories",),
    "objects": ("orientation", "grasps"),
    "place_locations": ("orientations",),
    "task": ("reach",),
}


class PoseParser(Validator):
    """Checks of the version 2 values; ``version`` is the scene's format version."""

    version = 1

    def gate(self, item: Any, path: str, part: str) -> None:
        """A version 2 key in a version 1 scene: one line saying so (before any other check)."""
        if self.version >= V2 or not isinstance(item, dict):
            return
        for key in V2_KEYS[part]:
            if key in item:
                where = f"{path}.{key}" if path else key
                self.fail(where, f"'{key}' needs version: 2 (this scene has version: {self.version})")

    def quaternion(self, value: Any, path: str) -> npt.NDArray[np.float64]:
        """A unit quaternion [x, y, z, w] (norm within the tolerance) -> (4,) normalised."""
        q = np.array(self.vector(value, path, 4))
        n = math.hypot(*q)  # no overflow for huge components
        if abs(n - 1.0) > UNIT_TOLERANCE:
            self.fail(
                path,
                f"expected a unit quaternion [x, y, z, w] (ROS order), got norm {fmt(n)} "
                f"(must be 1 within {UNIT_TOLERANCE:g})",
            )
        return normalised(q)

    def pose(self, value: Any, path: str, maximum: float) -> npt.NDArray[np.float64]:
        """``[x, y, z, qx, qy, qz, qw]`` -> (7,) with the quaternion normalised."""
        if not isinstance(value, list) or len(value) != 7:
            got = f"{len(value)} numbers" if isinstance(value, list) else describe(value)
            self.fail(path, f"expected a pose [x, y, z, qx, qy, qz, qw], got {got}")
        xyz = self.vector(value[:3], path, 3, maximum=maximum)
        return np.concatenate([xyz, self.quaternion(value[3:], f"{path}[3:7]")])

    def trajectory(self, item: Any, path: str, maximum: float) -> Trajectory:
        """``{name, poses}`` (the name is checked by the caller's rules) -> :class:`Trajectory`."""
        self.mapping(item, path, TRAJECTORY_KEYS, TRAJECTORY_KEYS)
        name = self.string(item["name"], f"{path}.name")
        poses = item["poses"]
        if not isinstance(poses, list) or not poses:
            got = "an empty list" if isinstance(poses, list) else describe(poses)
            self.fail(
                f"{path}.poses",
                f"expected a list of 1 to {MAX_POSES} poses [x, y, z, qx, qy, qz, qw] (pre-pose first), got {got}",
            )
        if len(poses) > MAX_POSES:
            self.fail(f"{path}.poses", f"expected at most {MAX_POSES} poses, got {len(poses)}")
        return Trajectory(name, np.stack([self.pose(p, f"{path}.poses[{i}]", maximum) for i, p in enumerate(poses)]))

    def grasps(self, value: Any, path: str, maximum: float) -> tuple[Trajectory, ...]:
        """An object's ``grasps``: a non-empty list of trajectories with names unique in the object."""
        if not isinstance(value, list) or not value:
            got = "an empty list (omit 'grasps' to generate them)" if isinstance(value, list) else describe(value)
            self.fail(path, f"expected a list of grasps {{name, poses}}, got {got}")
        out: list[Trajectory] = []
        seen: dict[str, str] = {}
        for i, item in enumerate(value):
            g = self.trajectory(item, f"{path}[{i}]", maximum)
            if g.name in seen:
                self.fail(f"{path}[{i}].name", f"duplicate grasp name '{g.name}' (already used by {seen[g.name]})")
            seen[g.name] = f"{path}[{i}]"
            out.append(g)
        return tuple(out)

    def orientations(self, value: Any, path: str) -> npt.NDArray[np.float64]:
        """A place location's ``orientations``: a non-empty list of quaternions -> (k, 4)."""
        if not isinstance(value, list) or not value:
            got = (
                "an empty list (omit 'orientations' to allow every turn about z)"
                if isinstance(value, list)
                else describe(value)
            )
            self.fail(path, f"expected a list of quaternions [x, y, z, w], got {got}")
        if len(value) > MAX_POSES:
            self.fail(path, f"expected at most {MAX_POSES} orientations, got {len(value)}")
        return np.stack([self.quaternion(q, f"{path}[{i}]") for i, q in enumerate(value)])

    def reach(self, value: Any, path: str, trajectories: Iterable[Trajectory]) -> tuple[str, ...]:
        """A step's ``reach``: one trajectory name or a non-empty list of distinct ones."""
        names = [t.name for t in trajectories]
        items = value if isinstance(value, list) else [value]
        if not items:
            self.fail(path, "expected a trajectory name or a non-empty list of them, got an empty list")
        out: list[str] = []
        for i, n in enumerate(items):
            p = f"{path}[{i}]" if isinstance(value, list) else path
            n = self.string(n, p)
            if n not in names:
                self.fail(p, f"'{n}' is not a trajectory; trajectories: {', '.join(names) or '(none)'}")
            if n in out:
                self.fail(p, f"trajectory '{n}' is listed twice")
            out.append(n)
        return tuple(out)
