"""Inverse reachability by slicing: the manipulation map of a TCP trajectory over base poses.

For a TCP pose with world position p, yaw psi (and pitch, roll), a base at (bx, by)
with yaw a sees the TCP at ``Rz(-a) (p - b)`` with yaw ``psi - a`` and unchanged z,
pitch and roll. So each TCP pose needs one stored slice of the reachability map
(fixed z, pitch, roll bins: (nx, ny, n_yaw)), looked up at rotated positions.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit, prange

from placement.kernels.grid import wrap_bin

CHUNK = 64  # cells per parallel task: per-task scratch, no allocation per cell


@njit(cache=True, parallel=True)
def trajectory_maps(
    slices: npt.NDArray[np.float32],
    column_max: npt.NDArray[np.float32],
    tcp_x: npt.NDArray[np.float64],
    tcp_y: npt.NDArray[np.float64],
    tcp_yaw: npt.NDArray[np.float64],
    rm_origin: npt.NDArray[np.float64],
    rm_res: float,
    base_yaws: npt.NDArray[np.float64],
    grid_origin: npt.NDArray[np.float64],
    grid_res: float,
    ny: int,
    nx: int,
    cells: npt.NDArray[np.int64],
    masks: npt.NDArray[np.uint64],
    out_val: npt.NDArray[np.float32],
    out_yaw: npt.NDArray[np.int16],
    out_y0: int = 0,
    out_x0: int = 0,
) -> None:
    """Min over the trajectory, max over the cell's allowed base yaws, of the map value, per base cell, for C
    trajectories at once that share their positions and map slices and differ only in yaw.

    Candidates of one step (two top grasps, eight place yaws) hold the TCP at the same points with
    the same tilt: the rotated position of a pose seen from a base pose is computed once and the map
    row read there serves all C of them. Each candidate's result equals its own one-trajectory
    evaluation exactly (same arithmetic; an early exit never changes a result).

    A base yaw whose first pose lands on a map column (all yaw bins at one position) whose maximum is
    at most every candidate's best so far is skipped: no value there could beat a best (a strict
    improvement is needed), so the results are those of evaluating it.

    Args:
        slices: (P, nx_rm, ny_rm, n_yaw) float32, the map slice of each TCP pose.
        column_max: (nx_rm, ny_rm) float32, ``slices[0].max(axis=2)`` (or any upper bound of it).
        tcp_x, tcp_y: (P,) world position of each pose [m]; tcp_yaw: (C, P) ZYX yaw of each
            candidate's poses [rad].
        rm_origin: (2,) map grid lower corner (x, y) in the base frame [m]; rm_res [m].
        base_yaws: (K,) base yaws to try [rad].
        grid_origin: (2,) navigation grid corner [m]; grid_res [m]; ny, nx its shape.
        cells: (N,) int64 flat indices of the base cells to evaluate (others untouched).
        masks: (N, W) uint64, the base yaws allowed on each cell (bit k & 63 of word k >> 6 is yaw
            k; a polygon footprint fits only at some yaws); a cell allowing none gets 0.
        out_val: (C, h, w) float32, best value (0 = unreachable); out_yaw: (C, h, w) int16,
            index into base_yaws of the best yaw (-1 if unreachable): a window of the grid whose
            cell (0, 0) is grid cell (out_y0, out_x0); it must contain every cell of ``cells``.
    """
    P = slices.shape[0]
    nxr = slices.shape[1]
    nyr = slices.shape[2]
    n_yaw = slices.shape[3]
    K = base_yaws.shape[0]
    C = tcp_yaw.shape[0]
    # per-yaw constants, shared by every cell
    cs = np.empty(K)
    sn = np.empty(K)
    ybin = np.empty((K, P, C), dtype=np.int64)
    for k in range(K):
        cs[k] = math.cos(base_yaws[k])
        sn[k] = math.sin(base_yaws[k])
        for p in range(P):
            for c in range(C):
                ybin[k, p, c] = wrap_bin(tcp_yaw[c, p] - base_yaws[k], n_yaw)
    n = cells.shape[0]
    for chunk in prange((n + CHUNK - 1) // CHUNK):
        best = np.empty(C, dtype=np.float32)
        arg = np.empty(C, dtype=np.int64)
        m = np.empty(C, dtype=np.float32)
        alive = np.empty(C, dtype=np.bool_)
        for ci in range(chunk * CHUNK, min(n, (chunk + 1) * CHUNK)):
            cell = cells[ci]
            iy = cell // nx
            ix = cell - iy * nx
            bx = grid_origin[0] + (ix + 0.5) * grid_res
            by = grid_origin[1] + (iy + 0.5) * grid_res
            for c in range(C):
                best[c] = np.float32(0.0)
                arg[c] = -1
            floor = np.float32(0.0)  # the least best over the candidates
            for k in range(K):
                if (masks[ci, k >> 6] >> np.uint64(k & 63)) & np.uint64(1) == 0:
                    continue
                co = cs[k]
                s = sn[k]
                for c in range(C):
                    m[c] = np.float32(np.inf)
                    alive[c] = True
                left = C
                for p in range(P):
                    dx = tcp_x[p] - bx
                    dy = tcp_y[p] - by
                    xr = co * dx + s * dy
                    yr = -s * dx + co * dy
                    jx = int(math.floor((xr - rm_origin[0]) / rm_res))
                    jy = int(math.floor((yr - rm_origin[1]) / rm_res))
                    if jx < 0 or jy < 0 or jx >= nxr or jy >= nyr:
                        left = 0  # unreachable for all: m would be 0, never above best
                        break
                    if p == 0 and column_max[jx, jy] <= floor:
                        left = 0  # no candidate's value here can beat its best
                        break
                    for c in range(C):
                        if alive[c]:
                            v = slices[p, jx, jy, ybin[k, p, c]]
                            if v < m[c]:
                                m[c] = v
                            if m[c] <= best[c]:
                                alive[c] = False
                                left -= 1
                    if left == 0:
                        break
                if left > 0:
                    for c in range(C):
                        if alive[c] and m[c] > best[c]:
                            best[c] = m[c]
                            arg[c] = k
                    floor = best[0]
                    for c in range(1, C):
                        floor = min(floor, best[c])
            for c in range(C):
                out_val[c, iy - out_y0, ix - out_x0] = best[c]
                out_yaw[c, iy - out_y0, ix - out_x0] = arg[c]
