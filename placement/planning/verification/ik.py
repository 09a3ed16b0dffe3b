"""Verification of a placement: IK for every pose of the TCP trajectory with the base there."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from placement.errors import PlacementError
from placement.kinematics.ik import IKResult, solve_ik
from placement.planning.arrays import BasePose, FloatArray
from placement.planning.settings import PlannerConfig
from placement.robots import Robot

#: The configuration whose IK tolerances (``ik_pos_tol_m``, ``ik_rot_tol_rad``) and seed count
#: (``ik_seeds``) apply when the caller gives none.
DEFAULTS = PlannerConfig()


def base_matrix(x: float, y: float, yaw: float) -> FloatArray:
    """(4, 4) pose of the base frame on the floor at (x, y) [m], heading ``yaw`` [rad]."""
    B: FloatArray = np.eye(4, dtype=np.float64)
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
        best_q: (n,) the best failed attempt's configuration at that pose (None on success).
    """

    qs: FloatArray
    failed_pose: int | None = None
    residual_m: float = 0.0
    residual_rad: float = 0.0
    best_q: FloatArray | None = None

    @property
    def ok(self) -> bool:
        return self.failed_pose is None

    @property
    def q(self) -> FloatArray:
        """(n,) the configuration at the last pose (only when ``ok``)."""
        out: FloatArray = self.qs[-1]
        return out


#: witness(pose in the base frame (4, 4)) -> (n,) configuration or None
Witness = Callable[[FloatArray], "FloatArray | None"]


def trajectory_ik(
    robot: Robot,
    arm: str,
    poses_world: FloatArray,
    base: BasePose,
    seed: FloatArray,
    witness: Witness | None = None,
    config: PlannerConfig = DEFAULTS,
) -> TrajectoryIK:
    """IK of every pose of ``poses_world`` (P, 4, 4) with the base at ``base`` (x [m], y [m], yaw [rad]).

    Start configurations, in order: for the first pose the map witness of its cell (when
    ``witness`` gives one), then ``seed`` (the arm's configuration after the previous step, its home
    at first) and ``ik_seeds - 1`` random restarts (seeded: deterministic); for later poses the previous
    pose's solution and the restarts first (the arm moves continuously along the trajectory), then
    the witness. (A further start from the home configuration after each failed pose made the IK
    of examples/table_clearing.yaml 2-3 times slower; the random restarts stand in for it.)
    Tolerances ``config.ik_pos_tol_m`` [m] and ``config.ik_rot_tol_rad`` [rad].
    """
    Binv = np.linalg.inv(base_matrix(*base))
    q = np.asarray(seed, dtype=np.float64)
    qs: list[FloatArray] = []
    for i, pose in enumerate(poses_world):
        target = Binv @ pose
        # the seed with restarts before the witness on later poses: a solution found this way is the
        # one found before witnesses existed; the witness is asked for only when it is needed
        starts = ("witness", "seed") if i == 0 else ("seed", "witness")
        best: IKResult | None = None
        for kind in starts:
            start: FloatArray | None
            if kind == "witness":
                start, n = (witness(target) if witness is not None else None), 1
            else:
                start, n = q, config.ik_seeds
            if start is None:
                continue
            res = solve_ik(
                robot, arm, target, start, seeds=n, pos_tol=config.ik_pos_tol_m, rot_tol=config.ik_rot_tol_rad
            )
            if res.success:
                best = res
                break
            if best is None or res.pos_err + 0.1 * res.rot_err < best.pos_err + 0.1 * best.rot_err:
                best = res
        if best is None:  # cannot happen: the seed is always tried
            raise PlacementError(f"trajectory_ik: no IK start for pose {i}")
        if not best.success:
            return TrajectoryIK(
                np.array(qs).reshape(len(qs), len(q)), i, float(best.pos_err), float(best.rot_err), best.q
            )
        q = best.q
        qs.append(q)
    return TrajectoryIK(np.array(qs))
