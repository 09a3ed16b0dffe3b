"""Damped least-squares IK descent on the chain kernels (one attempt from one start)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from placement.kernels.kinematics import fk_jacobian
from placement.kernels.linalg6 import cho_solve6, cholesky6

_TWO_PI = 2.0 * math.pi


@njit(cache=True)
def log3(R: npt.NDArray[np.float64], out: npt.NDArray[np.float64]) -> None:
    """Rotation vector (3,) of the rotation matrix R (3, 3) [rad]."""
    c = (R[0, 0] + R[1, 1] + R[2, 2] - 1.0) * 0.5
    c = min(1.0, max(-1.0, c))
    theta = math.acos(c)
    vx = R[2, 1] - R[1, 2]
    vy = R[0, 2] - R[2, 0]
    vz = R[1, 0] - R[0, 1]
    if theta < 1e-6:
        out[0], out[1], out[2] = 0.5 * vx, 0.5 * vy, 0.5 * vz
        return
    if theta > math.pi - 1e-4:
        # near pi: axis from the diagonal, sign from the antisymmetric part
        ax = math.sqrt(max(0.0, (R[0, 0] + 1.0) * 0.5))
        ay = math.sqrt(max(0.0, (R[1, 1] + 1.0) * 0.5))
        az = math.sqrt(max(0.0, (R[2, 2] + 1.0) * 0.5))
        if ax >= ay and ax >= az:
            ay = math.copysign(ay, R[0, 1] + R[1, 0])
            az = math.copysign(az, R[0, 2] + R[2, 0])
            if vx < 0:
                ax, ay, az = -ax, -ay, -az
        elif ay >= az:
            ax = math.copysign(ax, R[0, 1] + R[1, 0])
            az = math.copysign(az, R[1, 2] + R[2, 1])
            if vy < 0:
                ax, ay, az = -ax, -ay, -az
        else:
            ax = math.copysign(ax, R[0, 2] + R[2, 0])
            ay = math.copysign(ay, R[1, 2] + R[2, 1])
            if vz < 0:
                ax, ay, az = -ax, -ay, -az
        n = math.sqrt(ax * ax + ay * ay + az * az)
        if not n > 0.0:
            # only a non-rotation (NaN entries) gets here; numba would raise ZeroDivisionError
            out[0], out[1], out[2] = math.nan, math.nan, math.nan
            return
        out[0], out[1], out[2] = theta * ax / n, theta * ay / n, theta * az / n
        return
    f = theta / (2.0 * math.sin(theta))
    out[0], out[1], out[2] = f * vx, f * vy, f * vz


@njit(cache=True)
def dls_attempt(
    q0: npt.NDArray[np.float64],
    target: npt.NDArray[np.float64],
    lower: npt.NDArray[np.float64],
    upper: npt.NDArray[np.float64],
    continuous: npt.NDArray[np.bool_],
    link_T: npt.NDArray[np.float64],
    axis: npt.NDArray[np.float64],
    kind: npt.NDArray[np.int64],
    tip_T: npt.NDArray[np.float64],
    pos_tol: float,
    rot_tol: float,
    max_iter: int,
    damping: float,
    max_step: float,
    stall: int,
) -> tuple[bool, npt.NDArray[np.float64], float, float, int]:
    """One DLS descent of the TCP to ``target`` (4, 4) (base frame) from q0 (n,).

    Error: position in the TCP frame and the rotation vector of R^T R_target;
    step ``dq = J^T (J J^T + damping I)^-1 e`` capped at ``max_step`` in norm;
    limits clipped, continuous joints wrapped to [-pi, pi). Stops on success,
    after ``max_iter`` iterations, or when the error has not dropped 1 % in
    ``stall`` iterations. Returns (success, q_best, pos_err, rot_err, iterations).
    """
    n = q0.shape[0]
    q = q0.copy()
    T = np.empty((4, 4))
    J = np.empty((6, n))
    work = np.empty((n + 3, 4, 4))
    Rerr = np.empty((3, 3))
    e = np.empty(6)
    w = np.empty(3)
    A = np.empty((6, 6))
    L = np.empty((6, 6))
    y = np.empty(6)
    best_q = q.copy()
    best_score = np.inf
    best_pe = np.inf
    best_re = np.inf
    last_gain_it = 0
    last_gain = np.inf
    it = 0
    while True:
        fk_jacobian(q, link_T, axis, kind, tip_T, T, J, work)
        dx = target[0, 3] - T[0, 3]
        dy = target[1, 3] - T[1, 3]
        dz = target[2, 3] - T[2, 3]
        for r in range(3):
            e[r] = T[0, r] * dx + T[1, r] * dy + T[2, r] * dz
            for c in range(3):
                Rerr[r, c] = T[0, r] * target[0, c] + T[1, r] * target[1, c] + T[2, r] * target[2, c]
        log3(Rerr, w)
        e[3], e[4], e[5] = w[0], w[1], w[2]
        pe = math.sqrt(dx * dx + dy * dy + dz * dz)
        re = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        score = pe + 0.1 * re
        if score < best_score:
            best_score, best_pe, best_re = score, pe, re
            best_q[:] = q
        if pe <= pos_tol and re <= rot_tol:
            return True, best_q, pe, re, it
        if it >= max_iter:
            break
        if score < 0.99 * last_gain:
            last_gain_it, last_gain = it, score
        elif it - last_gain_it >= stall:
            break
        for r in range(6):
            for c in range(r, 6):
                acc = 0.0
                for j in range(n):
                    acc += J[r, j] * J[c, j]
                A[r, c] = acc
                A[c, r] = acc
        if not cholesky6(A, 1.0, damping, L):  # positive definite by the damping, unless NaN came in
            break
        cho_solve6(L, e, y, y)
        norm = 0.0
        for j in range(n):
            acc = 0.0
            for r in range(6):
                acc += J[r, j] * y[r]
            q[j] += acc
            norm += acc * acc
        norm = math.sqrt(norm)
        if norm > max_step:
            # undo and apply the capped step
            scale = max_step / norm
            for j in range(n):
                acc = 0.0
                for r in range(6):
                    acc += J[r, j] * y[r]
                q[j] -= acc * (1.0 - scale)
        for j in range(n):
            if continuous[j]:
                q[j] = (q[j] + math.pi) % _TWO_PI - math.pi
            else:
                q[j] = min(max(q[j], lower[j]), upper[j])
        it += 1
    return False, best_q, best_pe, best_re, it
