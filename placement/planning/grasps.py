"""Grasp and place candidates as TCP trajectories (pre-pose first, final pose last).

The canonical TCP frame has z along the approach direction and y along the
closing direction of the gripper (see README). Top grasps approach straight
down (TCP z = world -z): the TCP origin goes to the centre of the object's top
face, from a pre-grasp ``approach`` metres above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

APPROACH = 0.10  # [m] pre-grasp / pre-place height above the final TCP pose


@dataclass(frozen=True)
class Candidate:
    """A named TCP trajectory: ``poses`` (P, 4, 4) in the world frame, pre-pose first."""

    name: str
    poses: np.ndarray


def _down(position, closing_xy, approach: float) -> np.ndarray:
    """Two poses (pre, final) with z down, y along ``closing_xy`` (unit 2-vector)."""
    dx, dy = closing_xy
    R = np.array([[-dy, dx, 0.0], [dx, dy, 0.0], [0.0, 0.0, -1.0]])
    poses = np.repeat(np.eye(4)[None], 2, axis=0)
    poses[:, :3, :3] = R
    poses[1, :3, 3] = position
    poses[0, :3, 3] = np.asarray(position) + (0.0, 0.0, approach)
    return poses


def top_grasps(position, yaw: float, size, approach: float = APPROACH) -> list[Candidate]:
    """Top grasps of a box: centre ``position`` (3,) [m], ``yaw`` [rad], ``size`` (3,) [m].

    The gripper closes across the narrower horizontal side; both 180-degree
    variants about the vertical are returned.
    """
    c, s = math.cos(yaw), math.sin(yaw)
    across = (c, s) if size[0] <= size[1] else (-s, c)
    top = np.asarray(position, dtype=float) + (0.0, 0.0, 0.5 * float(size[2]))
    return [Candidate("top", _down(top, across, approach)),
            Candidate("top-flipped", _down(top, (-across[0], -across[1]), approach))]


def place_candidates(position, yaws=8, approach: float = APPROACH) -> list[Candidate]:
    """Place trajectories down onto ``position`` (3,) [m] (the TCP target).

    ``yaws``: a count of gripper yaws evenly over 2 pi, or a list of yaws [rad].
    """
    angles = [2 * math.pi * k / yaws for k in range(int(yaws))] if np.isscalar(yaws) else list(yaws)
    out = []
    for a in angles:
        out.append(Candidate(f"place-yaw{round(math.degrees(a))}", _down(position, (math.cos(a), math.sin(a)), approach)))
    return out
