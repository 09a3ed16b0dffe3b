import math

import pytest
from support.steps import placed_step

from placement.planning import InfeasibleStep, PlanResult
from placement.planning.task_time import task_time


def _step(pr2, arm, base, q, travel):
    return placed_step(arm=arm, base=tuple(base), joints=dict(zip(pr2.arm(arm).joints, q)), travel_time_s=travel)


def test_literal_two_steps(pr2):
    a = pr2.arm("right")
    q1 = a.home.copy()
    q1[0] += 1.044  # shoulder pan: 1.044 rad at 2.088 rad/s = 0.5 s
    q2 = q1.copy()
    q2[4] += 2 * math.pi - 0.36  # continuous forearm roll: the short way is 0.36 rad at 3.6 rad/s = 0.1 s
    res = PlanResult(
        "s",
        "sequential",
        {},
        [_step(pr2, "right", [1, 0, math.pi / 2], q1, 2.0), _step(pr2, "right", [1, 0, -math.pi / 2], q2, 0.2)],
    )
    t = task_time(pr2, res, (0, 0, 0))
    # step 0: base max(2.0, (pi/2)/1.0) = 2.0; arm 0.5 -> 2.0
    # step 1: base max(0.2, pi/1.0) = pi; arm 0.1 -> pi
    assert t["steps"][0] == pytest.approx({"base_s": 2.0, "arm_s": 0.5, "torso_s": 0.0, "step_s": 2.0})
    assert t["steps"][1]["arm_s"] == pytest.approx(0.1)
    assert t["total_s"] == pytest.approx(2.0 + math.pi)


def test_failed_task_has_no_time(pr2):
    failed = InfeasibleStep(0, "pick", "x", reason="out of reach")
    assert task_time(pr2, PlanResult("s", "sequential", {}, [failed]), (0, 0, 0)) is None
    assert task_time(pr2, None, (0, 0, 0)) is None
