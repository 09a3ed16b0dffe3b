"""Navigation kernels on a 2D grid: exact distance transform and 8-connected shortest paths.

Grids are (ny, nx) arrays, row = y index, column = x index, cell size ``res`` metres.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_INF = np.inf


@njit(cache=True)
def _dt_1d(f, n, d, v, z):
    """Felzenszwalb-Huttenlocher 1D squared distance transform of f (n,) into d (n,)."""
    k = 0
    v[0] = 0
    z[0] = -_INF
    z[1] = _INF
    first = -1
    for q in range(n):
        if f[q] < _INF:
            first = q
            break
    if first < 0:
        for q in range(n):
            d[q] = _INF
        return
    v[0] = first
    for q in range(first + 1, n):
        if f[q] == _INF:
            continue
        s = ((f[q] + q * q) - (f[v[k]] + v[k] * v[k])) / (2.0 * q - 2.0 * v[k])
        while s <= z[k]:
            k -= 1
            s = ((f[q] + q * q) - (f[v[k]] + v[k] * v[k])) / (2.0 * q - 2.0 * v[k])
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = _INF
    k = 0
    for q in range(n):
        while z[k + 1] < q:
            k += 1
        d[q] = (q - v[k]) * (q - v[k]) + f[v[k]]


@njit(cache=True)
def distance_transform(occupied, res):
    """Exact Euclidean distance [m] from each cell centre to the nearest occupied cell centre.

    occupied: (ny, nx) bool. Returns (ny, nx) float64; inf everywhere if nothing is occupied.
    """
    ny, nx = occupied.shape
    n = max(ny, nx)
    f = np.empty(n)
    d = np.empty(n)
    v = np.empty(n, dtype=np.int64)
    z = np.empty(n + 1)
    tmp = np.empty((ny, nx))
    for y in range(ny):
        for x in range(nx):
            f[x] = 0.0 if occupied[y, x] else _INF
        _dt_1d(f, nx, d, v, z)
        for x in range(nx):
            tmp[y, x] = d[x]
    out = np.empty((ny, nx))
    for x in range(nx):
        for y in range(ny):
            f[y] = tmp[y, x]
        _dt_1d(f, ny, d, v, z)
        for y in range(ny):
            out[y, x] = math.sqrt(d[y]) * res
    return out


@njit(cache=True)
def _push(hk, hv, size, key, val):
    i = size
    hk[i] = key
    hv[i] = val
    while i > 0:
        p = (i - 1) >> 1
        if hk[p] < hk[i] or (hk[p] == hk[i] and hv[p] <= hv[i]):
            break
        hk[p], hk[i] = hk[i], hk[p]
        hv[p], hv[i] = hv[i], hv[p]
        i = p
    return size + 1


@njit(cache=True)
def _pop(hk, hv, size):
    key = hk[0]
    val = hv[0]
    size -= 1
    hk[0] = hk[size]
    hv[0] = hv[size]
    i = 0
    while True:
        left = 2 * i + 1
        if left >= size:
            break
        c = left
        right = left + 1
        if right < size and (hk[right] < hk[left] or (hk[right] == hk[left] and hv[right] < hv[left])):
            c = right
        if hk[i] < hk[c] or (hk[i] == hk[c] and hv[i] <= hv[c]):
            break
        hk[c], hk[i] = hk[i], hk[c]
        hv[c], hv[i] = hv[i], hv[c]
        i = c
    return key, val, size


@njit(cache=True)
def shortest_costs(factor, feasible, sources, source_costs, res, targets):
    """Minimal path cost from the sources to every cell of an 8-connected grid (Dijkstra).

    The edge from cell i to its neighbour j costs ``|p_i - p_j| * factor[j]`` (res or
    res*sqrt(2) times the target cell's factor, the paper's Eq. 5). Only feasible
    cells are entered; infeasible cells keep cost inf.

    Args:
        factor: (ny, nx) float64 >= 1, the slowdown ``1 + lambda d_s``.
        feasible: (ny, nx) bool.
        sources: (k, 2) int64 (iy, ix) start cells; source_costs: (k,) their initial costs.
        res: cell size [m].
        targets: (ny, nx) bool; the search stops once every feasible target cell is settled
            (exact for them; cells not settled by then are returned as inf). An array with no
            True cell means: settle everything.
    Returns:
        cost (ny, nx) float64 [m of free-space travel], pred (ny, nx) int64 flat index of the
        predecessor (-1 at sources and unreached cells).
    """
    ny, nx = factor.shape
    cost = np.full((ny, nx), _INF)
    pred = np.full((ny, nx), -1, dtype=np.int64)
    done = np.zeros((ny, nx), dtype=np.bool_)
    cap = 8 * ny * nx + sources.shape[0] + 1
    hk = np.empty(cap)
    hv = np.empty(cap, dtype=np.int64)
    size = 0
    for s in range(sources.shape[0]):
        y, x = sources[s, 0], sources[s, 1]
        if feasible[y, x] and source_costs[s] < cost[y, x]:
            cost[y, x] = source_costs[s]
            size = _push(hk, hv, size, source_costs[s], y * nx + x)
    remaining = 0
    for y in range(ny):
        for x in range(nx):
            if targets[y, x] and feasible[y, x]:
                remaining += 1
    early = remaining > 0
    diag = res * math.sqrt(2.0)
    while size > 0:
        c, u, size = _pop(hk, hv, size)
        uy = u // nx
        ux = u - uy * nx
        if done[uy, ux]:
            continue
        done[uy, ux] = True
        if early and targets[uy, ux]:
            remaining -= 1
            if remaining == 0:
                break
        for dy in range(-1, 2):
            vy = uy + dy
            if vy < 0 or vy >= ny:
                continue
            for dx in range(-1, 2):
                if dy == 0 and dx == 0:
                    continue
                vx = ux + dx
                if vx < 0 or vx >= nx or not feasible[vy, vx] or done[vy, vx]:
                    continue
                step = diag if dy != 0 and dx != 0 else res
                nc = c + step * factor[vy, vx]
                if nc < cost[vy, vx]:
                    cost[vy, vx] = nc
                    pred[vy, vx] = u
                    size = _push(hk, hv, size, nc, vy * nx + vx)
    if early:
        for y in range(ny):
            for x in range(nx):
                if not done[y, x]:
                    cost[y, x] = _INF
                    pred[y, x] = -1
    return cost, pred
