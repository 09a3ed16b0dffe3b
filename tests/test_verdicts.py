"""What the whole-task methods' checks found for a step, as their failure reasons count it."""

from __future__ import annotations

import numpy as np

from placement.collision import CollisionResult
from placement.planning.verification.ik import TrajectoryIK
from placement.planning.verification.verdicts import Checks


def test_tally_counts_one_steps_failures_and_its_commonest_culprit():
    ok, failed = TrajectoryIK(np.zeros((2, 7))), TrajectoryIK(np.zeros((0, 7)), failed_pose=0, residual_m=0.1)
    hit = CollisionResult(False, -0.01, "l_gripper_finger_link vs table")
    other = CollisionResult(False, -0.02, "r_forearm_link vs shelf")
    free = CollisionResult(True, 0.05, "l_gripper_finger_link vs table")  # free: its closest pair, no culprit
    checks = Checks(
        ik={
            (2, None, 0, 10, False): failed,
            (2, None, 1, 10, False): ok,
            (2, None, 0, 11, True): ok,
            (2, None, 2, 12, False): ok,
            (3, None, 0, 10, False): failed,
        },
        collision={
            (2, None, 1, 10, False): hit,
            (2, None, 0, 11, True): hit,
            (2, None, 2, 12, False): other,
            (3, None, 1, 10, False): other,
            (2, 0.1, 1, 13, False): free,
        },
    )
    assert checks.tally(2) == (1, 3, "l_gripper_finger_link vs table")
    assert checks.tally(3) == (1, 1, "r_forearm_link vs shelf")
    assert checks.tally(4) == (0, 0, None)
