"""Simox's extended manipulability: the fast kernels against a plain-numpy reference (docs/design.md)."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from support.manipulability import (
    ROBOT_ARMS,
    SIGNS,
    assert_matches,
    reference,
    reference_jacobian,
    reference_measure,
    reference_penalties,
)
from support.robots import random_configs

import placement


@pytest.fixture
def robot(request):
    return request.getfixturevalue(request.param)


# --------------------------------------------------------------------------------------------
# The reference itself (so that a wrong reference cannot hide a wrong kernel)
# --------------------------------------------------------------------------------------------


def test_reference_penalty_formula_literal():
    lo, hi = np.array([-1.0]), np.array([3.0])
    # t = 2: w = |16 * 2 / (4 * 1 * 9)| = 8/9, nearer the upper limit
    plo, phi = reference_penalties(np.array([2.0]), lo, hi, np.array([False]))
    assert plo[0] == 1.0 and phi[0] == pytest.approx(1 / math.sqrt(1 + 8 / 9), rel=1e-15)
    # t = 0: w = |16 * -2 / (4 * 9 * 1)| = 8/9, nearer the lower limit
    plo, phi = reference_penalties(np.array([0.0]), lo, hi, np.array([False]))
    assert phi[0] == 1.0 and plo[0] == pytest.approx(1 / math.sqrt(1 + 8 / 9), rel=1e-15)
    # at a limit: w = 1e10; continuous: never penalised
    plo, phi = reference_penalties(np.array([3.0]), lo, hi, np.array([False]))
    assert plo[0] == 1.0 and phi[0] == pytest.approx(1 / math.sqrt(1 + 1e10), rel=1e-15)
    plo, phi = reference_penalties(np.array([3.0]), lo, hi, np.array([True]))
    assert plo[0] == phi[0] == 1.0


def test_reference_measure_literal():
    """An isotropic 6x6 Jacobian: isotropy 1, volume = prod of scales; one penalised column lowers both."""
    J = np.diag([2.0, 2.0, 2.0, 2.0, 2.0, 2.0])
    one = np.ones(6)
    assert reference_measure(J, one, one, "isotropy") == pytest.approx(1.0, abs=1e-15)
    assert reference_measure(J, one, one, "volume") == pytest.approx(64.0, rel=1e-15)
    lo = one.copy()
    lo[2] = 0.5  # motion of joint 2 towards its lower limit is halved: worst octant has 1 on column 2
    assert reference_measure(J, lo, one, "isotropy") == pytest.approx(0.5, abs=1e-15)
    assert reference_measure(J, lo, one, "volume") == pytest.approx(32.0, rel=1e-15)


# --------------------------------------------------------------------------------------------
# Kernel against reference
# --------------------------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("index", ["isotropy", "volume"])
@pytest.mark.parametrize("robot,arm_name", ROBOT_ARMS, indirect=["robot"])
def test_random_configurations(robot, arm_name, index):
    arm = robot.arm(arm_name)
    rng = np.random.default_rng(1234)
    Q = random_configs(arm, 40, rng)
    got, want = assert_matches(robot, arm_name, Q, index)
    assert np.all(want > 0) and np.ptp(want) > 0  # non-degenerate inputs


def near_limit_configs(arm, rng, eps: float, n: int, several: bool = False) -> np.ndarray:
    """Random configurations with one (or several) limited joints at distance eps inside a limit."""
    Q = random_configs(arm, n, rng)
    limited = np.flatnonzero(~arm.continuous)
    for i in range(n):
        k = rng.integers(2, len(limited) + 1) if several else 1
        for j in rng.choice(limited, size=k, replace=False):
            Q[i, j] = arm.lower[j] + eps if rng.random() < 0.5 else arm.upper[j] - eps
    return Q


def exact_volume(J, pen_lo, pen_hi) -> float:
    """min_s prod sigma(J_s) = min_s sqrt(det(J_s J_s^T)) (Cauchy-Binet), in exact rational arithmetic.

    Near joint limits the penalised Jacobian is so ill-conditioned (factors down to
    1e-8) that an SVD in float64 is itself only accurate to ~eps/ratio; this
    reference is exact up to the final square root.
    """
    best = None
    for s in SIGNS:
        F = [
            [
                Fraction(float(J[r, j] * (pen_hi[j] if (s[r] >= 0) != (J[r, j] < 0) else pen_lo[j])))
                for j in range(J.shape[1])
            ]
            for r in range(6)
        ]
        A = [[sum((a * b for a, b in zip(F[r], F[c])), Fraction(0)) for c in range(6)] for r in range(6)]
        det = Fraction(1)
        for i in range(6):
            p = next((k for k in range(i, 6) if A[k][i] != 0), None)
            if p is None:
                det = Fraction(0)
                break
            if p != i:
                A[i], A[p] = A[p], A[i]
                det = -det
            det *= A[i][i]
            for k in range(i + 1, 6):
                f = A[k][i] / A[i][i]
                if f:
                    for c in range(i, 6):
                        A[k][c] -= f * A[i][c]
        best = det if best is None else min(best, det)
    return math.sqrt(best)


def test_exact_volume_reference_agrees_with_svd(pr2):
    arm = pr2.arm("right")
    for q in random_configs(arm, 3, np.random.default_rng(4)):
        J = reference_jacobian(pr2, "right", q)
        lo, hi = reference_penalties(q, arm.lower, arm.upper, arm.continuous)
        assert exact_volume(J, lo, hi) == pytest.approx(reference_measure(J, lo, hi, "volume"), rel=1e-12)


@pytest.mark.parametrize("several", [False, True], ids=["one-joint", "several-joints"])
@pytest.mark.parametrize("eps", [1e-3, 1e-8, 0.0], ids=["1e-3", "1e-8", "at-limit"])
@pytest.mark.parametrize("robot,arm_name", [("pr2", "right"), ("armar6", "left")], indirect=["robot"])
def test_near_joint_limits_isotropy(robot, arm_name, eps, several):
    arm = robot.arm(arm_name)
    rng = np.random.default_rng(int(eps * 1e9) + 17 + several)
    Q = near_limit_configs(arm, rng, eps, 12, several)
    assert_matches(robot, arm_name, Q, "isotropy")


@pytest.mark.slow
@pytest.mark.parametrize("several", [False, True], ids=["one-joint", "several-joints"])
@pytest.mark.parametrize("eps", [1e-3, 1e-8, 0.0], ids=["1e-3", "1e-8", "at-limit"])
@pytest.mark.parametrize("robot,arm_name", [("pr2", "right"), ("armar6", "left")], indirect=["robot"])
def test_near_joint_limits_volume(robot, arm_name, eps, several):
    """Volume to 1e-9 relative against the exact reference (the float64 SVD is not accurate enough here).

    Plus 1e-15 absolute: within 1e-8 of a limit the penalised J_s has condition
    numbers ~1e10, and no backward-stable float64 method resolves its
    determinant better than eps * cond relative; 1e-15 is 1e-10 of a typical
    PR2 volume (~1e-5), so values that small are zero for every purpose.
    """
    arm = robot.arm(arm_name)
    rng = np.random.default_rng(int(eps * 1e9) + 17 + several)
    Q = near_limit_configs(arm, rng, eps, 6, several)
    got = placement.extended_manipulability(robot, arm_name, Q, index="volume")
    want = []
    for q in Q:
        J = reference_jacobian(robot, arm_name, q)
        lo, hi = reference_penalties(q, arm.lower, arm.upper, arm.continuous)
        want.append(exact_volume(J, lo, hi))
    np.testing.assert_allclose(got, np.array(want), rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("robot,arm_name", [("pr2", "right"), ("armar6", "right")], indirect=["robot"])
def test_limit_penalty_lowers_value(robot, arm_name):
    """A limited joint exactly at its limit: the value is below the unpenalised one (the penalty acts)."""
    arm = robot.arm(arm_name)
    rng = np.random.default_rng(5)
    q = random_configs(arm, 1, rng)[0]
    j = int(np.flatnonzero(~arm.continuous)[1])
    q[j] = arm.upper[j]
    J = reference_jacobian(robot, arm_name, q)
    unpenalised = reference_measure(J, np.ones(arm.dof), np.ones(arm.dof), "isotropy")
    v = placement.extended_manipulability(robot, arm_name, q)
    assert v < 0.99 * unpenalised
    assert v == pytest.approx(reference(robot, arm_name, q), abs=1e-9)


@pytest.mark.parametrize("robot,arm_name", [("pr2", "right"), ("armar6", "left")], indirect=["robot"])
def test_middle_of_ranges_is_plain_inverse_condition_number(robot, arm_name):
    """At the middle of every joint range the penalties are 1: the value is sigma_min/sigma_max of J."""
    arm = robot.arm(arm_name)
    q = 0.5 * (arm.lower + arm.upper)
    plo, phi = reference_penalties(q, arm.lower, arm.upper, arm.continuous)
    np.testing.assert_array_equal(plo, 1.0)
    np.testing.assert_array_equal(phi, 1.0)
    sv = np.linalg.svd(reference_jacobian(robot, arm_name, q), compute_uv=False)
    got = placement.extended_manipulability(robot, arm_name, q)
    assert isinstance(got, float)
    assert got == pytest.approx(sv.min() / sv.max(), abs=1e-9)
    vol = placement.extended_manipulability(robot, arm_name, q, index="volume")
    assert vol == pytest.approx(float(np.prod(sv)), rel=1e-9)


def test_kernel_penalties_match_reference(pr2, armar6):
    from placement.kernels.manipulability import joint_penalties

    rng = np.random.default_rng(99)
    for robot, arm_name in ((pr2, "right"), (armar6, "left")):
        arm = robot.arm(arm_name)
        for eps in (None, 1e-3, 1e-8, 0.0):
            Q = random_configs(arm, 20, rng) if eps is None else near_limit_configs(arm, rng, eps, 20)
            for q in Q:
                plo, phi = np.empty(arm.dof), np.empty(arm.dof)
                joint_penalties(q, arm.lower, arm.upper, arm.continuous.astype(np.bool_), plo, phi)
                rlo, rhi = reference_penalties(q, arm.lower, arm.upper, arm.continuous)
                np.testing.assert_allclose(plo, rlo, rtol=1e-12, atol=0)
                np.testing.assert_allclose(phi, rhi, rtol=1e-12, atol=0)


def test_scalar_and_batch_agree(pr2):
    arm = pr2.arm("right")
    Q = random_configs(arm, 5, np.random.default_rng(2))
    batch = placement.extended_manipulability(pr2, "right", Q)
    assert batch.shape == (5,)
    for q, v in zip(Q, batch):
        assert placement.extended_manipulability(pr2, "right", q) == v


def test_bad_input(pr2):
    with pytest.raises(placement.PlacementError, match="index"):
        placement.extended_manipulability(pr2, "right", np.zeros(7), index="nope")
    with pytest.raises(placement.PlacementError, match="7 joints"):
        placement.extended_manipulability(pr2, "right", np.zeros(6))
    with pytest.raises(placement.ArmNotFound):
        placement.extended_manipulability(pr2, "middle", np.zeros(7))
