"""Verification of a placement: IK for every pose of the TCP trajectory with the base there."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..ik import solve_ik
from ..robots import Robot

#: IK tolerances of a verified pose: position [m], rotation [rad].
POS_TOL, ROT_TOL = 2e-3, 2e-2
#: Start configurations per pose after the witness: the given seed, then random ones.
SEEDS = 4


def base_matrix(x: float, y: float, yaw: float) -> np.ndarray:
    """(4, 4) pose of the base frame on the floor at (x, y) [m], heading ``yaw`` [rad]."""
    B = np.eye(4)
    B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    B[:2, 3] = (x, y)
    return B


@dataclass(frozen=True)
class TrajectoryIK:
    """IK of a whole TCP trajectory at one base placement.

    Attributes:
        qs: (P, n) the arm's configuration at every pose [rad or m] (each seeds the next); on
            failure the poses before ``failed_pose`` only.
        failed_pose: index of the first pose without a solution (None: all solved).
        residual_m, residual_rad: the best attempt's TCP error at that pose: position [m] and
            rotation angle [rad] (0 on success).
        reached: (3,) world position [m] of the TCP of the best failed attempt (None on success).
    """

    qs: np.ndarray
    failed_pose: int | None = None
    residual_m: float = 0.0
    residual_rad: float = 0.0
    reached: np.ndarray | None = None

    @property
    def ok(self) -> bool:
        return self.failed_pose is None

    @property
    def q(self) -> np.ndarray:
        """(n,) the configuration at the last pose (only when ``ok``)."""
        return self.qs[-1]


#: witness(pose in the base frame (4, 4)) -> (n,) configuration or None
Witness = Callable[[np.ndarray], "np.ndarray | None"]


def trajectory_ik(robot: Robot, arm: str, poses_world: np.ndarray, base: tuple[float, float, float],
                  seed: np.ndarray, witness: Witness | None = None) -> TrajectoryIK:
    """IK of every pose of ``poses_world`` (P, 4, 4) with the base at ``base`` (x [m], y [m], yaw [rad]).

    Start configurations, in order: for the first pose the map witness of its cell (when
    ``witness`` gives one), then ``seed`` (the arm's previous configuration); for later poses the
    previous pose's solution first (the arm moves continuously along the trajectory), then the
    witness; each followed by random restarts (seeded: deterministic) and last the arm's home.
    Tolerances :data:`POS_TOL` [m] and :data:`ROT_TOL` [rad].
    """
    B = base_matrix(*base)
    Binv = np.linalg.inv(B)
    home = robot.arm(arm).home
    q = np.asarray(seed, dtype=float)
    qs = []
    for i, pose in enumerate(poses_world):
        target = Binv @ pose
        # the seed with restarts before the witness on later poses: a solution found this way is the
        # one found before witnesses existed; the witness is asked for only when it is needed
        starts = ("witness", "seed", "home") if i == 0 else ("seed", "witness", "home")
        best = None
        for kind in starts:
            if kind == "witness":
                start, n = (witness(target) if witness is not None else None), 1
            elif kind == "seed":
                start, n = q, SEEDS
            else:
                start, n = (None if np.array_equal(home, q) else home), 1
            if start is None:
                continue
            res = solve_ik(robot, arm, target, start, seeds=n, pos_tol=POS_TOL, rot_tol=ROT_TOL)
            if res.success:
                best = res
                break
            if best is None or res.pos_err + 0.1 * res.rot_err < best.pos_err + 0.1 * best.rot_err:
                best = res
        if not best.success:
            reached = (B @ robot.tcp_pose(arm, best.q))[:3, 3]
            return TrajectoryIK(np.array(qs).reshape(len(qs), len(q)), i, float(best.pos_err), float(best.rot_err),
                                reached)
        q = best.q
        qs.append(q)
    return TrajectoryIK(np.array(qs))
