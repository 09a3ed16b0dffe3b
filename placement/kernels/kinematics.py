"""Forward kinematics and the TCP Jacobian of a serial chain (see robots/chain.py)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _motion(kind, ax, q, out):
    """(4, 4) motion of one joint: rotation by q [rad] about ax, or translation q [m] along ax."""
    for i in range(4):
        for j in range(4):
            out[i, j] = 1.0 if i == j else 0.0
    if kind == 1:
        out[0, 3] = ax[0] * q
        out[1, 3] = ax[1] * q
        out[2, 3] = ax[2] * q
        return
    c = math.cos(q)
    s = math.sin(q)
    t = 1.0 - c
    x, y, z = ax[0], ax[1], ax[2]
    out[0, 0] = t * x * x + c
    out[0, 1] = t * x * y - s * z
    out[0, 2] = t * x * z + s * y
    out[1, 0] = t * x * y + s * z
    out[1, 1] = t * y * y + c
    out[1, 2] = t * y * z - s * x
    out[2, 0] = t * x * z - s * y
    out[2, 1] = t * y * z + s * x
    out[2, 2] = t * z * z + c


@njit(cache=True, inline="always")
def _mul4(a, b, out):
    for i in range(3):
        for j in range(4):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]
        out[i, 3] += a[i, 3]
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


@njit(cache=True)
def fk_jacobian(q, link_T, axis, kind, tip_T, T_out, J_out, work):
    """TCP pose and its LOCAL geometric Jacobian for one configuration.

    Args:
        q: (n,) joint values [rad or m].
        link_T, axis, kind, tip_T: the chain arrays (robots/chain.py).
        T_out: (4, 4) output, TCP pose in the base frame.
        J_out: (6, n) output, rows (vx, vy, vz, wx, wy, wz) in the TCP frame [m/rad, 1].
        work: (n + 3, 4, 4) scratch; rows 0..n-1 receive each joint frame in the base frame.
    """
    n = q.shape[0]
    frames = work
    M = work[n]
    tmp = work[n + 1]
    cur = work[n + 2]
    for i in range(4):
        for j in range(4):
            cur[i, j] = 1.0 if i == j else 0.0
    for k in range(n):
        _mul4(cur, link_T[k], tmp)
        for i in range(4):
            for j in range(4):
                frames[k, i, j] = tmp[i, j]
        _motion(kind[k], axis[k], q[k], M)
        _mul4(tmp, M, cur)
    _mul4(cur, tip_T, T_out)
    px, py, pz = T_out[0, 3], T_out[1, 3], T_out[2, 3]
    for k in range(n):
        F = frames[k]
        wx = F[0, 0] * axis[k, 0] + F[0, 1] * axis[k, 1] + F[0, 2] * axis[k, 2]
        wy = F[1, 0] * axis[k, 0] + F[1, 1] * axis[k, 1] + F[1, 2] * axis[k, 2]
        wz = F[2, 0] * axis[k, 0] + F[2, 1] * axis[k, 1] + F[2, 2] * axis[k, 2]
        if kind[k] == 1:
            vx, vy, vz = wx, wy, wz
            wx = wy = wz = 0.0
        else:
            dx, dy, dz = px - F[0, 3], py - F[1, 3], pz - F[2, 3]
            vx = wy * dz - wz * dy
            vy = wz * dx - wx * dz
            vz = wx * dy - wy * dx
        # rotate into the TCP frame: R^T v
        for r in range(3):
            J_out[r, k] = T_out[0, r] * vx + T_out[1, r] * vy + T_out[2, r] * vz
            J_out[3 + r, k] = T_out[0, r] * wx + T_out[1, r] * wy + T_out[2, r] * wz


@njit(cache=True)
def fk_jacobian_batch(Q, link_T, axis, kind, tip_T):
    """Vectorised :func:`fk_jacobian`: Q (N, n) -> poses (N, 4, 4), Jacobians (N, 6, n)."""
    N, n = Q.shape
    T = np.empty((N, 4, 4))
    J = np.empty((N, 6, n))
    work = np.empty((n + 3, 4, 4))
    for i in range(N):
        fk_jacobian(Q[i], link_T, axis, kind, tip_T, T[i], J[i], work)
    return T, J
