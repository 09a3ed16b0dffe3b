"""Ranking base placements by the combined cost (paper Eq. 6), the order in which IK tries them."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple, TypeAlias

import numpy as np
import numpy.typing as npt

from placement.kernels.ranking import rank_window
from placement.planning.arrays import FloatArray
from placement.planning.problems import Option
from placement.planning.settings import PlannerConfig

#: Eq. 6 terms and costs: float arrays (map values float32, costs float64) of one shape.
Costs: TypeAlias = npt.NDArray[np.floating[Any]]


class Ranked(NamedTuple):
    """A placement to try: its ``cost`` (Eq. 6, or minus the manipulability for ``fixed``),
    ``option`` index into the step's options, ``cell`` (flat index into the grid), base ``yaw`` [rad]."""

    cost: float
    option: int
    cell: int
    yaw: float


def combined_cost(config: PlannerConfig, nav_cost: Costs, value: Costs, heuristic: Costs) -> Costs:
    """Eq. 6: ``lambda_n nav + lambda_m / m + lambda_nh heuristic`` (arrays of one shape; nav and
    heuristic in metres, m dimensionless)."""
    out: Costs = config.lambda_n * nav_cost + config.lambda_m / value + config.lambda_nh * heuristic
    return out


def combined_map(
    options: Sequence[Option], nav_cost: FloatArray, heuristic: FloatArray, config: PlannerConfig
) -> FloatArray:
    """(ny, nx) Eq. 6 cost of the best option per cell (inf where none keeps the threshold), for plots."""
    best = np.full(nav_cost.shape, np.inf)
    for o in options:
        win = o.window.slices
        reach = (o.value >= config.threshold) & np.isfinite(nav_cost[win]) & np.isfinite(heuristic[win])
        c = np.full(o.value.shape, np.inf)
        c[reach] = combined_cost(config, nav_cost[win][reach], o.value[reach], heuristic[win][reach])
        np.minimum(best[win], c, out=best[win])
    return best


def rank_by_cost(
    options: Sequence[Option],
    nav_cost: FloatArray,
    heuristic: FloatArray,
    config: PlannerConfig,
    yaws: FloatArray,
    stop: Callable[[], None] | None = None,
) -> list[Ranked]:
    """Placements of every option in the order IK should try them.

    Per option, the ``config.ik_tries`` cheapest cells whose 3 x 3 neighbourhood keeps the threshold
    come first (tier 0), then the cheapest frontier cells (tier 1): at the frontier of a map cell's
    reach the cell is reachable somewhere, not reliably at its centre. Within a tier: by cost, then
    option index, then cell. ``stop``: called every 64 options (a task's budget check, raising to end
    the work: thousands of options, 360 grasp yaws per object, take seconds to rank).
    """
    nx = nav_cost.shape[1]
    thr32, lam_m32 = np.float32(config.threshold), np.float32(config.lambda_m)
    ranked = []  # (tier, cost, option index, flat cell, base yaw)
    for k, o in enumerate(options):
        if stop is not None and k % 64 == 63:
            stop()
        win = o.window.slices
        i0, c0, i1, c1 = rank_window(
            o.value,
            np.ascontiguousarray(nav_cost[win]),
            np.ascontiguousarray(heuristic[win]),
            thr32,
            float(config.lambda_n),
            lam_m32,
            float(config.lambda_nh),
            config.ik_tries,
        )
        for tier, local, costs in ((0, i0, c0), (1, i1, c1)):
            cells = o.window.to_global(local, nx)
            yaw_idx = o.yaw_index.ravel()[local]
            ranked += [(tier, float(c), k, int(g), float(yaws[j])) for c, g, j in zip(costs, cells, yaw_idx)]
    ranked.sort(key=lambda r: (r[0], r[1], r[2], r[3]))
    return [Ranked(*r[1:]) for r in ranked]
