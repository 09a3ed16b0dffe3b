"""Inverse kinematics of one arm with pinocchio: damped least squares with restarts.

The solver moves only the arm's joints (every other joint is held where
:meth:`Robot.full_q` puts it: neutral, with the preset's fixed joints set) and
drives the canonical TCP frame (tip frame * ``arm.tcp_offset``) to a target
pose given in the robot's base frame.

Each *attempt* from one start configuration is a damped least-squares descent
(``kernels/ik.py``, numba, on the chain kernels that equal pinocchio to 1e-9):
the error is the TCP position and rotation vector in the TCP frame, the step
``dq = J^T (J J^T + lambda^2 I)^-1 e`` capped at :data:`MAX_STEP` in norm, the
configuration clipped to the joint limits, continuous joints wrapped to
[-pi, pi). A solution the descent reports is then checked with pinocchio's own
forward kinematics (TCP frame added once to a copy of the model); only that
check decides ``success``.

An attempt ends when the TCP is within ``pos_tol`` / ``rot_tol`` of the target
(success), after ``max_iter`` iterations, or when the error has stopped
improving (stuck at a limit or in a local minimum). Attempts start from the
given seed (or ``arm.home``), then from random configurations drawn uniformly
within the joint limits by ``numpy.random.default_rng(rng_seed)``: the result
is a deterministic function of the inputs.

Typical cost on the PR2 arm: a few microseconds per iteration; a reachable
target takes well under 1 ms, an unreachable one all ``seeds`` attempts.
"""

from __future__ import annotations

import math
import threading
import weakref
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from placement.errors import PlacementError, RobotError
from placement.kernels.ik import dls_attempt
from placement.robots import Robot
from placement.robots.model_cache import frame_id
from placement.validation import finite_array

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
        tip_id = frame_id(model, a.tip_frame)
        tip = model.frames[tip_id]
        name = f"placement_tcp_{arm}"
        while model.existFrame(name):
            name += "_"
        placement = tip.placement * pin.SE3(np.asarray(a.tcp_offset, dtype=float))
        self.frame_id = model.addFrame(pin.Frame(name, tip.parentJoint, tip_id, placement, pin.FrameType.OP_FRAME))
        self.model = model
        cols: list[int] = []
        idx_q: list[int] = []
        nq2: list[bool] = []
        for jname, jid in zip(a.joints, a.joint_ids):
            jm = model.joints[jid]
            if jm.nv != 1:
                raise RobotError(
                    f"robot '{robot.name}': joint '{jname}' of arm '{arm}' has {jm.nv} "
                    "degrees of freedom; IK supports 1-DoF joints only"
                )
            cols.append(jm.idx_v)
            idx_q.append(jm.idx_q)
            nq2.append(jm.nq == 2)
        self.cols = np.asarray(cols, dtype=np.int64)
        self.idx_q = np.asarray(idx_q, dtype=np.int64)
        self.nq2 = np.asarray(nq2, dtype=bool)
        # per call these cost more than the FK itself: computed once
        self._plain = ~self.nq2
        self._plain_q = self.idx_q[self._plain]
        self._circle = bool(self.nq2.any())
        cont = np.asarray(a.continuous, dtype=bool)
        self.continuous = cont
        self._wrap = bool(cont.any())
        # clipping bounds: a continuous joint is wrapped, never clipped
        self._lower = np.where(cont, -np.inf, a.lower).astype(float)
        self._upper = np.where(cont, np.inf, a.upper).astype(float)
        self.q_ref = robot.reference_q()
        data = model.createData()
        pin.framesForwardKinematics(model, data, robot.full_q(arm, a.home))
        # The base frame does not move with the arm's joints: its world pose is constant.
        self.oMbase = pin.SE3(data.oMf[robot.base_frame_id])
        self._local = threading.local()
        #: rng seed -> the random starts drawn so far, projected (see :meth:`restarts`)
        self._restarts: dict[int, np.ndarray] = {}

    def restarts(self, rng_seed: int, count: int) -> np.ndarray:
        """(>= count, n) the random start configurations of :func:`solve_ik` after its first, in order,
        projected into the limits: what ``np.random.default_rng(rng_seed)`` draws uniformly within
        the limits, one configuration at a time. Drawn once per solver and seed, because making the
        generator and drawing cost more than a failed attempt."""
        drawn = self._restarts.get(rng_seed)
        if drawn is None or len(drawn) < count:
            rng = np.random.default_rng(rng_seed)
            a = self.arm
            drawn = np.array([self.project(rng.uniform(a.lower, a.upper)) for _ in range(max(count, 8))])
            drawn = drawn.reshape(-1, a.dof)
            drawn.flags.writeable = False
            self._restarts[rng_seed] = drawn  # replaced whole: a reader never sees it half drawn
        return drawn

    @property
    def data(self) -> pin.Data:
        d = getattr(self._local, "data", None)
        if d is None:
            d = self._local.data = self.model.createData()
        return d

    def full(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio configuration (nq,) with the arm at q (n,)."""
        out = self.q_ref.copy()
        out[self._plain_q] = q[self._plain]
        if self._circle:
            iq = self.idx_q[self.nq2]
            qc = q[self.nq2]
            out[iq] = np.cos(qc)
            out[iq + 1] = np.sin(qc)
        return out

    def project(self, q: np.ndarray) -> np.ndarray:
        """Clip q (n,) to the limits, wrap continuous joints to [-pi, pi) (in place)."""
        if self._wrap:
            cont = self.continuous
            q[cont] = np.mod(q[cont] + math.pi, _TWO_PI) - math.pi
        # (np.clip's dispatch costs more than the two ufuncs)
        np.maximum(q, self._lower, out=q)
        np.minimum(q, self._upper, out=q)
        return q

    def check(self, q: np.ndarray, oMt: pin.SE3, pos_tol: float, rot_tol: float) -> tuple[bool, float, float]:
        """(within tolerances, pos_err [m], rot_err [rad]) of q by pinocchio's FK."""
        pin.framesForwardKinematics(self.model, self.data, self.full(q))
        oMf = self.data.oMf[self.frame_id]
        pos_err = float(np.linalg.norm(oMf.translation - oMt.translation))
        rot_err = float(np.linalg.norm(pin.log3(oMf.rotation.T @ oMt.rotation)))
        return pos_err <= pos_tol and rot_err <= rot_tol, pos_err, rot_err


def _rotation(R: np.ndarray) -> np.ndarray:
    """(3, 3) ``R`` as a rotation: re-orthonormalised by SVD when it is off by more than 1e-12 (poses
    from text files carry rounding errors; the planner's own are orthonormal and skip the SVD);
    PlacementError for a reflection."""
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-12:
        u, _, vt = np.linalg.svd(R)
        R = u @ vt
    (a, b, c), (d, e, f), (g, h, i) = R.tolist()
    if a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) < 0:
        raise PlacementError("IK target rotation is a reflection (determinant < 0)")
    return R


_CACHE: weakref.WeakKeyDictionary[Robot, dict[str, _ArmIK]] = weakref.WeakKeyDictionary()
#: solvers by content (see :func:`_content`), for robot objects made again from the same files: a
#: fresh planner then skips the model copy (1-2 ms per arm)
_BY_CONTENT: dict[tuple[object, ...], _ArmIK] = {}
#: robots by content kept at once (the oldest is dropped)
CONTENT_CACHE_SIZE = 32
_CACHE_LOCK = threading.Lock()


def _content(robot: Robot, arm: str) -> tuple[object, ...]:
    """What an arm's solver is made of: the URDF, the model's joints and held values, the base frame and
    the arm's chain, TCP, home and limits."""
    a = robot.arm(arm)
    return (
        robot.urdf_sha256,
        tuple(robot.model.names),
        robot.reference_q().tobytes(),
        robot.base_frame,
        arm,
        a.tip_frame,
        tuple(a.joints),
        *(np.asarray(v, dtype=float).tobytes() for v in (a.tcp_offset, a.home, a.lower, a.upper)),
        np.asarray(a.continuous, dtype=bool).tobytes(),
    )


def _solver(robot: Robot, arm: str) -> _ArmIK:
    with _CACHE_LOCK:
        per_robot = _CACHE.setdefault(robot, {})
        s = per_robot.get(arm)
        if s is None:
            key = _content(robot, arm)
            s = _BY_CONTENT.get(key)
            if s is None:
                s = _BY_CONTENT[key] = _ArmIK(robot, arm)
                while len(_BY_CONTENT) > CONTENT_CACHE_SIZE:
                    del _BY_CONTENT[next(iter(_BY_CONTENT))]
            per_robot[arm] = s
        return s


def solve_ik(
    robot: Robot,
    arm: str,
    T_target: npt.ArrayLike,
    q_seed: npt.ArrayLike | None = None,
    *,
    seeds: int = 8,
    rng_seed: int = 0,
    pos_tol: float = 1e-3,
    rot_tol: float = 1e-2,
    max_iter: int = 200,
) -> IKResult:
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
    T = finite_array(T_target, "IK target", PlacementError)
    if T.shape != (4, 4):
        raise PlacementError(f"IK target must be a finite (4, 4) pose, got shape {T.shape}")
    for name, value in (("seeds", seeds), ("max_iter", max_iter)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise PlacementError(f"{name} must be a positive integer, got {value!r}")
    if isinstance(rng_seed, bool) or not isinstance(rng_seed, (int, np.integer)) or rng_seed < 0:
        raise PlacementError(f"rng_seed must be a non-negative integer, got {rng_seed!r}")
    for name, tol in (("pos_tol", pos_tol), ("rot_tol", rot_tol)):
        if (
            isinstance(tol, bool)
            or not isinstance(tol, (int, float, np.floating, np.integer))
            or not (math.isfinite(tol) and tol > 0)
        ):
            raise PlacementError(f"{name} must be a positive finite number, got {tol!r}")
    s = _solver(robot, arm)
    a = s.arm
    R = _rotation(T[:3, :3])
    oMt = s.oMbase * pin.SE3(R, T[:3, 3].copy())
    # a NaN start would reach the kernels' divisions (a NaN home once came in through a preset)
    if q_seed is None:
        q0 = finite_array(a.home, f"the home configuration of arm '{arm}'", PlacementError)
    else:
        q0 = finite_array(q_seed, "q_seed", PlacementError)
    if q0.shape != (a.dof,):
        raise PlacementError(f"q_seed must have {a.dof} values for arm '{arm}', got shape {q0.shape}")
    restarts = s.restarts(rng_seed, seeds - 1) if seeds > 1 else None
    best: IKResult | None = None
    total = 0
    target = np.eye(4)
    target[:3, :3] = R
    target[:3, 3] = T[:3, 3]
    ch = a.chain
    cont = s.continuous
    for k in range(seeds):
        if k == 0:
            start = s.project(q0.copy())
        else:
            assert restarts is not None
            start = restarts[k - 1].copy()
        # the descent runs in numba on the chain kernels (= pinocchio to 1e-9) ...
        ok, q, pe, re, it = dls_attempt(
            start,
            target,
            a.lower,
            a.upper,
            cont,
            *ch.arrays,
            pos_tol,
            rot_tol,
            max_iter,
            DAMPING,
            MAX_STEP,
            STALL_ITERATIONS,
        )
        q = np.array(q)
        if ok:
            # ... and pinocchio has the last word on every solution
            ok, pe, re = s.check(q, oMt, pos_tol, rot_tol)
        total += it
        res = IKResult(bool(ok), q.copy(), pe, re, total, k + 1)
        if ok:
            return res
        if best is None or pe + 0.1 * re < best.pos_err + 0.1 * best.rot_err:
            best = res
    assert best is not None  # seeds >= 1 attempts, checked above
    best.iterations = total
    best.attempts = seeds
    return best
