"""Generated grasps of a box in any orientation (scene version 2): the geometry both the scene check (a picked
object without ``grasps`` must have one) and the planner's grasp candidates use, so the two cannot disagree.

The canonical TCP frame has z along the approach direction and y along the closing direction of the gripper
(see docs/planning.md). :func:`box_grasps` gives top grasps along whichever object axis is closest to world up,
and side grasps on each face whose normal is within 30 degrees of horizontal: the TCP on the face centre,
approach horizontal into the face, the pre-pose ``approach`` metres back. Every grasp closes across the object
through its centre where that chord is at most the gripper's opening (the robot preset's
``gripper.max_opening``, default :data:`GRIPPER_OPENING`).

Why side grasps close :data:`SIDE_TILT` above horizontal: with approach and closing both horizontal the TCP x
axis is vertical, the ZYX pitch +-90 degrees, where yaw and roll are not separable; the reachability map's
lookup then reads the bins of yaw 0 whatever the approach direction. On the PR2 maps (0.8-1.05 m, 7 approach
directions) such grasps passed IK in 4 of 10 best placements or fewer for most directions (0 of 10 for some),
against 139 of 140 with the closing axis tilted 10 degrees (pitch 80 degrees, the centre of the top pitch bin
of 9).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypeAlias

import numpy as np
import numpy.typing as npt

from placement.robots.spec import GripperSpec

#: float64 arrays: poses (4, 4) and (P, 4, 4) [m].
FloatArray: TypeAlias = npt.NDArray[np.float64]
#: Something numpy reads as a vector of floats: (3,) positions and sizes [m], (2,) directions.
Vector: TypeAlias = npt.ArrayLike

APPROACH = 0.10  # [m] pre-grasp / pre-place height above the final TCP pose
#: [m] widest chord the gripper closes across when the robot preset does not say (the PR2's)
GRIPPER_OPENING = GripperSpec().max_opening
SIDE_TILT = math.radians(10.0)  # [rad] side grasps' closing axis above horizontal (see the module docstring)
VERTICAL_FACE = 0.5  # |z| of a face normal up to which the face gets side grasps (30 degrees from vertical)
AXES = "xyz"


@dataclass(frozen=True, eq=False)
class Candidate:
    """A named TCP trajectory: ``poses`` (P, 4, 4) in the world frame, pre-pose first.

    ``grasp``: the grasp the object is held by (a pick's own name, a place's pick grasp; None for
    a ``reach``); a place also has the object's pose there, ``object_pose`` (4, 4), and the name of
    the obstacle it is set on, ``support`` (see :mod:`placement.planning.problems.transfer`)."""

    name: str
    poses: FloatArray
    grasp: str | None = None
    object_pose: FloatArray | None = None
    support: str | None = None


def tcp_frame(position: Vector, approach_dir: Vector, closing: Vector, approach: float) -> FloatArray:
    """Two poses (pre, final) (2, 4, 4): z along ``approach_dir``, y along ``closing`` (unit, orthogonal),
    the final TCP at ``position`` (3,) [m], the pre-pose ``approach`` [m] back along z."""
    a, c = np.asarray(approach_dir, dtype=float), np.asarray(closing, dtype=float)
    poses = np.repeat(np.eye(4)[None], 2, axis=0)
    poses[:, :3, :3] = np.column_stack([np.cross(c, a), c, a])
    poses[1, :3, 3] = position
    poses[0, :3, 3] = np.asarray(position, dtype=float) - approach * a
    return poses


def chord(R: FloatArray, size: Vector, direction: Vector) -> float:
    """Length [m] of the line along ``direction`` (3,) through the centre of a box with axes R
    (3, 3) and edge lengths ``size`` (3,) [m], inside the box."""
    d = np.abs(np.asarray(R).T @ np.asarray(direction, dtype=float))
    s = np.asarray(size, dtype=float)
    return float(min(s[m] / d[m] for m in range(3) if d[m] > 1e-12))


def box_grasps(
    pose: FloatArray, size: Vector, opening: float = GRIPPER_OPENING, approach: float = APPROACH
) -> list[Candidate]:
    """Generated grasps of a box centred at ``pose`` (4, 4) with edge lengths ``size`` (3,) [m] along
    its axes (see the module docstring): "top", "top-flipped", then "side-+x", "side--x", ... named
    by the object axis of the face, for a gripper that closes across chords up to ``opening`` [m].
    Empty when the gripper closes across no side."""
    R, p = np.asarray(pose)[:3, :3], np.asarray(pose)[:3, 3]
    sizes = np.asarray(size, dtype=float)
    up = np.array([0.0, 0.0, 1.0])
    k = int(np.argmax(np.abs(R[2])))
    top_axis = R[:, k] * (1.0 if R[2, k] >= 0 else -1.0)
    i, j = (m for m in range(3) if m != k)
    across = R[:, i] if sizes[i] <= sizes[j] else R[:, j]
    out = []
    if min(sizes[i], sizes[j]) <= opening:
        top = p + top_axis * sizes[k] / 2
        out += [
            Candidate("top", tcp_frame(top, -top_axis, across, approach)),
            Candidate("top-flipped", tcp_frame(top, -top_axis, -across, approach)),
        ]
    for m in (i, j):
        for sign in (1.0, -1.0):
            n = sign * R[:, m]
            if abs(n[2]) > VERTICAL_FACE:
                continue
            a = -(n - n[2] * up)
            a /= np.linalg.norm(a)
            c = math.cos(SIDE_TILT) * np.cross(up, a) + math.sin(SIDE_TILT) * up
            if chord(R, sizes, c) <= opening:
                name = f"side-{'+' if sign > 0 else '-'}{AXES[m]}"
                out.append(Candidate(name, tcp_frame(p + n * sizes[m] / 2, a, c, approach)))
    return out
