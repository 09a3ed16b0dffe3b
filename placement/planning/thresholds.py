"""The map threshold of each arm: resolved once at load, applied per option.

A map value means different things on different arms, so the threshold is by default a quantile of
each arm's own non-zero map values (``planner.threshold_quantile``, see
:mod:`placement.maps.quantiles`); a scene's ``planner.threshold`` is a map value used on every arm.
The planner resolves either into one value per arm (:func:`resolve_thresholds`) and keeps them on the
planning context; ``PlannerConfig.threshold`` then holds the smallest of them, for the code that
needs one number (messages) and for :func:`per_arm_values`, which lets a single-threshold ranking
apply every arm's own.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from placement.maps.rmap import ReachabilityMap
from placement.planning.config import PlannerConfig
from placement.planning.option import Option


def resolve_thresholds(config: PlannerConfig, maps: Mapping[str, ReachabilityMap]) -> dict[str, float]:
    """arm -> its threshold (map value, dimensionless): ``config.threshold`` on every arm when the scene
    gave it (``threshold_quantile`` None), else each map's value at ``threshold_quantile``."""
    q = config.threshold_quantile
    if q is None:
        return {arm: float(config.threshold) for arm in maps}
    # > 0 (a quantile of positive values): cells an arm does not reach (value 0) stay infeasible
    return {arm: rmap.quantile_value(q) for arm, rmap in maps.items()}


def with_threshold(config: PlannerConfig, thresholds: Mapping[str, float]) -> PlannerConfig:
    """``config`` with ``threshold`` the smallest of ``thresholds`` (unchanged when there are none)."""
    return replace(config, threshold=min(thresholds.values())) if thresholds else config


def per_arm_values(options: Sequence[Option], thresholds: Mapping[str, float], floor: float) -> list[Option]:
    """``options`` with each value below its arm's threshold set to 0, for code that applies one
    threshold ``floor`` (the smallest arm's, > 0) to every option (the Eq. 6 ranking): it then keeps
    exactly the cells each arm's own threshold keeps. The options themselves when no arm's threshold
    lies above ``floor``."""
    out = list(options)
    for k, o in enumerate(out):
        t = thresholds.get(o.arm, floor)
        if t > floor:
            out[k] = replace(o, value=np.where(o.value >= np.float32(t), o.value, np.float32(0)))
    return out


__all__ = ["per_arm_values", "resolve_thresholds", "with_threshold"]
