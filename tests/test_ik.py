"""Inverse kinematics (placement.kinematics.ik): reaches FK poses within limits, reports failure honestly."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.robots import random_configs

from placement.errors import PlacementError
from placement.kinematics.ik import IKResult, solve_ik


def _rot_angle(R1: np.ndarray, R2: np.ndarray) -> float:
    """Angle [rad] of the rotation R1^T R2."""
    c = (np.trace(R1.T @ R2) - 1.0) / 2.0
    return math.acos(min(1.0, max(-1.0, c)))


def _assert_in_limits(arm, q):
    assert q.shape == (arm.dof,)
    lim = ~arm.continuous
    assert np.all(q[lim] >= arm.lower[lim] - 1e-12) and np.all(q[lim] <= arm.upper[lim] + 1e-12)
    assert np.all(q[arm.continuous] >= -math.pi) and np.all(q[arm.continuous] < math.pi)


@pytest.mark.parametrize("arm_name", ["right", "left"])
def test_reaches_fk_poses_of_random_configurations(pr2, arm_name):
    arm = pr2.arm(arm_name)
    qs = random_configs(arm, 30, np.random.default_rng(42))
    solved = 0
    for q in qs:
        T = pr2.tcp_pose(arm_name, q)
        res = solve_ik(pr2, arm_name, T)
        assert isinstance(res, IKResult)
        _assert_in_limits(arm, res.q)
        if not res.success:
            continue
        solved += 1
        # Check with the reference FK, not the solver's own numbers.
        T_ik = pr2.tcp_pose(arm_name, res.q)
        pos_err = float(np.linalg.norm(T_ik[:3, 3] - T[:3, 3]))
        rot_err = _rot_angle(T_ik[:3, :3], T[:3, :3])
        assert pos_err < 1e-3
        assert rot_err < 1e-2
        assert res.pos_err == pytest.approx(pos_err, abs=1e-9)
        assert res.rot_err == pytest.approx(rot_err, abs=1e-6)
    # Random restarts make failures on reachable poses rare (~1 % with 8 seeds).
    assert solved >= 28


def test_seed_near_solution_converges_on_first_attempt(pr2):
    arm = pr2.arm("right")
    q = random_configs(arm, 1, np.random.default_rng(3))[0]
    q = np.clip(q, arm.lower + 0.2, arm.upper - 0.2)
    T = pr2.tcp_pose("right", q)
    res = solve_ik(pr2, "right", T, q_seed=q + 0.05)
    assert res.success and res.attempts == 1
    assert res.iterations < 50


def test_tight_tolerance(pr2):
    arm = pr2.arm("right")
    q = np.clip(random_configs(arm, 1, np.random.default_rng(5))[0], arm.lower + 0.2, arm.upper - 0.2)
    T = pr2.tcp_pose("right", q)
    res = solve_ik(pr2, "right", T, q_seed=q + 0.1, pos_tol=1e-6, rot_tol=1e-6)
    assert res.success
    T_ik = pr2.tcp_pose("right", res.q)
    assert np.linalg.norm(T_ik[:3, 3] - T[:3, 3]) < 1e-6


def test_impossible_target_reports_failure(pr2):
    T = np.eye(4)
    T[:3, 3] = (5.0, 0.0, 1.0)  # 5 m in front of the base: far out of reach
    res = solve_ik(pr2, "right", T)
    assert res.success is False
    assert res.attempts == 8
    assert res.pos_err > 3.0
    _assert_in_limits(pr2.arm("right"), res.q)
    # The reported error is the real error of the returned configuration.
    assert res.pos_err == pytest.approx(np.linalg.norm(pr2.tcp_pose("right", res.q)[:3, 3] - T[:3, 3]), abs=1e-9)


def test_deterministic(pr2):
    arm = pr2.arm("right")
    q = random_configs(arm, 1, np.random.default_rng(11))[0]
    T = pr2.tcp_pose("right", q)
    a = solve_ik(pr2, "right", T, rng_seed=7)
    b = solve_ik(pr2, "right", T, rng_seed=7)
    assert a.success == b.success and a.iterations == b.iterations
    np.testing.assert_array_equal(a.q, b.q)


def test_bad_inputs(pr2):
    with pytest.raises(PlacementError):
        solve_ik(pr2, "right", np.eye(3))
    with pytest.raises(PlacementError):
        solve_ik(pr2, "right", np.eye(4), q_seed=np.zeros(3))
    with pytest.raises(PlacementError):
        solve_ik(pr2, "right", np.eye(4), seeds=0)


def test_armar6_8dof_non_root_base(armar6):
    arm = armar6.arm("right")
    qs = random_configs(arm, 10, np.random.default_rng(0))
    solved = 0
    for q in qs:
        T = armar6.tcp_pose("right", q)
        res = solve_ik(armar6, "right", T)
        _assert_in_limits(arm, res.q)
        if res.success:
            solved += 1
            assert np.linalg.norm(armar6.tcp_pose("right", res.q)[:3, 3] - T[:3, 3]) < 1e-3
    assert solved >= 9


def test_log3_kernel_matches_pinocchio():
    """The IK kernel's rotation error equals pinocchio's log3, also near 0 and near pi."""
    import pinocchio as pin

    from placement.kernels.ik import log3

    rng = np.random.default_rng(21)
    out = np.empty(3)
    for i in range(300):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = [rng.uniform(0, np.pi), 1e-8, np.pi - 1e-6, np.pi - 1e-3, np.pi][i % 5]
        R = pin.exp3(axis * angle)
        log3(R, out)
        want = pin.log3(R)
        if angle > np.pi - 1e-5:  # +-axis*pi are the same rotation
            assert np.linalg.norm(out) == pytest.approx(np.linalg.norm(want), abs=1e-6)
            np.testing.assert_allclose(pin.exp3(out), R, atol=1e-6)
        else:
            np.testing.assert_allclose(out, want, atol=1e-7)


def test_target_rotation_is_orthonormalised_and_a_reflection_refused(pr2):
    """A target whose rotation is off by 1e-6 (rounded text) is re-orthonormalised and reached within
    the tolerances of the exact pose; a reflection is refused in one line."""
    arm = pr2.arm("right")
    q = random_configs(arm, 1, np.random.default_rng(5))[0]
    T = pr2.tcp_pose("right", q)
    noisy = T.copy()
    noisy[:3, :3] += 1e-6 * np.random.default_rng(6).standard_normal((3, 3))
    res = solve_ik(pr2, "right", noisy, q)
    assert res.success
    got = pr2.tcp_pose("right", res.q)
    assert np.linalg.norm(got[:3, 3] - T[:3, 3]) <= 1e-3
    assert _rot_angle(got[:3, :3], T[:3, :3]) <= 1e-2
    mirrored = T.copy()
    mirrored[:3, 0] *= -1.0
    with pytest.raises(PlacementError, match="reflection"):
        solve_ik(pr2, "right", mirrored)


def test_start_outside_the_limits_is_clipped_and_continuous_joints_wrapped(pr2):
    """A seed 3 rad past every limit: the answer lies within the limits, each continuous joint in
    [-pi, pi), and the seed itself is not modified."""
    arm = pr2.arm("left")
    assert arm.continuous.any()  # the PR2's forearm and wrist rolls
    T = pr2.tcp_pose("left", arm.home)
    seed = np.where(arm.continuous, arm.home + 4 * math.pi, arm.upper + 3.0)
    kept = seed.copy()
    res = solve_ik(pr2, "left", T, seed, seeds=1)
    _assert_in_limits(arm, res.q)
    assert np.array_equal(seed, kept)


def test_solvers_are_shared_by_content_and_kept_apart_by_held_joints(pr2):
    """A second robot object loaded from the same preset reuses the first one's solver (same answers);
    the robot with its lift held elsewhere gets its own, and its answers reach the pose by its own FK
    (a solver of the wrong lift would miss by the lift's travel)."""
    import placement
    from placement.kinematics import ik as ik_module

    again = placement.load_robot("pr2")
    assert again is not pr2
    assert ik_module._solver(again, "right") is ik_module._solver(pr2, "right")
    q = random_configs(pr2.arm("right"), 1, np.random.default_rng(8))[0]
    T = pr2.tcp_pose("right", q)
    a, b = solve_ik(pr2, "right", T, q), solve_ik(again, "right", T, q)
    assert a.success and np.array_equal(a.q, b.q)
    low = pr2.with_fixed({"torso_lift_joint": 0.0})
    assert ik_module._solver(low, "right") is not ik_module._solver(pr2, "right")
    T_low = low.tcp_pose("right", q)
    assert np.linalg.norm(T_low[:3, 3] - T[:3, 3]) > 0.1
    res = solve_ik(low, "right", T_low, q)
    assert res.success
    assert np.linalg.norm(low.tcp_pose("right", res.q)[:3, 3] - T_low[:3, 3]) <= 1e-3
