"""Grasp and place candidates as TCP trajectories (pre-pose first, final pose last).

The canonical TCP frame has z along the approach direction and y along the
closing direction of the gripper (see docs/planning.md). Top grasps approach straight
down (TCP z = world -z): the TCP origin goes to the centre of the object's top
face, from a pre-grasp ``approach`` metres above.

Generated grasps of a box in any orientation (scene version 2, :func:`box_grasps`) live with the scene, in
:mod:`placement.scene.graspable` (the scene refuses a picked object no gripper can hold); they are
re-exported here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from placement.planning.arrays import FloatArray
from placement.scene.graspable import (
    APPROACH,
    AXES,
    GRIPPER_OPENING,
    SIDE_TILT,
    VERTICAL_FACE,
    Candidate,
    Vector,
    box_grasps,
    chord,
    tcp_frame,
)


def _down(position: Vector, closing_xy: Sequence[float], approach: float) -> FloatArray:
    """Two poses (pre, final) with z down, y along ``closing_xy`` (unit 2-vector)."""
    return tcp_frame(position, (0.0, 0.0, -1.0), (closing_xy[0], closing_xy[1], 0.0), approach)


def top_grasps(position: Vector, yaw: float, size: Vector, approach: float = APPROACH) -> list[Candidate]:
    """Top grasps of a box: centre ``position`` (3,) [m], ``yaw`` [rad], ``size`` (3,) [m].

    The gripper closes across the narrower horizontal side; both 180-degree
    variants about the vertical are returned.
    """
    c, s = math.cos(yaw), math.sin(yaw)
    sizes = np.asarray(size, dtype=float)
    across = (c, s) if sizes[0] <= sizes[1] else (-s, c)
    top = np.asarray(position, dtype=float) + (0.0, 0.0, 0.5 * float(sizes[2]))
    return [
        Candidate("top", _down(top, across, approach)),
        Candidate("top-flipped", _down(top, (-across[0], -across[1]), approach)),
    ]


def place_candidates(
    position: Vector, yaws: float | Sequence[float] | FloatArray = 8, approach: float = APPROACH
) -> list[Candidate]:
    """Place trajectories down onto ``position`` (3,) [m] (the TCP target).

    ``yaws``: a count of gripper yaws evenly over 2 pi, or a list of yaws [rad].
    """
    if isinstance(yaws, (Sequence, np.ndarray)):
        angles = [float(a) for a in yaws]
    else:
        angles = [2 * math.pi * k / yaws for k in range(int(yaws))]
    out = []
    for a in angles:
        out.append(
            Candidate(f"place-yaw{round(math.degrees(a))}", _down(position, (math.cos(a), math.sin(a)), approach))
        )
    return out


def in_world(name: str, pose: FloatArray, poses: FloatArray) -> Candidate:
    """A trajectory ``poses`` (P, 4, 4) given in the frame ``pose`` (4, 4) as a world-frame candidate."""
    return Candidate(name, np.asarray(pose) @ np.asarray(poses))


__all__ = [
    "APPROACH",
    "AXES",
    "GRIPPER_OPENING",
    "SIDE_TILT",
    "VERTICAL_FACE",
    "Candidate",
    "Vector",
    "box_grasps",
    "chord",
    "in_world",
    "place_candidates",
    "top_grasps",
]
