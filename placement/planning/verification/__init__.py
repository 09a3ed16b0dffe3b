"""Verification of a placement: what the planner proves before it keeps a base pose.

IK of every TCP pose with the base there (:mod:`.ik`), the verdicts (IK and collision) kept across the
plans of a live planner (:mod:`.verdicts`), the robot's whole configuration at a step (:mod:`.configuration`)
and the exact footprint clearance a plan is checked with (:mod:`.clearance`).
"""

from placement.planning.verification.clearance import scene_clearance
from placement.planning.verification.configuration import (
    Resting,
    actuated_joints,
    fixed_problems,
    held,
    joint_limits,
    out_of_limits,
    pinocchio_q,
    resting,
    velocity_limit,
    world_tcp,
)
from placement.planning.verification.ik import TrajectoryIK, base_matrix, trajectory_ik
from placement.planning.verification.verdicts import CheckKey, Checks

__all__ = [
    "CheckKey",
    "Checks",
    "Resting",
    "TrajectoryIK",
    "actuated_joints",
    "base_matrix",
    "fixed_problems",
    "held",
    "joint_limits",
    "out_of_limits",
    "pinocchio_q",
    "resting",
    "scene_clearance",
    "trajectory_ik",
    "velocity_limit",
    "world_tcp",
]
