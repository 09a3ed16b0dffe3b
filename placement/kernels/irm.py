"""Inverse reachability by slicing: the manipulation map of a TCP trajectory over base poses.

For a TCP pose with world position p, yaw psi (and pitch, roll), a base at (bx, by)
with yaw a sees the TCP at ``Rz(-a) (p - b)`` with yaw ``psi - a`` and unchanged z,
pitch and roll. So each TCP pose needs one stored slice of the reachability map
(fixed z, pitch, roll bins: (nx, ny, n_yaw)), looked up at rotated positions.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .grid import wrap_bin


@njit(cache=True, parallel=True)
def trajectory_map(slices, tcp_x, tcp_y, tcp_yaw, rm_origin, rm_res, base_yaws,
                   grid_origin, grid_res, ny, nx, cells, out_val, out_yaw, out_y0=0, out_x0=0):
    """Min over the trajectory, max over base yaws, of the map value, per base cell.

    Args:
        slices: (P, nx_rm, ny_rm, n_yaw) float32, the map slice of each TCP pose.
        tcp_x, tcp_y, tcp_yaw: (P,) world position [m] and ZYX yaw [rad] of each pose.
        rm_origin: (2,) map grid lower corner (x, y) in the base frame [m]; rm_res [m].
        base_yaws: (K,) base yaws to try [rad].
        grid_origin: (2,) navigation grid corner [m]; grid_res [m]; ny, nx its shape.
        cells: (C,) int64 flat indices of the base cells to evaluate (others untouched).
        out_val: (h, w) float32, best value (0 = unreachable); out_yaw: (h, w) int64,
            index into base_yaws of the best yaw (-1 if unreachable): a window of the grid whose
            cell (0, 0) is grid cell (out_y0, out_x0); it must contain every cell of ``cells``.
    """
    P = slices.shape[0]
    nxr = slices.shape[1]
    nyr = slices.shape[2]
    n_yaw = slices.shape[3]
    K = base_yaws.shape[0]
    # per-yaw constants, shared by every cell
    cs = np.empty(K)
    sn = np.empty(K)
    ybin = np.empty((K, P), dtype=np.int64)
    for k in range(K):
        cs[k] = math.cos(base_yaws[k])
        sn[k] = math.sin(base_yaws[k])
        for p in range(P):
            ybin[k, p] = wrap_bin(tcp_yaw[p] - base_yaws[k], n_yaw)
    for ci in prange(cells.shape[0]):
        cell = cells[ci]
        iy = cell // nx
        ix = cell - iy * nx
        bx = grid_origin[0] + (ix + 0.5) * grid_res
        by = grid_origin[1] + (iy + 0.5) * grid_res
        best = np.float32(0.0)
        arg = -1
        for k in range(K):
            c = cs[k]
            s = sn[k]
            m = np.float32(np.inf)
            for p in range(P):
                dx = tcp_x[p] - bx
                dy = tcp_y[p] - by
                xr = c * dx + s * dy
                yr = -s * dx + c * dy
                jx = int(math.floor((xr - rm_origin[0]) / rm_res))
                jy = int(math.floor((yr - rm_origin[1]) / rm_res))
                if jx < 0 or jy < 0 or jx >= nxr or jy >= nyr:
                    m = np.float32(0.0)
                    break
                v = slices[p, jx, jy, ybin[k, p]]
                if v < m:
                    m = v
                if m <= best:
                    break
            if m > best:
                best = m
                arg = k
        out_val[iy - out_y0, ix - out_x0] = best
        out_yaw[iy - out_y0, ix - out_x0] = arg
