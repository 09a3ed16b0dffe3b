"""Verification of a placement: IK for every pose of the TCP trajectory with the base there."""

from __future__ import annotations

import math

import numpy as np

from ..ik import solve_ik
from ..robots import Robot


def base_matrix(x: float, y: float, yaw: float) -> np.ndarray:
    """(4, 4) pose of the base frame on the floor at (x, y) [m], heading ``yaw`` [rad]."""
    B = np.eye(4)
    B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    B[:2, 3] = (x, y)
    return B


def trajectory_ik(robot: Robot, arm: str, poses_world: np.ndarray, base: tuple[float, float, float],
                  seed: np.ndarray) -> np.ndarray | None:
    """Joint angles (n,) [rad or m] reaching the last pose of ``poses_world`` (P, 4, 4), having reached
    each earlier pose in turn (each solution seeds the next), or None if a pose has no solution.

    Tolerances 2 mm and 0.02 rad; 4 seeds per pose (``seed`` first).
    """
    Binv = np.linalg.inv(base_matrix(*base))
    q = np.asarray(seed, dtype=float)
    for pose in poses_world:
        res = solve_ik(robot, arm, Binv @ pose, q, seeds=4, pos_tol=2e-3, rot_tol=2e-2)
        if not res.success:
            return None
        q = res.q
    return q
