"""Ranking base placements by the combined cost (paper Eq. 6), the order in which IK tries them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from .config import PlannerConfig
from .problems import Option


@dataclass(frozen=True)
class Ranked:
    """A placement to try: its ``cost`` (Eq. 6, or minus the manipulability for ``fixed``),
    ``option`` index into the step's options, ``cell`` (flat index into the grid), base ``yaw`` [rad]."""

    cost: float
    option: int
    cell: int
    yaw: float


def combined_cost(config: PlannerConfig, nav_cost, value, heuristic):
    """Eq. 6: ``lambda_n nav + lambda_m / m + lambda_nh heuristic`` (arrays or scalars; nav and
    heuristic in metres, m dimensionless)."""
    return config.lambda_n * nav_cost + config.lambda_m / value + config.lambda_nh * heuristic


def rank_by_cost(options: list[Option], nav_cost: np.ndarray, heuristic: np.ndarray, config: PlannerConfig,
                 yaws: np.ndarray) -> tuple[list[Ranked], np.ndarray]:
    """Placements of every option in the order IK should try them, and the combined cost map.

    Per option, the ``config.ik_tries`` cheapest cells whose 3 x 3 neighbourhood keeps the threshold
    come first (tier 0), then the cheapest frontier cells (tier 1): at the frontier of a map cell's
    reach the cell is reachable somewhere, not reliably at its centre. Within a tier: by cost, then
    option index, then cell. Returns (ranked, combined (ny, nx) with inf where infeasible).
    """
    best = np.full(nav_cost.shape, np.inf)
    nx = nav_cost.shape[1]
    ranked = []  # (tier, cost, option index, flat cell, base yaw)
    for k, o in enumerate(options):
        win = o.window.slices
        nav_w, heur_w = nav_cost[win], heuristic[win]
        reach = (o.value >= config.threshold) & np.isfinite(nav_w) & np.isfinite(heur_w)
        if not reach.any():
            continue
        c = np.full(o.value.shape, np.inf)
        c[reach] = combined_cost(config, nav_w[reach], o.value[reach], heur_w[reach])
        np.minimum(best[win], c, out=best[win])
        # the window holds one cell of zeros around the reach, so the filter sees what it would
        # see on the whole grid
        inner = ndimage.minimum_filter(o.value, size=3, mode="constant", cval=0.0) >= config.threshold
        for tier, mask in ((0, reach & inner), (1, reach & ~inner)):
            flat = np.flatnonzero(mask)
            top = flat[np.argsort(c.flat[flat], kind="stable")[:config.ik_tries]]
            cells = o.window.to_global(top, nx)
            ranked += [(tier, float(c.flat[f]), k, int(g), float(yaws[o.yaw_index.flat[f]]))
                       for f, g in zip(top, cells)]
    ranked.sort(key=lambda r: (r[0], r[1], r[2], r[3]))
    return [Ranked(*r[1:]) for r in ranked], best
