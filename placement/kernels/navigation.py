"""Navigation kernels on a 2D grid: exact distance transform, 8-connected components and shortest paths.

Grids are (ny, nx) arrays, row = y index, column = x index, cell size ``res`` metres.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

_INF = np.inf
#: the goal-directed search's heuristic is this fraction of the octile distance to the targets' box:
#: below 1 so that every edge still raises a cell's key by (1 - GUIDE) * res * min(factor) (the bucket
#: queue's condition), close to 1 so that the search heads for the targets
GUIDE = 0.9


@njit(cache=True)
def _dt_1d(
    f: npt.NDArray[np.float64], n: int, d: npt.NDArray[np.float64], v: npt.NDArray[np.int64], z: npt.NDArray[np.float64]
) -> None:
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
def distance_transform(occupied: npt.NDArray[np.bool_], res: float) -> npt.NDArray[np.float64]:
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
def _fill(
    mask: npt.NDArray[np.bool_], labels: npt.NDArray[np.int32], stack: npt.NDArray[np.int64], y: int, x: int, n: int
) -> tuple[int, int, int, int]:
    """Label ``n`` on the unlabelled 8-connected cells of ``mask`` reached from (``y``, ``x``) (on the
    mask, unlabelled), a flood fill with ``stack`` (ny nx,) as its work; returns their box (y0, y1,
    x0, x1), half-open."""
    ny, nx = mask.shape
    labels[y, x] = n
    y0, y1, x0, x1 = y, y + 1, x, x + 1
    stack[0] = y * nx + x
    top = 1
    while top > 0:
        top -= 1
        u = stack[top]
        uy = u // nx
        ux = u - uy * nx
        for vy in range(max(uy - 1, 0), min(uy + 2, ny)):
            for vx in range(max(ux - 1, 0), min(ux + 2, nx)):
                if mask[vy, vx] and labels[vy, vx] == 0:
                    labels[vy, vx] = n
                    stack[top] = vy * nx + vx
                    top += 1
                    y0 = min(y0, vy)
                    y1 = max(y1, vy + 1)
                    x0 = min(x0, vx)
                    x1 = max(x1, vx + 1)
    return y0, y1, x0, x1


@njit(cache=True)
def components8(mask: npt.NDArray[np.bool_]) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int64]]:
    """The 8-connected components of ``mask`` (ny, nx): labels (ny, nx) int32, 1..n in the raster
    order of each component's first cell (0 off the mask), and boxes (n, 4) int64, each component's
    rows y0..y1 and columns x0..x1 (half-open), as ``scipy.ndimage.label`` with a 3 x 3 structure
    and ``find_objects`` give them (flood fills from each unlabelled cell in raster order)."""
    ny, nx = mask.shape
    labels = np.zeros((ny, nx), dtype=np.int32)
    stack = np.empty(ny * nx, dtype=np.int64)
    boxes = np.empty((16, 4), dtype=np.int64)
    n = 0
    for y in range(ny):
        for x in range(nx):
            if not mask[y, x] or labels[y, x] != 0:
                continue
            if n == boxes.shape[0]:
                grown = np.empty((2 * n, 4), dtype=np.int64)
                grown[:n] = boxes
                boxes = grown
            n += 1
            y0, y1, x0, x1 = _fill(mask, labels, stack, y, x, n)
            boxes[n - 1, 0] = y0
            boxes[n - 1, 1] = y1
            boxes[n - 1, 2] = x0
            boxes[n - 1, 3] = x1
    return labels, boxes[:n].copy()


@njit(cache=True)
def component_of(mask: npt.NDArray[np.bool_], y: int, x: int) -> npt.NDArray[np.bool_]:
    """(ny, nx) bool: the 8-connected component of ``mask`` holding cell (``y``, ``x``) (nothing when
    that cell is off the mask): one flood fill, its work the component's size."""
    ny, nx = mask.shape
    labels = np.zeros((ny, nx), dtype=np.int32)
    if mask[y, x]:
        _fill(mask, labels, np.empty(ny * nx, dtype=np.int64), y, x, 1)
    out: npt.NDArray[np.bool_] = labels == 1
    return out


@njit(cache=True, inline="always")
def _guide(i: int, W: int, ty0: int, ty1: int, tx0: int, tx1: int, hs: float) -> float:
    """The goal-directed search's heuristic [m] of padded cell ``i`` (row width ``W``): ``hs`` times
    its octile distance [cells] to the targets' box (rows ty0..ty1, columns tx0..tx1); 0 when hs is."""
    if hs == 0.0:
        return 0.0
    y = i // W
    x = i - y * W
    dy = max(ty0 - y, y - ty1, 0)
    dx = max(tx0 - x, x - tx1, 0)
    return hs * (max(dx, dy) + (math.sqrt(2.0) - 1.0) * min(dx, dy))


@njit(cache=True)
def padded_grid(
    factor: npt.NDArray[np.float64], feasible: npt.NDArray[np.bool_]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_], float, float]:
    """The grid as :func:`padded_costs` reads it: (fac (N,), feas (N,)) with a border of infeasible cells
    (N = (ny + 2) (nx + 2), row-major: no bounds checks in the search), and the least and largest
    factor of a feasible cell (inf and 0 when none is)."""
    ny, nx = factor.shape
    W = nx + 2
    N = (ny + 2) * W
    feas = np.zeros(N, dtype=np.bool_)
    fac = np.ones(N)
    fmin = _INF
    fmax = 0.0
    for y in range(ny):
        for x in range(nx):
            i = (y + 1) * W + x + 1
            feas[i] = feasible[y, x]
            fac[i] = factor[y, x]
            if feasible[y, x]:
                fmin = min(fmin, factor[y, x])
                fmax = max(fmax, factor[y, x])
    return fac, feas, fmin, fmax


@njit(cache=True, nogil=True)  # searches of one grid run side by side in threads (their own work arrays)
def padded_costs(
    grid: tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_], float, float],
    work: tuple[
        npt.NDArray[np.float64],
        npt.NDArray[np.int64],
        npt.NDArray[np.bool_],
        npt.NDArray[np.bool_],
        npt.NDArray[np.int64],
    ],
    ny: int,
    nx: int,
    sources: npt.NDArray[np.int64],
    source_costs: npt.NDArray[np.float64],
    res: float,
    targets: npt.NDArray[np.int64],
    reverse: bool = False,
    sparse: bool = False,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Minimal path cost from the sources to every cell of an 8-connected grid (Dijkstra).

    The edge from cell i to its neighbour j costs ``|p_i - p_j| * factor[j]`` (res or
    res*sqrt(2) times the target cell's factor, the paper's Eq. 5). Only feasible
    cells are entered; infeasible cells keep cost inf. With ``reverse`` the cost is that of the
    path from each cell *to* the sources (the graph's edges turned around: the edge into cell u
    from a neighbour costs ``|p_u - p_v| * factor[u]``), and ``pred`` points to the next cell
    towards the sources.

    Args:
        grid: (fac, feas, fmin, fmax) of :func:`padded_grid`: the (ny, nx) grid's slowdown ``1 + lambda
            d_s`` (>= 1) and its feasible cells, padded; made once per grid (a search near its targets
            touches few cells: making them, or its work arrays, took most of its time).
        work: (cost (N,) all inf, prev (N,) all -1, open (N,) equal to feas, tgt (N,) all False, root (N,)
            all -1): the search's work arrays, given back as they came (only the cells the search
            touched are written back), so that the next search on the grid reuses them.
        ny, nx: the grid's shape.
        sources: (k, 2) int64 (iy, ix) start cells; source_costs: (k,) their initial costs.
        res: cell size [m].
        targets: (t,) int64 flat cells of the (ny, nx) grid; the search stops once every feasible
            target cell is settled (exact for them; cells not settled by then are returned as inf) and
            is directed at them (see below). No target means: settle everything.
        sparse: return the targets' costs and sources only, not the (ny, nx) maps (which, made anew
            for every search, cost more than a search near its targets).
    Returns:
        cost (ny, nx) float64 [m of free-space travel], pred (ny, nx) int64 flat index of the
        predecessor (-1 at sources and unreached cells) (both (0, 0) when ``sparse``); and when
        ``sparse``, (t,) each target's cost and (t,) the flat source its shortest path starts from
        (the target itself where unreached), else both empty.
    """
    # Dijkstra with a bucket queue instead of a heap (Dial's algorithm with buckets narrower than
    # the shortest edge): every edge costs at least ``res * min(factor)``, so no cell of the lowest
    # non-empty bucket can be improved by another cell of that bucket or a later one: all its
    # labels are final and the bucket is settled in any order. Costs equal Dijkstra's exactly (a
    # cell's cost is the minimum of cost[u] + w over the neighbours u settled before it, the same
    # set either way); among equal-cost paths the predecessor may differ.
    # With targets the buckets hold keys cost + h (A*), h = GUIDE * res * min(factor) * the octile
    # distance to the targets' bounding box: h changes along an edge by at most GUIDE times the edge's
    # least cost (the octile distance to a box is 1-Lipschitz), so an edge raises a key by at least
    # (1 - GUIDE) * res * min(factor), the bucket width: a key's bucket is still final when reached,
    # and a target's cost is exact once settled; cells farther from the targets are never reached.
    fac, feas, fmin, fmax = grid
    cost, prev, open_, tgt, root = work
    W = nx + 2
    N = (ny + 2) * W
    remaining = 0
    ty0, ty1, tx0, tx1 = N, -1, N, -1  # the feasible targets' box (padded indices)
    for t in range(targets.shape[0]):
        y, x = targets[t] // nx, targets[t] % nx
        i = (y + 1) * W + x + 1
        if feas[i] and not tgt[i]:
            tgt[i] = True
            remaining += 1
            ty0, ty1 = min(ty0, y + 1), max(ty1, y + 1)
            tx0, tx1 = min(tx0, x + 1), max(tx1, x + 1)
    early = remaining > 0
    hs = GUIDE * res * fmin if early else 0.0  # heuristic per unit of octile distance [m]
    # (computed where a cell is queued, not for every cell: a search near its targets touches few)
    diag = res * math.sqrt(2.0)
    # a hair below the least key increase along an edge, against rounding
    delta = (res * fmin - hs) / (1.0 + 1e-9)
    # entries: (cell, next entry in its bucket); a cell is entered again when its cost drops; int32
    # halves their memory traffic (the wrapper refuses grids whose 9 N entries would not fit)
    cap = 9 * N + sources.shape[0] + 1
    settled = np.empty(N, dtype=np.int32)  # in the order they were settled
    n_settled = 0
    ent_cell = np.empty(cap, dtype=np.int32)
    ent_next = np.empty(cap, dtype=np.int32)
    n_ent = 0
    lo = _INF
    hi = 0.0
    for s in range(sources.shape[0]):
        i = (sources[s, 0] + 1) * W + sources[s, 1] + 1
        if feas[i] and source_costs[s] < cost[i]:
            cost[i] = source_costs[s]
    for s in range(sources.shape[0]):
        i = (sources[s, 0] + 1) * W + sources[s, 1] + 1
        if feas[i] and cost[i] == source_costs[s]:
            hi_ = _guide(i, W, ty0, ty1, tx0, tx1, hs)
            lo = min(lo, cost[i] + hi_)
            hi = max(hi, cost[i] + hi_)
    if lo == _INF:
        for t in range(targets.shape[0]):
            tgt[(targets[t] // nx + 1) * W + targets[t] % nx + 1] = False
        if sparse:
            at = np.empty(targets.shape[0], dtype=np.int64)
            at[:] = targets
            return np.full((0, 0), _INF), np.full((0, 0), -1, dtype=np.int64), np.full(targets.shape[0], _INF), at
        return (
            np.full((ny, nx), _INF),
            np.full((ny, nx), -1, dtype=np.int64),
            np.empty(0),
            np.empty(0, dtype=np.int64),
        )
    # live keys span at most (sources' spread + the largest key increase along an edge): a ring of
    # buckets that wide
    nb = int((hi - lo + diag * fmax + math.sqrt(2.0) * hs) / delta) + 3
    head = np.full(nb, -1, dtype=np.int32)
    base = lo
    live = 0
    for s in range(sources.shape[0]):
        i = (sources[s, 0] + 1) * W + sources[s, 1] + 1
        if open_[i] and cost[i] == source_costs[s]:
            b = int((cost[i] + _guide(i, W, ty0, ty1, tx0, tx1, hs) - base) / delta) % nb
            ent_cell[n_ent] = i
            ent_next[n_ent] = head[b]
            head[b] = n_ent
            n_ent += 1
            live += 1
    offs = np.array([-W - 1, -W, -W + 1, -1, 1, W - 1, W, W + 1])
    steps = np.array([diag, res, diag, res, res, diag, res, diag])
    k = 0
    stop = False
    while live > 0 and not stop:
        b = k % nb
        while head[b] >= 0:
            e = head[b]
            head[b] = ent_next[e]
            live -= 1
            u = ent_cell[e]
            if not open_[u]:  # settled already (entered again at a lower cost before)
                continue
            open_[u] = False
            settled[n_settled] = u
            n_settled += 1
            if early and tgt[u]:
                remaining -= 1
                if remaining == 0:
                    stop = True
                    break
            c = cost[u]
            fu = fac[u]
            for j in range(8):
                v = u + offs[j]
                if not open_[v]:
                    continue
                nc = c + steps[j] * (fu if reverse else fac[v])
                if nc < cost[v]:
                    cost[v] = nc
                    prev[v] = u
                    kb = int((nc + _guide(v, W, ty0, ty1, tx0, tx1, hs) - base) / delta)
                    if kb <= k:  # cannot happen (edges are longer than a bucket): never lose a cell
                        kb = k + 1
                    bb = kb % nb
                    ent_cell[n_ent] = v
                    ent_next[n_ent] = head[bb]
                    head[bb] = n_ent
                    n_ent += 1
                    live += 1
        k += 1
    cost_at = np.empty(targets.shape[0] if sparse else 0)
    source_at = np.empty(targets.shape[0] if sparse else 0, dtype=np.int64)
    if sparse:
        out = np.full((0, 0), _INF)
        pred = np.full((0, 0), -1, dtype=np.int64)
        trail = np.empty(n_settled + 1, dtype=np.int64)
        for t in range(targets.shape[0]):
            i = (targets[t] // nx + 1) * W + targets[t] % nx + 1
            cost_at[t] = cost[i]
            if cost[i] == _INF or open_[i]:  # not reached (a settled cell's path is final)
                source_at[t] = targets[t]
                continue
            # the path back to its source, every cell on it given that source (each followed once)
            u = i
            depth = 0
            while root[u] < 0 and prev[u] >= 0:
                trail[depth] = u
                depth += 1
                u = prev[u]
            r = root[u] if root[u] >= 0 else u
            root[u] = r
            for d in range(depth):
                root[trail[d]] = r
            source_at[t] = (r // W - 1) * nx + (r % W - 1)
        for k in range(n_settled):
            root[settled[k]] = -1
    elif early:  # only the settled cells have their costs (a search near its targets settles few)
        out = np.full((ny, nx), _INF)
        pred = np.full((ny, nx), -1, dtype=np.int64)
        for k in range(n_settled):
            i = settled[k]
            y, x = i // W - 1, i % W - 1
            out[y, x] = cost[i]
            p = prev[i]
            if p >= 0:
                pred[y, x] = (p // W - 1) * nx + (p % W - 1)
    else:
        out = np.full((ny, nx), _INF)
        pred = np.full((ny, nx), -1, dtype=np.int64)
        for y in range(ny):
            for x in range(nx):
                i = (y + 1) * W + x + 1
                out[y, x] = cost[i]
                p = prev[i]
                if p >= 0:
                    pred[y, x] = (p // W - 1) * nx + (p % W - 1)
    # the work arrays as they came (what the search touched only: every cell it queued and the targets)
    for e in range(n_ent):
        i = ent_cell[e]
        cost[i] = _INF
        prev[i] = -1
        open_[i] = feas[i]
    for t in range(targets.shape[0]):
        tgt[(targets[t] // nx + 1) * W + targets[t] % nx + 1] = False
    return out, pred, cost_at, source_at
