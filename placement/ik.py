"""Inverse kinematics of one arm with pinocchio: damped least squares with restarts.

The solver moves only the arm's joints (every other joint is held where
:meth:`Robot.full_q` puts it: neutral, with the preset's fixed joints set) and
drives the canonical TCP frame (tip frame * ``arm.tcp_offset``) to a target
pose given in the robot's base frame.

Each iteration (one *attempt* from one start configuration):

1. pinocchio computes the TCP pose ``oMf`` and its 6 x n ``LOCAL`` Jacobian
   (``computeJointJacobians`` + ``getFrameJacobian`` on a TCP frame added
   once to a copy of the model; columns of the arm's joints only);
2. the error is the local twist ``e = log6(oMf^-1 * oMt)`` (``oMt``: the
   target in the world frame), ``J_e = -Jlog6(...) J`` its Jacobian;
3. a damped least-squares step ``dq = -J_e^T (J_e J_e^T + lambda^2 I)^-1 e``,
   capped at :data:`MAX_STEP` rad (or m) in norm;
4. the new configuration is clipped to the joint limits; continuous joints
   are wrapped to [-pi, pi).

An attempt ends when the TCP is within ``pos_tol`` / ``rot_tol`` of the target
(success), after ``max_iter`` iterations, or when the error has stopped
improving (stuck at a limit or in a local minimum). Attempts start from the
given seed (or ``arm.home``), then from random configurations drawn uniformly
within the joint limits by ``numpy.random.default_rng(rng_seed)``: the result
is a deterministic function of the inputs.

Typical cost on the PR2 arm: ~30-60 us per iteration, a reachable target
takes 1-5 ms; an unreachable one costs all ``seeds`` attempts (tens of ms).
"""

from __future__ import annotations

import math
import threading
import weakref
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .errors import PlacementError, RobotError
from .robots import Robot

#: Damping lambda^2 of the least-squares step [m^2, rad^2].
DAMPING = 1e-3
#: Largest joint step per iteration (Euclidean norm over the arm's joints) [rad or m].
MAX_STEP = 0.4
#: An attempt is abandoned when its error has not dropped by 1 % within this many iterations.
STALL_ITERATIONS = 20

_TWO_PI = 2.0 * math.pi


@dataclass
class IKResult:
    """Outcome of :func:`solve_ik`.

    Attributes:
        success: True if the TCP is within the position and rotation tolerances.
        q: (n,) joint values of the arm, in ``arm.joints`` order [rad or m],
            within the joint limits (continuous joints in [-pi, pi)). On failure,
            the best configuration found (smallest error); never use it as a
            solution without checking ``success``.
        pos_err: distance between the TCP and the target position [m].
        rot_err: angle of the rotation between the TCP and the target orientation [rad].
        iterations: DLS iterations over all attempts.
        attempts: start configurations tried (1 .. seeds).
    """

    success: bool
    q: np.ndarray
    pos_err: float
    rot_err: float
    iterations: int
    attempts: int = 1


class _ArmIK:
    """Per (robot, arm) solver state: a model copy with the TCP frame added."""

    def __init__(self, robot: Robot, arm: str):
        a = robot.arm(arm)
        self.arm = a
        model = pin.Model(robot.model)
        tip_id = model.getFrameId(a.tip_frame)
        tip = model.frames[tip_id]
        name = f"placement_tcp_{arm}"
        while model.existFrame(name):
            name += "_"
        placement = tip.placement * pin.SE3(np.asarray(a.tcp_offset, dtype=float))
        self.frame_id = model.addFrame(pin.Frame(name, tip.parentJoint, tip_id, placement, pin.FrameType.OP_FRAME))
        self.model = model
        self.cols = []
        self.idx_q = []
        self.nq2 = []
        for jname, jid in zip(a.joints, a.joint_ids):
            jm = model.joints[jid]
            if jm.nv != 1:
                raise RobotError(f"robot '{robot.name}': joint '{jname}' of arm '{arm}' has {jm.nv} "
                                 "degrees of freedom; IK supports 1-DoF joints only")
            self.cols.append(jm.idx_v)
            self.idx_q.append(jm.idx_q)
            self.nq2.append(jm.nq == 2)
        self.cols = np.asarray(self.cols, dtype=np.int64)
        self.idx_q = np.asarray(self.idx_q, dtype=np.int64)
        self.nq2 = np.asarray(self.nq2, dtype=bool)
        self.q_ref = robot.reference_q()
        data = model.createData()
        pin.framesForwardKinematics(model, data, robot.full_q(arm, a.home))
        # The base frame does not move with the arm's joints: its world pose is constant.
        self.oMbase = pin.SE3(data.oMf[robot.base_frame_id])
        self._local = threading.local()

    @property
    def data(self) -> pin.Data:
        d = getattr(self._local, "data", None)
        if d is None:
            d = self._local.data = self.model.createData()
        return d

    def full(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio configuration (nq,) with the arm at q (n,)."""
        out = self.q_ref.copy()
        plain = ~self.nq2
        out[self.idx_q[plain]] = q[plain]
        if self.nq2.any():
            iq = self.idx_q[self.nq2]
            qc = q[self.nq2]
            out[iq] = np.cos(qc)
            out[iq + 1] = np.sin(qc)
        return out

    def project(self, q: np.ndarray) -> np.ndarray:
        """Clip q (n,) to the limits, wrap continuous joints to [-pi, pi) (in place)."""
        a = self.arm
        cont = a.continuous
        if cont.any():
            q[cont] = np.mod(q[cont] + math.pi, _TWO_PI) - math.pi
        lim = ~cont
        q[lim] = np.minimum(np.maximum(q[lim], a.lower[lim]), a.upper[lim])
        return q

    def attempt(self, q: np.ndarray, oMt: pin.SE3, pos_tol: float, rot_tol: float, max_iter: int):
        """One DLS descent from q (n,).

        Returns (success, q, pos_err, rot_err, iterations); on failure the best q seen.
        """
        model, data, fid, cols = self.model, self.data, self.frame_id, self.cols
        eye = np.eye(6) * DAMPING
        best = (math.inf, q.copy(), math.inf, math.inf)
        last_gain_it, last_gain_err = 0, math.inf
        it = 0
        while True:
            pin.computeJointJacobians(model, data, self.full(q))
            oMf = pin.updateFramePlacement(model, data, fid)
            J = pin.getFrameJacobian(model, data, fid, pin.LOCAL)[:, cols]
            iMt = oMf.actInv(oMt)
            err = pin.log6(iMt).vector
            pos_err = float(np.linalg.norm(oMf.translation - oMt.translation))
            rot_err = float(np.linalg.norm(err[3:]))
            score = pos_err + 0.1 * rot_err
            if score < best[0]:
                best = (score, q.copy(), pos_err, rot_err)
            if pos_err <= pos_tol and rot_err <= rot_tol:
                return True, q, pos_err, rot_err, it
            if it >= max_iter:
                break
            if score < 0.99 * last_gain_err:
                last_gain_it, last_gain_err = it, score
            elif it - last_gain_it >= STALL_ITERATIONS:
                break
            Je = -pin.Jlog6(iMt.inverse()) @ J
            dq = -Je.T @ np.linalg.solve(Je @ Je.T + eye, err)
            norm = float(np.linalg.norm(dq))
            if norm > MAX_STEP:
                dq *= MAX_STEP / norm
            q = self.project(q + dq)
            it += 1
        _, q, pos_err, rot_err = best
        return False, q, pos_err, rot_err, it


_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_CACHE_LOCK = threading.Lock()


def _solver(robot: Robot, arm: str) -> _ArmIK:
    with _CACHE_LOCK:
        per_robot = _CACHE.setdefault(robot, {})
        s = per_robot.get(arm)
        if s is None:
            s = per_robot[arm] = _ArmIK(robot, arm)
        return s


def solve_ik(robot: Robot, arm: str, T_target, q_seed=None, *, seeds: int = 8, rng_seed: int = 0,
             pos_tol: float = 1e-3, rot_tol: float = 1e-2, max_iter: int = 200) -> IKResult:
    """Joint values that put ``arm``'s canonical TCP at ``T_target``.

    Args:
        robot: the robot (see :func:`placement.load_robot`).
        arm: arm name.
        T_target: (4, 4) TCP pose in the robot's base frame [m].
        q_seed: (n,) first start configuration [rad or m], arm joint order;
            default ``arm.home``. Clipped/wrapped into the limits.
        seeds: number of start configurations (>= 1): ``q_seed`` (or home),
            then ``seeds - 1`` uniform random ones within the joint limits.
        rng_seed: seed of the random start configurations.
        pos_tol: position tolerance [m].
        rot_tol: rotation tolerance, angle of the residual rotation [rad].
        max_iter: iterations per attempt.

    Returns:
        :class:`IKResult`; the first successful attempt, else the best one
        (``success=False``). Deterministic for the same inputs.

    Joints other than the arm's are held as in :meth:`Robot.full_q`. The
    solver state is cached per (robot, arm); calls from several threads are safe.
    """
    T = np.asarray(T_target, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise PlacementError(f"IK target must be a finite (4, 4) pose, got shape {T.shape}")
    if not (isinstance(seeds, (int, np.integer)) and seeds >= 1):
        raise PlacementError(f"seeds must be a positive integer, got {seeds!r}")
    if not (pos_tol > 0 and rot_tol > 0):
        raise PlacementError(f"tolerances must be positive, got pos_tol={pos_tol}, rot_tol={rot_tol}")
    s = _solver(robot, arm)
    a = s.arm
    R = T[:3, :3]
    # Re-orthonormalise the rotation (poses from text files carry rounding errors).
    u, _, vt = np.linalg.svd(R)
    R = u @ vt
    if np.linalg.det(R) < 0:
        raise PlacementError("IK target rotation is a reflection (determinant < 0)")
    oMt = s.oMbase * pin.SE3(R, T[:3, 3].copy())
    q0 = np.array(a.home if q_seed is None else q_seed, dtype=float)
    if q0.shape != (a.dof,):
        raise PlacementError(f"q_seed must have {a.dof} values for arm '{arm}', got shape {q0.shape}")
    rng = np.random.default_rng(rng_seed)
    best: IKResult | None = None
    total = 0
    for k in range(seeds):
        start = q0 if k == 0 else rng.uniform(a.lower, a.upper)
        ok, q, pe, re, it = s.attempt(s.project(start.copy()), oMt, pos_tol, rot_tol, max_iter)
        total += it
        res = IKResult(bool(ok), q.copy(), pe, re, total, k + 1)
        if ok:
            return res
        if best is None or pe + 0.1 * re < best.pos_err + 0.1 * best.rot_err:
            best = res
    best.iterations = total
    best.attempts = seeds
    return best
