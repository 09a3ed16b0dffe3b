"""Polygon base footprints against occupied grid cells: which base yaws a cell allows.

An occupied cell stands for its whole closed square (the layer marks every cell an obstacle
reaches into, see ``planning/world/footprints.py``), so a footprint that keeps ``pad`` [m] from every
occupied square keeps ``pad`` from the obstacles themselves. Yaw masks are packed bits: word
``k >> 6``, bit ``k & 63`` is base yaw k.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit, prange


@njit(cache=True)
def _point_segment(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    dx, dy = bx - ax, by - ay
    dd = dx * dx + dy * dy
    t = 0.0 if dd == 0.0 else ((px - ax) * dx + (py - ay) * dy) / dd
    t = min(max(t, 0.0), 1.0)
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


@njit(cache=True)
def _inside(px: float, py: float, poly: npt.NDArray[np.float64]) -> bool:
    """Even-odd rule: whether (px, py) lies inside polygon ``poly`` (k, 2)."""
    k = poly.shape[0]
    inside = False
    for i in range(k):
        x1, y1 = poly[i, 0], poly[i, 1]
        x2, y2 = poly[(i + 1) % k, 0], poly[(i + 1) % k, 1]
        if (y1 > py) != (y2 > py) and px < x1 + (py - y1) * (x2 - x1) / (y2 - y1):
            inside = not inside
    return inside


@njit(cache=True)
def _orient(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True)
def polygon_square_distance(poly: npt.NDArray[np.float64], cx: float, cy: float, half: float) -> float:
    """Distance [m] between polygon ``poly`` (k, 2) and the closed axis-aligned square of centre
    (cx, cy) and half-size ``half`` [m]; 0 when they overlap."""
    sq = np.array([[cx - half, cy - half], [cx + half, cy - half], [cx + half, cy + half], [cx - half, cy + half]])
    k = poly.shape[0]
    if _inside(cx, cy, poly):
        return 0.0
    for i in range(k):
        if abs(poly[i, 0] - cx) <= half and abs(poly[i, 1] - cy) <= half:
            return 0.0
    best = np.inf
    for i in range(k):
        ax, ay = poly[i, 0], poly[i, 1]
        bx, by = poly[(i + 1) % k, 0], poly[(i + 1) % k, 1]
        for j in range(4):
            px, py = sq[j, 0], sq[j, 1]
            qx, qy = sq[(j + 1) % 4, 0], sq[(j + 1) % 4, 1]
            o1 = _orient(ax, ay, bx, by, px, py)
            o2 = _orient(ax, ay, bx, by, qx, qy)
            o3 = _orient(px, py, qx, qy, ax, ay)
            o4 = _orient(px, py, qx, qy, bx, by)
            if o1 * o2 < 0 and o3 * o4 < 0:
                return 0.0  # a proper crossing (touching ones give distance 0 below)
            d = min(_point_segment(px, py, ax, ay, bx, by), _point_segment(ax, ay, px, py, qx, qy))
            if d < best:
                best = d
    return best


@njit(cache=True)
def _rotated(poly: npt.NDArray[np.float64], yaw: float) -> npt.NDArray[np.float64]:
    c, s = math.cos(yaw), math.sin(yaw)
    out = np.empty_like(poly)
    for i in range(poly.shape[0]):
        out[i, 0] = c * poly[i, 0] - s * poly[i, 1]
        out[i, 1] = s * poly[i, 0] + c * poly[i, 1]
    return out


@njit(cache=True, parallel=True)
def block_table(
    poly: npt.NDArray[np.float64], yaws: npt.NDArray[np.float64], pad: float, res: float, radius: int
) -> npt.NDArray[np.uint64]:
    """Which yaws an occupied cell at each offset blocks: (2R + 1, 2R + 1, W) uint64 with R =
    ``radius`` cells and W = ceil(K / 64); entry [R + dy, R + dx] has bit k set when the footprint
    ``poly`` (k, 2) [m], rotated by ``yaws[k]`` [rad], comes within ``pad`` [m] of the cell square
    centred (dx res, dy res) from the base origin."""
    K = yaws.shape[0]
    W = (K + 63) // 64
    n = 2 * radius + 1
    out = np.zeros((n, n, W), dtype=np.uint64)
    rot = np.empty((K, poly.shape[0], 2))
    for k in range(K):
        rot[k] = _rotated(poly, yaws[k])
    for a in prange(n):  # by rows: the yaws of one entry share its words
        for b in range(n):
            for k in range(K):
                if polygon_square_distance(rot[k], (b - radius) * res, (a - radius) * res, res / 2) <= pad:
                    out[a, b, k >> 6] |= np.uint64(1) << np.uint64(k & 63)
    return out


@njit(cache=True, parallel=True)
def band_masks(
    touched: npt.NDArray[np.bool_],
    cells: npt.NDArray[np.int64],
    off_y: npt.NDArray[np.int64],
    off_x: npt.NDArray[np.int64],
    off_bits: npt.NDArray[np.uint64],
    full: npt.NDArray[np.uint64],
) -> npt.NDArray[np.uint64]:
    """Allowed-yaw masks (M, W) uint64 of base ``cells`` (M,) flat indices into ``touched``
    (ny, nx) bool: ``full`` (W,) minus the bits ``off_bits`` (L, W) of every offset (off_y, off_x)
    (L,) whose cell is occupied (cells outside the grid are free)."""
    ny, nx = touched.shape
    M = cells.shape[0]
    W = full.shape[0]
    out = np.empty((M, W), dtype=np.uint64)
    for m in prange(M):
        iy = cells[m] // nx
        ix = cells[m] - iy * nx
        blocked = np.zeros(W, dtype=np.uint64)
        for li in range(off_y.shape[0]):
            y = iy + off_y[li]
            x = ix + off_x[li]
            if 0 <= y < ny and 0 <= x < nx and touched[y, x]:
                done = True
                for w in range(W):
                    blocked[w] |= off_bits[li, w]
                    if blocked[w] != full[w]:
                        done = False
                if done:
                    break
        for w in range(W):
            out[m, w] = full[w] & ~blocked[w]
    return out


@njit(cache=True)
def pose_blocked(
    touched: npt.NDArray[np.bool_], ox: float, oy: float, res: float, poly: npt.NDArray[np.float64], pad: float
) -> bool:
    """Whether polygon ``poly`` (k, 2) in world coordinates [m] comes within ``pad`` [m] of an
    occupied cell square of ``touched`` (ny, nx), grid corner (ox, oy), cell ``res`` [m]."""
    ny, nx = touched.shape
    x0 = poly[:, 0].min() - pad
    x1 = poly[:, 0].max() + pad
    y0 = poly[:, 1].min() - pad
    y1 = poly[:, 1].max() + pad
    i0 = max(int(math.floor((x0 - ox) / res)) - 1, 0)
    i1 = min(int(math.ceil((x1 - ox) / res)) + 1, nx)
    j0 = max(int(math.floor((y0 - oy) / res)) - 1, 0)
    j1 = min(int(math.ceil((y1 - oy) / res)) + 1, ny)
    for j in range(j0, j1):
        for i in range(i0, i1):
            if (
                touched[j, i]
                and polygon_square_distance(poly, ox + (i + 0.5) * res, oy + (j + 0.5) * res, res / 2) <= pad
            ):
                return True
    return False
