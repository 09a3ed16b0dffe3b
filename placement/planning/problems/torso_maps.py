"""A map at each of its lift settings: the views the planner's options are computed from (see
:mod:`placement.planning.torso`). Only maps here: the problems cache reads it."""

from __future__ import annotations

from collections.abc import Mapping

from placement.maps.rmap import ReachabilityMap
from placement.maps.torso import TorsoSettings


def torso_record(rmap: ReachabilityMap) -> TorsoSettings | None:
    """The map's torso record (joint, values and reference [m or rad], shift (None: one build per
    setting), velocity [m/s or rad/s]), or None for a map built at one torso value."""
    return rmap.torso


def map_variants(maps: Mapping[str, ReachabilityMap]) -> dict[str, tuple[ReachabilityMap, ...]]:
    """arm -> its map at every torso setting of its record (the map alone without one)."""
    out: dict[str, tuple[ReachabilityMap, ...]] = {}
    for arm, rmap in maps.items():
        record = torso_record(rmap)
        out[arm] = (rmap,) if record is None else tuple(rmap.at_torso(float(v)) for v in record.values)
    return out


def torso_value(rmap: ReachabilityMap) -> float | None:
    """The torso value [m or rad] a map (view) stands for; None for a map without a torso record."""
    value = rmap.torso_value
    return None if value is None else float(value)


__all__ = ["map_variants", "torso_record", "torso_value"]
