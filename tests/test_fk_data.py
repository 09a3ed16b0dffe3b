"""The per-thread pinocchio Data behind ``Robot.tcp_pose``: the same poses as a Data made per call,
from many threads at once."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pinocchio as pin

from placement.robots.model_cache import fk_data


def reference_tcp(robot, arm, q):
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.full_q(arm, q))
    a = robot.arm(arm)
    base = data.oMf[robot.base_frame_id]
    tip = data.oMf[robot.model.getFrameId(a.tip_frame)]
    return (base.inverse() * tip).homogeneous @ a.tcp_offset


def test_tcp_pose_from_threads_equals_a_fresh_data(pr2):
    rng = np.random.default_rng(3)
    jobs = []
    for k in range(64):
        arm = sorted(pr2.arms)[k % 2]
        a = pr2.arm(arm)
        jobs.append((arm, rng.uniform(a.lower, a.upper)))
    want = [reference_tcp(pr2, arm, q) for arm, q in jobs]
    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(lambda job: pr2.tcp_pose(*job), jobs * 4))
    for g, w in zip(got, want * 4):
        np.testing.assert_allclose(g, w, atol=1e-12)


def test_one_data_per_thread_and_model(pr2):
    assert fk_data(pr2.model) is fk_data(pr2.model)
    with ThreadPoolExecutor(1) as pool:
        other = pool.submit(fk_data, pr2.model).result()
    assert other is not fk_data(pr2.model)
