"""Extended manipulability written from its definition (docs/design.md) in plain numpy (slow, obviously correct).

The reference the kernels are tested against, and the kernels' inputs for one configuration batch.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pinocchio as pin

import placement

ROT_SCALE = 0.15
SIGNS = np.array(list(itertools.product((1.0, -1.0), repeat=6)))  # the 64 hyper-octants
assert SIGNS.shape == (64, 6)


# --------------------------------------------------------------------------------------------
# Reference implementation, written from the definition (slow, obviously correct)
# --------------------------------------------------------------------------------------------


def reference_jacobian(robot, arm_name: str, q) -> np.ndarray:
    """(6, n) LOCAL TCP Jacobian from pinocchio, rotation rows scaled by 0.15."""
    arm = robot.arm(arm_name)
    model = pin.Model(robot.model)
    tip_id = model.getFrameId(arm.tip_frame)
    tip = model.frames[tip_id]
    tcp_id = model.addFrame(
        pin.Frame("ref_tcp", tip.parentJoint, tip_id, tip.placement * pin.SE3(arm.tcp_offset), pin.FrameType.OP_FRAME)
    )
    data = model.createData()
    pin.computeJointJacobians(model, data, robot.full_q(arm_name, q))
    pin.updateFramePlacements(model, data)
    J = pin.getFrameJacobian(model, data, tcp_id, pin.LOCAL)[:, [model.joints[j].idx_v for j in arm.joint_ids]]
    J = np.array(J)
    J[3:] *= ROT_SCALE
    return J


def reference_penalties(q, lower, upper, continuous):
    """(pen_lo, pen_hi): factors for motion towards the lower / upper limit."""
    n = len(q)
    pen_lo, pen_hi = np.ones(n), np.ones(n)
    for j in range(n):
        if continuous[j]:
            continue
        t, lo, hi = float(q[j]), float(lower[j]), float(upper[j])
        if min(t - lo, hi - t) < 1e-10:
            w = 1e10
        else:
            w = abs((hi - lo) ** 2 * (2 * t - hi - lo) / (4 * (hi - t) ** 2 * (t - lo) ** 2))
        factor = 1.0 / math.sqrt(1.0 + w)
        if t - lo < hi - t:  # nearer to the lower limit
            pen_lo[j] = factor
        elif hi - t < t - lo:
            pen_hi[j] = factor
        else:  # exactly in the middle: w = 0, factor 1 either way
            assert factor == 1.0
    return pen_lo, pen_hi


def reference_measure(J, pen_lo, pen_hi, index: str, rowfac=None) -> float:
    """rowfac (6, 2): an extra factor per row and octant sign (0 = +, 1 = -), e.g. self-distance."""
    rowfac = np.ones((6, 2)) if rowfac is None else rowfac
    values = []
    for s in SIGNS:
        Js = np.empty_like(J)
        for r in range(6):
            for j in range(J.shape[1]):
                towards_hi = (s[r] >= 0) != (J[r, j] < 0)
                Js[r, j] = J[r, j] * (pen_hi[j] if towards_hi else pen_lo[j]) * rowfac[r, 0 if s[r] >= 0 else 1]
        sv = np.linalg.svd(Js, compute_uv=False)
        values.append(sv.min() / sv.max() if index == "isotropy" else float(np.prod(sv)))
    return min(values)


def reference(robot, arm_name: str, q, index: str = "isotropy") -> float:
    arm = robot.arm(arm_name)
    J = reference_jacobian(robot, arm_name, q)
    lo, hi = reference_penalties(q, arm.lower, arm.upper, arm.continuous)
    return reference_measure(J, lo, hi, index)


def assert_matches(robot, arm_name, Q, index):
    got = placement.extended_manipulability(robot, arm_name, Q, index=index)
    want = np.array([reference(robot, arm_name, q, index) for q in Q])
    assert got.shape == want.shape
    if index == "isotropy":
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    else:
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=0)
    return got, want


def kernel_inputs(arm, Q):
    """Kernel Jacobians (N, 6, n) of configurations Q (rotation rows scaled) and one set of kernel scratch."""
    from placement.kernels.isotropy import W_ROWS
    from placement.kernels.kinematics import fk_jacobian_batch

    ch = arm.chain
    _, J = fk_jacobian_batch(Q, ch.link_T, ch.axis, ch.kind, ch.tip_T)
    J[:, 3:] *= 0.15
    n = arm.dof
    scratch = (
        np.empty(n),
        np.empty(n),
        np.empty((6, n, 2)),
        np.empty((6, 6, 2, 2)),
        np.empty((6, 6)),
        np.empty((6, 6)),
        np.empty((21, 64)),
        np.empty((W_ROWS, 64)),
        np.empty((2, 6)),
    )
    return J, scratch


#: (robot fixture, arm) pairs the manipulability tests run on
ROBOT_ARMS = [("pr2", "right"), ("pr2", "left"), ("armar6", "left"), ("armar6", "right")]
