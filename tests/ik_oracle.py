"""An independent oracle for "is this step feasible?": random base poses around the target and a
pinocchio-only damped least-squares IK with restarts (no map, no planner kernel, no placement.ik).

A step is feasible when some base pose (the centre of a base-feasible cell of the planner's world,
any yaw) lets the arm reach every pose of one of the step's TCP trajectories, each within 2 mm and
0.02 rad.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

POS_TOL, ROT_TOL = 2e-3, 2e-2


class PinIK:
    """DLS IK of one arm on pinocchio alone: TCP frame added to a copy of the model."""

    def __init__(self, robot, arm: str):
        a = robot.arm(arm)
        self.robot, self.arm, self.a = robot, arm, a
        self.model = pin.Model(robot.model)
        tip_id = self.model.getFrameId(a.tip_frame)
        tip = self.model.frames[tip_id]
        self.tcp = self.model.addFrame(pin.Frame("oracle_tcp", tip.parentJoint, tip_id,
                                                 tip.placement * pin.SE3(np.asarray(a.tcp_offset, float)),
                                                 pin.FrameType.OP_FRAME))
        self.data = self.model.createData()
        self.cols = [self.model.joints[j].idx_v for j in a.joint_ids]
        self.ref = robot.reference_q()
        pin.framesForwardKinematics(self.model, self.data, robot.full_q(arm, a.home, self.ref))
        self.oMbase = pin.SE3(self.data.oMf[robot.base_frame_id])

    def solve(self, T_base: np.ndarray, q0: np.ndarray, iters: int = 80):
        """(success, q (n,)) for the TCP pose ``T_base`` (4, 4) in the base frame, from q0."""
        target = self.oMbase * pin.SE3(T_base[:3, :3].copy(), T_base[:3, 3].copy())
        q = q0.copy()
        a = self.a
        for _ in range(iters):
            full = self.robot.full_q(self.arm, q, self.ref)
            pin.computeJointJacobians(self.model, self.data, full)
            pin.updateFramePlacements(self.model, self.data)
            cur = self.data.oMf[self.tcp]
            err = pin.log6(cur.actInv(target)).vector
            if np.linalg.norm(err[:3]) < POS_TOL and np.linalg.norm(err[3:]) < ROT_TOL:
                return True, q
            J = pin.getFrameJacobian(self.model, self.data, self.tcp, pin.LOCAL)[:, self.cols]
            dq = J.T @ np.linalg.solve(J @ J.T + 1e-4 * np.eye(6), err)
            n = np.linalg.norm(dq)
            q = q + (dq * (0.5 / n) if n > 0.5 else dq)
            q = np.where(a.continuous, (q + math.pi) % (2 * math.pi) - math.pi, np.clip(q, a.lower, a.upper))
        return False, q


def base_matrix(x, y, yaw):
    B = np.eye(4)
    B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    B[:2, 3] = (x, y)
    return B


def find_placement(planner, trajectories, samples: int = 400, restarts: int = 3, radius: float = 1.2,
                   seed: int = 0):
    """A base pose (x, y, yaw) on a free cell from which one arm reaches every pose of one of
    ``trajectories`` ((P, 4, 4) world poses), or None after ``samples`` random base poses."""
    rng = np.random.default_rng(seed)
    world = planner.world
    solvers = {arm: PinIK(planner.robot, arm) for arm in planner.maps}
    target = np.mean([T[-1, :2, 3] for T in trajectories], axis=0)
    for _ in range(samples):
        r, th = radius * math.sqrt(rng.random()), 2 * math.pi * rng.random()
        x, y, yaw = target[0] + r * math.cos(th), target[1] + r * math.sin(th), 2 * math.pi * rng.random() - math.pi
        try:
            cell = world.nav.cell(x, y)
        except Exception:
            continue
        if not world.feasible[cell]:
            continue
        # base positions are the planner's grid cells: feasibility is known at their centres only
        x, y = float(world.nav.centres()[0][cell[1]]), float(world.nav.centres()[1][cell[0]])
        Binv = np.linalg.inv(base_matrix(x, y, yaw))
        for arm, ik in solvers.items():
            T = trajectories[rng.integers(len(trajectories))]  # the samples spread over the trajectories
            lo = np.where(ik.a.continuous, -math.pi, ik.a.lower)
            hi = np.where(ik.a.continuous, math.pi, ik.a.upper)
            for q in [ik.a.home] + [rng.uniform(lo, hi) for _ in range(restarts - 1)]:
                ok = True
                for pose in T:
                    ok, q = ik.solve(Binv @ pose, q)
                    if not ok:
                        break
                if ok:
                    return x, y, yaw
    return None
