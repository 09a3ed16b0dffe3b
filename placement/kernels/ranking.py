"""Eq. 6 over one manipulation map's window, and the cheapest cells of each tier, in one pass."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit


@njit(cache=True)
def rank_window(
    value: npt.NDArray[np.float32],
    nav: npt.NDArray[np.float64],
    heur: npt.NDArray[np.float64],
    thr32: np.float32,
    lam_n: float,
    lam_m32: np.float32,
    lam_nh: float,
    k: int,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """Costs ``lam_n nav + lam_m / value + lam_nh heur`` of the cells that keep the threshold, and
    the ``k`` cheapest of each tier.

    Arithmetic as numpy does it on these dtypes (the reference in tests/test_ranking.py): the
    threshold and ``lam_m`` are float32 like the map, so ``lam_m / value`` and ``value >= thr`` are
    float32 operations, the sum float64.

    Args:
        value: (h, w) float32 map window (0 outside it). nav, heur: (h, w) float64 costs [m] over
            the same window (inf where unknown).
        thr32: float32 threshold; lam_n, lam_nh: float64 weights [1/m]; lam_m32: float32 weight.
        k: how many cells per tier.
    Returns:
        (idx0, cost0, idx1, cost1): flat indices into the window and costs of the cheapest cells of
        tier 0 (the 3 x 3 neighbourhood keeps the threshold) and tier 1 (the others), by cost then
        index.
    """
    h, w = value.shape
    n = h * w
    idx = np.empty(n, dtype=np.int64)
    cost = np.empty(n)
    tier = np.empty(n, dtype=np.int64)
    m = 0
    for y in range(h):
        for x in range(w):
            v = value[y, x]
            if not v >= thr32:
                continue
            a = nav[y, x]
            b = heur[y, x]
            if not (np.isfinite(a) and np.isfinite(b)):
                continue
            inner = 0
            for dy in range(-1, 2):
                for dx in range(-1, 2):
                    yy = y + dy
                    xx = x + dx
                    if yy < 0 or yy >= h or xx < 0 or xx >= w or not value[yy, xx] >= thr32:
                        inner = 1
            idx[m] = y * w + x
            cost[m] = (lam_n * a + np.float64(lam_m32 / v)) + lam_nh * b
            tier[m] = inner
            m += 1
    out = []
    for t in range(2):
        sel = np.empty(m, dtype=np.int64)
        c = 0
        for i in range(m):
            if tier[i] == t:
                sel[c] = i
                c += 1
        sel = sel[:c]
        order = np.argsort(cost[sel], kind="mergesort")[:k]  # stable: ties by index
        out.append((idx[sel[order]], cost[sel[order]]))
    return out[0][0], out[0][1], out[1][0], out[1][1]
