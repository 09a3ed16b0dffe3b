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
    ranked = []  # (tier, cost, option index, flat cell, base yaw)
    for k, o in enumerate(options):
        reach = (o.value >= config.threshold) & np.isfinite(nav_cost) & np.isfinite(heuristic)
        if not reach.any():
            continue
        c = np.full(nav_cost.shape, np.inf)
        c[reach] = combined_cost(config, nav_cost[reach], o.value[reach], heuristic[reach])
        np.minimum(best, c, out=best)
        inner = ndimage.minimum_filter(o.value, size=3, mode="constant", cval=0.0) >= config.threshold
        for tier, mask in ((0, reach & inner), (1, reach & ~inner)):
            flat = np.flatnonzero(mask)
            top = flat[np.argsort(c.flat[flat], kind="stable")[:config.ik_tries]]
            ranked += [(tier, float(c.flat[f]), k, int(f), float(yaws[o.yaw_index.flat[f]])) for f in top]
    ranked.sort(key=lambda r: (r[0], r[1], r[2], r[3]))
    return [Ranked(*r[1:]) for r in ranked], best
