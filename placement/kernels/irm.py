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


@njit(cache=True)
def column_maxima(values: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
    """(nx, ny) float32: the maximum of ``values`` (nx, ny, n_yaw) over its last axis (a slice's bound
    per (x, y) cell, which the kernel skips base yaws with; numpy reduces a short last axis slowly)."""
    nx, ny, nyaw = values.shape
    out = np.empty((nx, ny), dtype=np.float32)
    for jx in range(nx):
        for jy in range(ny):
            m = values[jx, jy, 0]
            for k in range(1, nyaw):
                v = values[jx, jy, k]
                if v > m:
                    m = v
            out[jx, jy] = m
    return out


@njit(cache=True)
def yaw_bits(values: npt.NDArray[np.float32], above: float) -> npt.NDArray[np.uint64]:
    """(nx, ny) uint64: per (x, y) cell of ``values`` (nx, ny, n_yaw), n_yaw <= 64, bit b set when
    yaw bin b holds a value above ``above`` (compared in float32, as the kernel compares): what a
    threshold pass reads, an eighth of a slice's bytes."""
    nx, ny, nyaw = values.shape
    out = np.zeros((nx, ny), dtype=np.uint64)
    a = np.float32(above)
    for jx in range(nx):
        for jy in range(ny):
            w = np.uint64(0)
            for k in range(nyaw):
                if values[jx, jy, k] > a:
                    w |= np.uint64(1) << np.uint64(k)
            out[jx, jy] = w
    return out


@njit(cache=True)
def farthest_reached(values: npt.NDArray[np.float32], x0: float, y0: float, res: float) -> float:
    """Largest distance [m] from the origin to a point of a cell of ``values`` (nx, ny, n_yaw) holding
    a value other than 0 at some yaw bin, the grid's lower corner at (``x0``, ``y0``) [m] and its cells
    ``res`` [m] wide (a slice's reach: a pose farther than this from the base reads 0 at every base
    yaw); -1 if no cell holds one."""
    nx, ny, nyaw = values.shape
    far = -1.0
    for jx in range(nx):
        fx = max(abs(x0 + jx * res), abs(x0 + (jx + 1) * res))
        for jy in range(ny):
            fy = max(abs(y0 + jy * res), abs(y0 + (jy + 1) * res))
            d = math.sqrt(fx * fx + fy * fy)
            if d <= far:
                continue
            for k in range(nyaw):
                if values[jx, jy, k] != 0:
                    far = d
                    break
    return far


#: Bins of the relative angle (a pose's yaw less its bearing from the base) in a slice's polar bound
POLAR_ANGLES = 64


@njit(cache=True, nogil=True)  # may be made in the background thread (planning.problems.manipulation)
def polar_bound(
    values: npt.NDArray[np.float32], x0: float, y0: float, res: float, rows_per_m: float, n_angle: int
) -> npt.NDArray[np.float32]:
    """(R, n_angle) float32: an upper bound of what a TCP pose reads from the slice ``values`` (nx, ny,
    n_yaw; its grid's lower corner at (``x0``, ``y0``) [m], cells ``res`` [m] wide) at any base yaw,
    by the pose's distance d [m] from the base and its relative angle (its yaw less its bearing
    atan2(dy, dx) from the base [rad]): row ``int(d * rows_per_m)``, bin ``floor(angle / (2 pi /
    n_angle)) mod n_angle``; a distance past the last row reads 0 everywhere.

    Turning the base turns a pose's position and its yaw in the base frame by the same angle, so
    neither its distance nor its relative angle changes: a cell of the base grid whose pose's entry
    is at most a threshold keeps it at no base yaw, and the inverse-map kernel skips it with one
    lookup instead of a scan of every base yaw. Each map value is entered at its cell centre's
    distance and relative angle, then spread over every bin a point of its cell and an angle of its
    yaw bin can fall in (the cell's half-diagonal in distance and bearing, half a yaw bin, one bin
    of slack on each side), so the bound holds for every point the kernel may read, whatever the
    rounding."""
    nx, ny, nyaw = values.shape
    two_pi = 2.0 * math.pi
    w = two_pi / nyaw
    da = two_pi / n_angle
    h = 0.5 * math.sqrt(2.0) * res
    fx = max(abs(x0), abs(x0 + nx * res))
    fy = max(abs(y0), abs(y0 + ny * res))
    spread = int(math.ceil(h * rows_per_m)) + 1
    rows = int(math.sqrt(fx * fx + fy * fy) * rows_per_m) + spread + 2
    centre = np.zeros((rows, n_angle), dtype=np.float32)
    for jx in range(nx):
        cx = x0 + (jx + 0.5) * res
        for jy in range(ny):
            cy = y0 + (jy + 0.5) * res
            row = int(math.sqrt(cx * cx + cy * cy) * rows_per_m)
            bearing = math.atan2(cy, cx)
            for b in range(nyaw):
                v = values[jx, jy, b]
                if v <= 0:
                    continue
                k = int(math.floor((b * w - bearing) / da)) % n_angle
                if k < 0:
                    k += n_angle
                if v > centre[row, k]:
                    centre[row, k] = v
    turned = np.zeros((rows, n_angle), dtype=np.float32)
    ring = np.zeros(3 * n_angle, dtype=np.float32)  # a row three times over: windows need no modulo
    live = np.zeros(rows, dtype=np.bool_)
    for r in range(rows):
        m = np.float32(0.0)
        for k in range(n_angle):
            m = max(m, centre[r, k])
        if m <= 0:
            continue
        live[r] = True
        near = r / rows_per_m  # the least distance of a cell centre entered in this row
        bearing = math.asin(h / near) if near > h else math.pi
        half = int(math.ceil((0.5 * w + bearing) / da)) + 1
        if 2 * half + 1 >= n_angle:
            for k in range(n_angle):
                turned[r, k] = m
            continue
        for k in range(n_angle):
            ring[k] = ring[k + n_angle] = ring[k + 2 * n_angle] = centre[r, k]
        for k in range(n_angle):
            m = np.float32(0.0)
            for j in range(n_angle + k - half, n_angle + k + half + 1):
                m = max(m, ring[j])
            turned[r, k] = m
    out = np.zeros((rows, n_angle), dtype=np.float32)
    for j in range(rows):
        if not live[j]:
            continue
        for r in range(max(j - spread, 0), min(j + spread + 1, rows)):
            for k in range(n_angle):
                out[r, k] = max(out[r, k], turned[j, k])
    return out


@njit(cache=True, parallel=True, nogil=True)  # runs in a background thread: planning.problems.background
def trajectory_maps(
    slices: npt.NDArray[np.float32],
    slice_row: npt.NDArray[np.int64],
    bits: npt.NDArray[np.uint64],
    polar: npt.NDArray[np.float32],
    polar_rows_per_m: float,
    column_max: npt.NDArray[np.float32],
    pose_slice: npt.NDArray[np.int64],
    pose_x: npt.NDArray[np.float64],
    pose_y: npt.NDArray[np.float64],
    group_pose: npt.NDArray[np.int64],
    group_member: npt.NDArray[np.int64],
    member_row: npt.NDArray[np.int64],
    member_yaw: npt.NDArray[np.float64],
    group_column: npt.NDArray[np.int64],
    group_disc: npt.NDArray[np.float64],
    rm_origin: npt.NDArray[np.float64],
    rm_res: float,
    base_yaws: npt.NDArray[np.float64],
    grid_origin: npt.NDArray[np.float64],
    grid_res: float,
    nx: int,
    cells: npt.NDArray[np.int64],
    masks: npt.NDArray[np.uint64],
    out_val: npt.NDArray[np.float32],
    out_yaw: npt.NDArray[np.int16],
    out_y0: int = 0,
    out_x0: int = 0,
    above: float = 0.0,
    first: bool = False,
) -> None:
    """Min over the trajectory, max over the cell's allowed base yaws, of the map value, per base
    cell, for G groups of trajectories in one pass; the trajectories of a group share their positions
    and map slices and differ only in yaw.

    Candidates of one step (two top grasps, eight place yaws) hold the TCP at the same points with
    the same tilt: the rotated position of a pose seen from a base pose is computed once and the map
    row read there serves every member of its group. Each member's result equals its own
    one-trajectory evaluation exactly (same arithmetic; an early exit never changes a result).

    A base yaw whose first pose lands on a map column (all yaw bins at one position) whose maximum is
    at most every member's best so far is skipped: no value there could beat a best (a strict
    improvement is needed), so the results are those of evaluating it.

    Args:
        slices: (R, nx_rm, ny_rm, n_yaw) float32, map slices: the pass's slice s is
            ``slices[slice_row[s]]`` (a slab of the map's slices, :meth:`ReachabilityMap.stacked`).
        slice_row: (S,) int64, the row of ``slices`` of each of the pass's S slices.
        bits: (S, nx_rm, ny_rm) uint64, :func:`yaw_bits` of each slice for ``above``, read instead of
            the slices by a ``first`` pass of a one-member group until a yaw keeps every pose above
            ``above`` (whose values are then read: the same results, an eighth of the bytes read);
            (0, 0, 0): the slices are read.
        polar: (S, R, A) float32, :func:`polar_bound` of each slice at ``polar_rows_per_m`` rows per
            metre: a base cell where some pose of a member reads at most ``above`` there leaves that
            member's value 0 unread, and one where every member's does is skipped; (0, 0, 0): none.
        column_max: (B, nx_rm, ny_rm) float32 upper bounds, ``slice.max(axis=2)`` of some slices.
        pose_slice: (M,) the slice of each pose; pose_x, pose_y: (M,) its world position [m].
        group_pose: (G + 1,) group g's poses are ``group_pose[g]:group_pose[g + 1]`` (P_g of them).
        group_member: (G + 1,) group g's members are ``group_member[g]:group_member[g + 1]`` (C_g of
            them); member_row: (R,) the output row of each member.
        member_yaw: (sum of C_g P_g,) the ZYX yaw [rad] of each member's poses: group by group,
            member by member (in member order), pose by pose.
        group_column: (G,) index into ``column_max`` of the bound of group g's first pose.
        group_disc: (G, 3) per group (x [m], y [m], r [m]): base cells whose centre is farther than r
            from (x, y) are not evaluated (their rows keep what the caller put there); r = inf: all.
        rm_origin: (2,) map grid lower corner (x, y) in the base frame [m]; rm_res [m].
        base_yaws: (K,) base yaws to try [rad].
        grid_origin: (2,) navigation grid corner [m]; grid_res [m]; nx its column count.
        cells: (N,) int64 flat indices of the base cells to evaluate (others untouched).
        masks: (N, W) uint64, the base yaws allowed on each cell (bit k & 63 of word k >> 6 is yaw
            k; a polygon footprint fits only at some yaws); a cell allowing none gets 0.
        out_val: (rows, h, w) float32, best value (0 = unreachable); out_yaw: (rows, h, w) int16,
            index into base_yaws of the best yaw (-1 if unreachable): a window of the grid whose
            cell (0, 0) is grid cell (out_y0, out_x0); it must contain every cell of ``cells``.
        above: only values above it count (below or at it: 0 and -1, as unreachable); 0: all.
        first: stop at a cell once every member has a value above ``above``: its value and yaw are
            then the first found, not the best (a region's test ``value > above`` in a fraction of the
            time; with ``above`` 0: reachable or not).
    """
    G = group_pose.shape[0] - 1
    n_yaw = slices.shape[3]
    nxr = slices.shape[1]
    nyr = slices.shape[2]
    K = base_yaws.shape[0]
    cs = np.empty(K)
    sn = np.empty(K)
    for k in range(K):
        cs[k] = math.cos(base_yaws[k])
        sn[k] = math.sin(base_yaws[k])
    # per group: where its yaws and its yaw bins (K, P, C) start
    yaw_start = np.zeros(G + 1, dtype=np.int64)
    for g in range(G):
        P = group_pose[g + 1] - group_pose[g]
        C = group_member[g + 1] - group_member[g]
        yaw_start[g + 1] = yaw_start[g] + P * C
    ybin = np.empty(yaw_start[G] * K, dtype=np.int64)
    for g in prange(G):
        P = group_pose[g + 1] - group_pose[g]
        C = group_member[g + 1] - group_member[g]
        for k in range(K):
            for p in range(P):
                for c in range(C):
                    yaw = member_yaw[yaw_start[g] + c * P + p]
                    ybin[yaw_start[g] * K + (k * P + p) * C + c] = wrap_bin(yaw - base_yaws[k], n_yaw)
    pose_row = np.empty(pose_slice.shape[0], dtype=np.int64)
    for p in range(pose_slice.shape[0]):
        pose_row[p] = slice_row[pose_slice[p]]
    n = cells.shape[0]
    chunks = (n + CHUNK - 1) // CHUNK
    one = np.uint64(1)
    n_rows = polar.shape[1]
    angle_bins = polar.shape[2] / (2.0 * math.pi)
    n_angle = polar.shape[2]
    for task in prange(G * chunks):
        g = task // chunks
        chunk = task - g * chunks
        p0 = group_pose[g]
        P = group_pose[g + 1] - p0
        r0 = group_member[g]
        C = group_member[g + 1] - r0
        yb0 = yaw_start[g] * K
        b = group_column[g]
        dx0, dy0, reach = group_disc[g, 0], group_disc[g, 1], group_disc[g, 2]
        best = np.empty(C, dtype=np.float32)
        arg = np.empty(C, dtype=np.int64)
        m = np.empty(C, dtype=np.float32)
        alive = np.empty(C, dtype=np.bool_)
        dead = np.zeros(C, dtype=np.bool_)
        prow = np.empty(P, dtype=np.int64)
        pbear = np.empty(P)
        pdx = np.empty(P)
        pdy = np.empty(P)
        pjx = np.empty(P, dtype=np.int64)
        pjy = np.empty(P, dtype=np.int64)
        by_bits = first and C == 1 and bits.shape[0] > 0
        for ci in range(chunk * CHUNK, min(n, (chunk + 1) * CHUNK)):
            cell = cells[ci]
            iy = cell // nx
            ix = cell - iy * nx
            bx = grid_origin[0] + (ix + 0.5) * grid_res
            by = grid_origin[1] + (iy + 0.5) * grid_res
            if (bx - dx0) * (bx - dx0) + (by - dy0) * (by - dy0) > reach * reach:
                continue
            for c in range(C):
                best[c] = np.float32(above)
                arg[c] = -1
            floor = np.float32(above)  # the least best over the members
            found = 0  # members with a value above ``above`` (or none by the polar bound)
            if polar.shape[0] > 0:  # members some pose of which reads at most ``above`` at every yaw
                for p in range(P):
                    pdx[p] = pose_x[p0 + p] - bx
                    pdy[p] = pose_y[p0 + p] - by
                    prow[p] = int(math.sqrt(pdx[p] * pdx[p] + pdy[p] * pdy[p]) * polar_rows_per_m)
                    pbear[p] = math.atan2(pdy[p], pdx[p])
                for c in range(C):
                    dead[c] = False
                    for p in range(P):
                        row = prow[p]
                        if row >= n_rows:
                            dead[c] = True
                            break
                        rel = member_yaw[yaw_start[g] + c * P + p] - pbear[p]
                        k = int(math.floor(rel * angle_bins)) % n_angle
                        if k < 0:
                            k += n_angle
                        if polar[pose_slice[p0 + p], row, k] <= above:
                            dead[c] = True
                            break
                    if dead[c]:
                        found += 1
                if found == C:
                    for c in range(C):
                        out_val[member_row[r0 + c], iy - out_y0, ix - out_x0] = 0.0
                        out_yaw[member_row[r0 + c], iy - out_y0, ix - out_x0] = -1
                    continue
            if C == 1:  # one member (trajectories at distinct points): no per-member bookkeeping
                for p in range(P):
                    pdx[p] = pose_x[p0 + p] - bx
                    pdy[p] = pose_y[p0 + p] - by
                b1 = np.float32(above)
                a1 = -1
                for k in range(K):
                    if (masks[ci, k >> 6] >> np.uint64(k & 63)) & np.uint64(1) == 0:
                        continue
                    co = cs[k]
                    s = sn[k]
                    if by_bits:  # the first yaw whose every pose lies above ``above``: bits, then values
                        kept = True
                        for p in range(P):
                            jx = int(math.floor(((co * pdx[p] + s * pdy[p]) - rm_origin[0]) / rm_res))
                            jy = int(math.floor(((-s * pdx[p] + co * pdy[p]) - rm_origin[1]) / rm_res))
                            if jx < 0 or jy < 0 or jx >= nxr or jy >= nyr:
                                kept = False
                                break
                            if (bits[pose_slice[p0 + p], jx, jy] >> np.uint64(ybin[yb0 + k * P + p])) & one == 0:
                                kept = False
                                break
                            pjx[p] = jx
                            pjy[p] = jy
                        if kept:
                            b1 = np.float32(np.inf)
                            for p in range(P):
                                v = slices[pose_row[p0 + p], pjx[p], pjy[p], ybin[yb0 + k * P + p]]
                                if v < b1:
                                    b1 = v
                            a1 = k
                            break
                        continue
                    v1 = np.float32(np.inf)
                    for p in range(P):
                        jx = int(math.floor(((co * pdx[p] + s * pdy[p]) - rm_origin[0]) / rm_res))
                        jy = int(math.floor(((-s * pdx[p] + co * pdy[p]) - rm_origin[1]) / rm_res))
                        if jx < 0 or jy < 0 or jx >= nxr or jy >= nyr:
                            v1 = np.float32(0.0)  # unreachable: 0, never above the best
                            break
                        if p == 0 and column_max[b, jx, jy] <= b1:
                            v1 = np.float32(0.0)
                            break
                        v = slices[pose_row[p0 + p], jx, jy, ybin[yb0 + k * P + p]]
                        if v < v1:
                            v1 = v
                        if v1 <= b1:
                            break
                    if v1 > b1:
                        b1 = v1
                        a1 = k
                        if first:
                            break
                if a1 < 0:
                    b1 = np.float32(0.0)
                out_val[member_row[r0], iy - out_y0, ix - out_x0] = b1
                out_yaw[member_row[r0], iy - out_y0, ix - out_x0] = a1
                continue
            for k in range(K):
                if (masks[ci, k >> 6] >> np.uint64(k & 63)) & np.uint64(1) == 0:
                    continue
                co = cs[k]
                s = sn[k]
                left = C
                for c in range(C):
                    m[c] = np.float32(np.inf)
                    alive[c] = not dead[c]
                    if dead[c]:
                        left -= 1
                for p in range(P):
                    sl = pose_row[p0 + p]
                    dx = pose_x[p0 + p] - bx
                    dy = pose_y[p0 + p] - by
                    xr = co * dx + s * dy
                    yr = -s * dx + co * dy
                    jx = int(math.floor((xr - rm_origin[0]) / rm_res))
                    jy = int(math.floor((yr - rm_origin[1]) / rm_res))
                    if jx < 0 or jy < 0 or jx >= nxr or jy >= nyr:
                        left = 0  # unreachable for all: m would be 0, never above best
                        break
                    if p == 0 and column_max[b, jx, jy] <= floor:
                        left = 0  # no member's value here can beat its best
                        break
                    for c in range(C):
                        if alive[c]:
                            v = slices[sl, jx, jy, ybin[yb0 + (k * P + p) * C + c]]
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
                            if arg[c] < 0:
                                found += 1
                            best[c] = m[c]
                            arg[c] = k
                    floor = np.float32(np.inf)
                    for c in range(C):
                        if not dead[c]:
                            floor = min(floor, best[c])
                    if first and found == C:
                        break
            for c in range(C):
                if arg[c] < 0:
                    best[c] = np.float32(0.0)
                out_val[member_row[r0 + c], iy - out_y0, ix - out_x0] = best[c]
                out_yaw[member_row[r0 + c], iy - out_y0, ix - out_x0] = arg[c]
