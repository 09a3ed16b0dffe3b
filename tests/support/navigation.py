"""The navigation grid as a scipy sparse graph (8-connected), for Dijkstra references."""

from __future__ import annotations

import math

from scipy.sparse import csr_matrix

S2 = math.sqrt(2.0)


def grid_graph(factor, feasible, res):
    ny, nx = factor.shape
    rows, cols, w = [], [], []
    for y in range(ny):
        for x in range(nx):
            if not feasible[y, x]:
                continue
            for dy in (-1, 0, 1):
                for dx in (-1, 0, 1):
                    vy, vx = y + dy, x + dx
                    if (dy, dx) != (0, 0) and 0 <= vy < ny and 0 <= vx < nx and feasible[vy, vx]:
                        rows.append(y * nx + x)
                        cols.append(vy * nx + vx)
                        w.append((res * S2 if dy and dx else res) * factor[vy, vx])
    return csr_matrix((w, (rows, cols)), shape=(ny * nx, ny * nx))
