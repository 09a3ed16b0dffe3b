"""Forward kinematics and the TCP Jacobian of a serial chain (see robots/chain.py)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit


@njit(cache=True)
def fk_jacobian(
    q: npt.NDArray[np.float64],
    link_T: npt.NDArray[np.float64],
    axis: npt.NDArray[np.float64],
    kind: npt.NDArray[np.int64],
    tip_T: npt.NDArray[np.float64],
    T_out: npt.NDArray[np.float64],
    J_out: npt.NDArray[np.float64],
    work: npt.NDArray[np.float64],
) -> None:
    """TCP pose and its LOCAL geometric Jacobian for one configuration.

    Args:
        q: (n,) joint values [rad or m].
        link_T, axis, kind, tip_T: the chain arrays (robots/chain.py).
        T_out: (4, 4) output, TCP pose in the base frame.
        J_out: (6, n) output, rows (vx, vy, vz, wx, wy, wz) in the TCP frame [m/rad, 1].
        work: (n + 3, 4, 4) scratch; work[k, 0, :3] receives joint k's axis and
            work[k, 1, :3] its origin, in the base frame.
    """
    n = q.shape[0]
    # the running frame as 12 scalars (rotation r.., position p.): no 4x4 temporaries
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    p0, p1, p2 = 0.0, 0.0, 0.0
    for k in range(n):
        L = link_T[k]
        # F = cur * link_T[k]
        f00 = r00 * L[0, 0] + r01 * L[1, 0] + r02 * L[2, 0]
        f01 = r00 * L[0, 1] + r01 * L[1, 1] + r02 * L[2, 1]
        f02 = r00 * L[0, 2] + r01 * L[1, 2] + r02 * L[2, 2]
        f10 = r10 * L[0, 0] + r11 * L[1, 0] + r12 * L[2, 0]
        f11 = r10 * L[0, 1] + r11 * L[1, 1] + r12 * L[2, 1]
        f12 = r10 * L[0, 2] + r11 * L[1, 2] + r12 * L[2, 2]
        f20 = r20 * L[0, 0] + r21 * L[1, 0] + r22 * L[2, 0]
        f21 = r20 * L[0, 1] + r21 * L[1, 1] + r22 * L[2, 1]
        f22 = r20 * L[0, 2] + r21 * L[1, 2] + r22 * L[2, 2]
        p0 = r00 * L[0, 3] + r01 * L[1, 3] + r02 * L[2, 3] + p0
        p1 = r10 * L[0, 3] + r11 * L[1, 3] + r12 * L[2, 3] + p1
        p2 = r20 * L[0, 3] + r21 * L[1, 3] + r22 * L[2, 3] + p2
        x, y, z = axis[k, 0], axis[k, 1], axis[k, 2]
        work[k, 0, 0] = f00 * x + f01 * y + f02 * z
        work[k, 0, 1] = f10 * x + f11 * y + f12 * z
        work[k, 0, 2] = f20 * x + f21 * y + f22 * z
        work[k, 1, 0] = p0
        work[k, 1, 1] = p1
        work[k, 1, 2] = p2
        if kind[k] == 1:
            p0 += work[k, 0, 0] * q[k]
            p1 += work[k, 0, 1] * q[k]
            p2 += work[k, 0, 2] * q[k]
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = f00, f01, f02, f10, f11, f12, f20, f21, f22
            continue
        # cur = F * Rot(axis, q) (Rodrigues)
        c = math.cos(q[k])
        sn = math.sin(q[k])
        t = 1.0 - c
        m00 = t * x * x + c
        m01 = t * x * y - sn * z
        m02 = t * x * z + sn * y
        m10 = t * x * y + sn * z
        m11 = t * y * y + c
        m12 = t * y * z - sn * x
        m20 = t * x * z - sn * y
        m21 = t * y * z + sn * x
        m22 = t * z * z + c
        r00 = f00 * m00 + f01 * m10 + f02 * m20
        r01 = f00 * m01 + f01 * m11 + f02 * m21
        r02 = f00 * m02 + f01 * m12 + f02 * m22
        r10 = f10 * m00 + f11 * m10 + f12 * m20
        r11 = f10 * m01 + f11 * m11 + f12 * m21
        r12 = f10 * m02 + f11 * m12 + f12 * m22
        r20 = f20 * m00 + f21 * m10 + f22 * m20
        r21 = f20 * m01 + f21 * m11 + f22 * m21
        r22 = f20 * m02 + f21 * m12 + f22 * m22
    # T = cur * tip_T
    for j in range(3):
        T_out[0, j] = r00 * tip_T[0, j] + r01 * tip_T[1, j] + r02 * tip_T[2, j]
        T_out[1, j] = r10 * tip_T[0, j] + r11 * tip_T[1, j] + r12 * tip_T[2, j]
        T_out[2, j] = r20 * tip_T[0, j] + r21 * tip_T[1, j] + r22 * tip_T[2, j]
    T_out[0, 3] = r00 * tip_T[0, 3] + r01 * tip_T[1, 3] + r02 * tip_T[2, 3] + p0
    T_out[1, 3] = r10 * tip_T[0, 3] + r11 * tip_T[1, 3] + r12 * tip_T[2, 3] + p1
    T_out[2, 3] = r20 * tip_T[0, 3] + r21 * tip_T[1, 3] + r22 * tip_T[2, 3] + p2
    T_out[3, 0] = 0.0
    T_out[3, 1] = 0.0
    T_out[3, 2] = 0.0
    T_out[3, 3] = 1.0
    px, py, pz = T_out[0, 3], T_out[1, 3], T_out[2, 3]
    for k in range(n):
        wx, wy, wz = work[k, 0, 0], work[k, 0, 1], work[k, 0, 2]
        if kind[k] == 1:
            vx, vy, vz = wx, wy, wz
            wx = wy = wz = 0.0
        else:
            dx, dy, dz = px - work[k, 1, 0], py - work[k, 1, 1], pz - work[k, 1, 2]
            vx = wy * dz - wz * dy
            vy = wz * dx - wx * dz
            vz = wx * dy - wy * dx
        # rotate into the TCP frame: R^T v
        for r in range(3):
            J_out[r, k] = T_out[0, r] * vx + T_out[1, r] * vy + T_out[2, r] * vz
            J_out[3 + r, k] = T_out[0, r] * wx + T_out[1, r] * wy + T_out[2, r] * wz


@njit(cache=True)
def fk_jacobian_batch(
    Q: npt.NDArray[np.float64],
    link_T: npt.NDArray[np.float64],
    axis: npt.NDArray[np.float64],
    kind: npt.NDArray[np.int64],
    tip_T: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Vectorised :func:`fk_jacobian`: Q (N, n) -> poses (N, 4, 4), Jacobians (N, 6, n)."""
    N, n = Q.shape
    T = np.empty((N, 4, 4))
    J = np.empty((N, 6, n))
    work = np.empty((n + 3, 4, 4))
    for i in range(N):
        fk_jacobian(Q[i], link_T, axis, kind, tip_T, T[i], J[i], work)
    return T, J
